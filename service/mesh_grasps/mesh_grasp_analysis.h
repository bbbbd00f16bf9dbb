#pragma once
/// The whole Dex-Net 2.0 style analysis of one rigid mesh (docs/mesh-grasps.md): its stable poses
/// on a table, antipodal jaw grasps, their force closure and (robust) Ferrari-Canny quality, and
/// for every grasp in every pose whether a top-down gripper reaches it without touching the
/// object or the table. Also a depth picture of a pose for previews. What POST /v1/meshes/grasps
/// and `softgrasp-sim mesh-grasps` answer.
///
/// Units: metres and radians; grasps in the mesh's frame O, poses as table_from_object.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "service/core/depth.h"
#include "service/core/grasp.h"
#include "service/core/status.h"
#include "service/mesh/mesh.h"
#include "service/mesh/mesh_io.h"
#include "service/mesh/mesh_prepare.h"
#include "service/mesh_grasps/antipodal.h"
#include "service/mesh_grasps/grasp_quality.h"
#include "service/mesh_grasps/gripper_collision.h"
#include "service/mesh_grasps/stable_poses.h"

namespace softgrasp::mesh {

struct MeshGraspOptions {
  GripperBoxes gripper;               ///< its opening is the sampler's stroke
  double friction_coefficient = 0.5;  ///< mu of sampling, force closure and quality
  int num_grasps = 100;               ///< target number of antipodal grasps, >= 1
  /// Robust Ferrari-Canny samples per grasp (Dex-Net: 25); 0 skips the robust metric.
  int robust_samples = 25;
  std::uint64_t seed = 0;
  /// Stable poses at or below this probability are dropped (Dex-Net's database: 0.01).
  double min_pose_probability = 0.01;
  /// REFERENCE §1.6: the gripper moves in from this far back along its approach...
  double approach_distance_m = 0.1;
  /// ...and may sink this far into the table (Dex-Net's table_offset).
  double table_clearance_m = 0.005;
  /// A grasp is aligned with a pose when its top-down approach is within this angle of vertical.
  double max_approach_table_angle_rad = 5.0 * 3.14159265358979323846 / 180.0;
  /// Approach offsets about the grasp axis tried in this order; a grasp is collision-free in a
  /// pose when any of them is (Dex-Net: -10, -5, 0, 5, 10 degrees).
  std::vector<double> approach_offsets_rad = {0.0, -0.0872664626, 0.0872664626, -0.1745329252,
                                              0.1745329252};
  /// Quality parameters besides mu (cone faces, torque scaling, soft fingers) and noise.
  QualityParams quality;
  RobustParams robust;
};

/// One grasp seen in one stable pose.
struct GraspInPose {
  double approach_table_angle_rad = 0.0;  ///< of the top-down approach (0 = vertical)
  bool aligned = false;                   ///< approach_table_angle <= max_approach_table_angle
  bool collision_free = false;  ///< some approach offset reaches the grasp without contact
  /// The first collision-free offset and its approach in O; unset when none is.
  std::optional<double> approach_offset_rad;
  Eigen::Vector3d approach_o = -Eigen::Vector3d::UnitZ();  ///< offset's, else the nominal one
};

struct AnalysedGrasp {
  JawGrasp grasp;
  int sample_index = 0;        ///< position in sampling order (ties keep this order)
  double ferrari_canny = 0.0;  ///< nominal grasp, nominal friction
  /// Mean over the robust samples; equals ferrari_canny's definition with noise (unset when
  /// robust_samples is 0).
  std::optional<double> robust_ferrari_canny;
  std::vector<GraspInPose> poses;  ///< one per kept stable pose, same order
};

struct MeshGraspTiming {
  double stable_poses_ms = 0.0;
  double sampling_ms = 0.0;
  double quality_ms = 0.0;
  double collisions_ms = 0.0;
  double total_ms = 0.0;
};

/// Why an analysis has no grasp the gripper can use, checked in this order.
enum class NoGraspReason {
  /// The object is wider than the stroke in every direction: no two surface points the open jaws
  /// can reach face each other.
  kWiderThanStroke,
  /// It fits the stroke, but no two surface points within it face each other inside the friction
  /// cone (a higher friction_coefficient or another stroke may find some).
  kNoAntipodalPair,
  /// Antipodal grasps exist, but none is in force closure at this friction (quality 0).
  kNoForceClosure,
  /// Grasps in force closure exist, but in every stable pose each is either not approachable
  /// from above or collides with the table or the gripper's body on the way in.
  kCollidesInEveryPose,
};
const char* NoGraspReasonName(NoGraspReason reason);  ///< "wider_than_stroke", ...

struct NoGrasp {
  NoGraspReason reason = NoGraspReason::kWiderThanStroke;
  std::string message;  ///< says what was found and what would help
  /// The object's narrowest width over all directions (its vertices' extent), metres.
  double narrowest_width_m = 0.0;
  /// When the narrowest width exceeds the stroke (always for kWiderThanStroke): the stroke it
  /// needs, rounded up to the millimetre.
  std::optional<double> needed_stroke_m;
};

struct MeshGraspAnalysis {
  Eigen::Vector3d center_of_mass_m = Eigen::Vector3d::Zero();  ///< volume centroid, O
  std::vector<StablePose> poses;                               ///< most probable first
  /// Best first: by robust quality when computed (else nominal), ties in sampling order.
  std::vector<AnalysedGrasp> grasps;
  /// Set when no grasp is usable: none sampled, none in force closure, or none aligned and free
  /// of collisions in any stable pose.
  std::optional<NoGrasp> no_grasp;
  MeshGraspTiming timing;
};

/// The narrowest width of the mesh's vertices over all directions: the least extent
/// max(v . d) - min(v . d), searched from dense directions and refined locally (to about 1e-5 rad).
double NarrowestWidthM(const TriangleMesh& mesh);

/// Why `analysis` (its grasps analysed in its poses with `options`) has no usable grasp; nullopt
/// when some grasp is in force closure, aligned and free of collisions in some pose.
std::optional<NoGrasp> WhyNoGrasp(const TriangleMesh& mesh, const MeshGraspAnalysis& analysis,
                                  const MeshGraspOptions& options);

/// Analyses a closed, outward-oriented mesh (check it first, e.g. with PrepareMesh). Errors:
/// kInvalidArgument naming the option out of range; kUnprocessable when the mesh has no stable
/// pose above the threshold or no volume; whatever the stages report for degenerate meshes.
core::Result<MeshGraspAnalysis> AnalyseMeshGrasps(const TriangleMesh& mesh_o,
                                                  const MeshGraspOptions& options);

/// A mesh file analysed: decoded (any format ReadMesh reads), prepared (repaired, checked, in
/// metres, optionally rescaled), then AnalyseMeshGrasps.
struct MeshFileJob {
  PrepareOptions prepare;  ///< its max_triangles also bounds the decoder
  MeshGraspOptions analysis;
};

struct MeshFileAnalysis {
  MeshFormat format = MeshFormat::kObj;
  PreparedMesh prepared;
  MeshGraspAnalysis analysis;
  double decode_ms = 0.0;
  double prepare_ms = 0.0;
};

/// Errors: ReadMesh's (415 unknown format, 400 malformed, 413 too large), PrepareMesh's (413 too
/// many triangles, 422 not closed, non-manifold, several pieces, degenerate, ...), then
/// AnalyseMeshGrasps'.
core::Result<MeshFileAnalysis> AnalyseMeshFile(std::string_view bytes, const MeshFileJob& job);

/// A depth picture of the mesh resting in `pose` on the table, from straight above: the camera
/// looks down the table's -z at the centre of mass and is placed so that the object's bounding
/// sphere fills about 80 % of the image's shorter side. The table is not drawn (NaN around).
struct PoseView {
  core::DepthImage depth;
  core::Camera camera;
  Eigen::Isometry3d table_from_camera = Eigen::Isometry3d::Identity();
  /// The grasps aligned and collision-free in this pose, best first, as the planners' top-down
  /// grasps in this camera (pixel footprint, closing angle, opening = the grasp's width: the
  /// fingers drawn at the contacts).
  std::vector<core::Grasp> grasps;
};

/// Renders `analysis.poses[pose_index]` with the first `max_grasps` usable grasps. `size_px` is
/// the image's width and height. Errors: kInvalidArgument for a pose index out of range or a size
/// outside [16, 4096].
core::Result<PoseView> RenderPoseView(const TriangleMesh& mesh_o, const MeshGraspAnalysis& analysis,
                                      int pose_index, const GripperBoxes& gripper,
                                      int size_px = 480, int max_grasps = 10);

}  // namespace softgrasp::mesh
