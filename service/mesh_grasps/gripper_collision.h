#pragma once
/// Collision checks of an open parallel-jaw gripper moving in along its approach against a mesh
/// and a table, after Dex-Net 2.0's `collides_along_approach` (REFERENCE §1.6), with FCL.
///
/// Why FCL and not Embree rays: the question is whether two solids overlap, not what a ray sees.
/// FCL (Debian's libfcl-dev) tests a box against the mesh's bounding-volume hierarchy exactly,
/// triangle by triangle, so a thin rim or a spike between two sample rays is never missed, and it
/// needs no tuning of a ray density. Dex-Net steps the gripper mesh back along the approach in
/// 21 poses; here the path of each box is one longer box (the swept volume of a box moving along
/// one of its own axes), so a path costs three box tests and has no gaps between steps.
///
/// Gripper frame G (the convention of core::Grasp): origin at the grasp centre (midway between
/// the contacts), x = closing axis, z = approach (from the palm towards the fingertips, into the
/// object), y = z x x. Units: metres and radians.

#include <Eigen/Geometry>
#include <memory>
#include <vector>

#include "service/core/grasp.h"
#include "service/core/status.h"
#include "service/mesh/mesh.h"
#include "service/mesh_grasps/antipodal.h"
#include "service/mesh_grasps/stable_poses.h"

namespace softgrasp::mesh {

/// The gripper as three boxes, open: two jaws whose inner faces are `opening_m` apart and a palm
/// behind them spanning both.
struct GripperBoxes {
  double opening_m = 0.05;            ///< inner faces at x = +-opening/2 while approaching
  double finger_width_m = 0.015;      ///< along y
  double finger_thickness_m = 0.008;  ///< along x
  double finger_length_m = 0.04;      ///< along z, from the palm to the fingertip
  /// How far the fingertips reach past the grasp centre along +z (the contact sits this far up the
  /// finger pad).
  double fingertip_depth_m = 0.005;
  double palm_thickness_m = 0.02;  ///< along z, behind the fingers

  /// The jaws and palm of `gripper` (opening = its stroke); the last two fields keep their
  /// defaults, which core::Gripper does not describe.
  static GripperBoxes From(const core::Gripper& gripper);
};

/// An axis-aligned box of G: centre and half sizes, metres.
struct BoxInG {
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_extent_m = Eigen::Vector3d::Zero();
};

/// The three boxes the gripper sweeps while it moves from `approach_distance_m` back along -z to
/// its grasp pose: each box is extended backwards by the distance. Order: +x jaw, -x jaw, palm.
/// @throws std::invalid_argument for non-positive or non-finite sizes or a negative distance.
std::vector<BoxInG> SweptGripperBoxes(const GripperBoxes& gripper, double approach_distance_m);

/// The table in the object frame O: the plane a stable pose rests on, pushed `clearance_m` into
/// the table (Dex-Net lets the gripper sink 5 mm, its `table_offset`). A point p is inside the
/// table when down_o . p > offset_m.
struct TableInObject {
  Eigen::Vector3d down_o = -Eigen::Vector3d::UnitZ();  ///< unit, from the object into the table
  double offset_m = 0.0;

  /// The table under `pose` (its face normal points into the table), lowered by clearance_m.
  static TableInObject Under(const StablePose& pose, double clearance_m);
};

/// The approach a top-down arm would use for `grasp` resting in `pose`: the table's downward
/// normal, in O, made perpendicular to the grasp axis; and the angle between the two (0 when the
/// axis is parallel to the table). When the axis is vertical any perpendicular is returned and
/// the angle is pi/2.
struct TopDownApproach {
  Eigen::Vector3d approach_o = -Eigen::Vector3d::UnitZ();
  double table_angle_rad = 0.0;
};
TopDownApproach ApproachFromAbove(const JawGrasp& grasp, const StablePose& pose);

/// object_from_gripper for a jaw grasp with a given approach (perpendicular to its axis; it is
/// re-orthogonalised).
Eigen::Isometry3d GripperPose(const JawGrasp& grasp, const Eigen::Vector3d& approach_o);

/// The approach of `approach_o` turned by `angle_rad` about the grasp axis (Dex-Net's approach
/// offsets).
Eigen::Vector3d RotateApproach(const JawGrasp& grasp, const Eigen::Vector3d& approach_o,
                               double angle_rad);

/// An immutable FCL bounding-volume hierarchy of one mesh in O. Thread-safe for concurrent
/// queries once built.
class GripperCollisionChecker {
 public:
  /// Errors: kInvalidArgument for an empty mesh, out-of-range indices or non-finite vertices
  /// (field "mesh"), and for gripper sizes that are not positive and finite (field "gripper").
  static core::Result<GripperCollisionChecker> Build(const TriangleMesh& mesh_o,
                                                     const GripperBoxes& gripper,
                                                     double approach_distance_m);

  GripperCollisionChecker(GripperCollisionChecker&&) noexcept;
  GripperCollisionChecker& operator=(GripperCollisionChecker&&) noexcept;
  ~GripperCollisionChecker();

  /// True when the open gripper, moving along +z of `object_from_gripper` from the approach
  /// distance back to that pose, overlaps the mesh or (when given) enters the table.
  bool Collides(const Eigen::Isometry3d& object_from_gripper,
                const TableInObject* table = nullptr) const;

 private:
  struct Impl;
  explicit GripperCollisionChecker(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace softgrasp::mesh
