#pragma once
/// The GQ-CNN policy of strategy=gqcnn (docs/gqcnn.md), Dex-Net 2.0's on one depth image:
/// antipodal candidates from depth edges, each cropped grasp-aligned (CropGrasp) and ranked by a
/// grasp-quality function (the trained GQ-CNN), then refined by the cross-entropy method.
///
///   gqcnn::PolicyParams params;
///   auto plan = gqcnn::PlanGqcnnGrasps(scene, camera, gripper, params,
///       [&](std::span<const float> crops, std::span<const float> depths,
///           std::span<const float> clearances) {
///         return model.Predict(crops, depths, clearances);
///       });
///
/// Units: metres, pixels of the input image, radians; poses in the camera frame C.

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "service/core/contact_check.h"
#include "service/core/depth.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"
#include "service/core/status.h"
#include "service/gqcnn/crop.h"

namespace softgrasp::gqcnn {

/// P(success) in [0, 1] for n crops (n x kCropPixels, CropGrasp's convention), their n grasp
/// depths and their gripper clearances (n x 3: jaws, palm, floor, as MeasureClearance gives them
/// on the scene; clearance.h). Must return exactly n values.
using QualityFunction = std::function<std::vector<float>(std::span<const float> crops_depth_m,
                                                         std::span<const float> grasp_depths_m,
                                                         std::span<const float> clearances_m)>;

struct PolicyParams {
  /// Antipodal candidates scored before refinement (Dex-Net CEM: 250).
  int seed_samples = 250;
  /// Cross-entropy refinement: rounds, new samples per round, the best fraction refitted.
  int cem_iterations = 3;
  int cem_samples = 50;
  double cem_elite_fraction = 0.25;
  /// Antipodality of an edge pair in the image plane (Dex-Net's depth sampler: 0.8).
  double friction_coefficient = 0.8;
  /// An edge pixel's depth gradient after a sigma-1 px Gaussian, metres per pixel (Dex-Net).
  double depth_gradient_threshold_m = 0.0025;
  /// How far below the highest surface between the contacts the grasp centre goes (Dex-Net's
  /// depth offsets).
  double min_depth_offset_m = 0.005;
  double max_depth_offset_m = 0.04;
  /// Contacts closer than this in metres are one point (Dex-Net's min_contact_dist).
  double min_contact_distance_m = 0.0025;
  /// Edge pixels paired (randomly chosen when there are more): pairs cost its square.
  int max_edge_pixels = 1000;
  /// The crop covers 96 px of a camera with this focal length (the dataset's); other cameras
  /// crop 96 * fx / training_fx_px pixels so the crop spans the same angle.
  double training_fx_px = 525.0;
  int source_crop_px = 96;
  /// Candidates the gripper would not reach are dropped before scoring: gqcnn::ClearanceRule
  /// on gqcnn::MeasureClearance (clearance.h; a surface above the floor under a finger is nearer
  /// than the fingertips, or under the palm nearer than its face: the object is wider than the
  /// stroke there or a neighbour is in the way). The dataset's records carry the same check, so
  /// a network can be trained on the grasps it admits (`--admitted-only`). Dex-Net 2.0 leaves
  /// this to the network; ours learns it too weakly (docs/gqcnn.md).
  bool check_clearance = true;
  /// Candidates whose fingers, closing at the grasp depth, would not meet faces that hold are
  /// dropped: core::CheckContacts (FGE's contact check: a patch of at least 5 mm on each
  /// finger) and core::ContactFacesSteep (the faces at the fingertips steep enough for the
  /// gripper's friction cone). Firm contacts rank before stable ones whatever the network says.
  /// Slanted faces, corners and rounded tops slip (docs/gqcnn.md, "Contacts that hold").
  bool check_contacts = true;
  /// Grasps returned, best first, after suppressing near-duplicates.
  int num_grasps = 10;
  std::uint64_t seed = 0;
};

/// Errors (kInvalidArgument naming the field) for values out of range; nullopt when valid.
std::optional<core::Error> ValidatePolicyParams(const PolicyParams& params);

struct PolicyGrasp {
  core::Grasp grasp;  ///< score = predicted quality
  GraspImagePose image_pose;
  float quality = 0.0F;
  /// The contact check's verdict (kFirm for every grasp when check_contacts is off).
  core::ContactHold contacts = core::ContactHold::kFirm;
};

struct PolicyTimings {
  double sample_ms = 0.0;    ///< edges, pairs, seed candidates
  double evaluate_ms = 0.0;  ///< crops and the quality function, all rounds
  double total_ms = 0.0;
};

struct PolicyPlan {
  std::vector<PolicyGrasp> grasps;  ///< best first
  int edge_pixels = 0;              ///< before subsampling
  int antipodal_pairs = 0;          ///< found among the paired edge pixels
  int evaluated = 0;                ///< crops scored, all rounds
  PolicyTimings timing;
};

/// Plans on a preprocessed scene (depth_filled_m, floor, contact_allowed). No antipodal pair is
/// not an error: the plan has no grasps. Errors: ValidatePolicyParams'; kInternal when `quality`
/// returns the wrong count or a value outside [0, 1] or NaN.
core::Result<PolicyPlan> PlanGqcnnGrasps(const core::Scene& scene, const core::Camera& camera,
                                         const core::Gripper& gripper, const PolicyParams& params,
                                         const QualityFunction& quality);

}  // namespace softgrasp::gqcnn
