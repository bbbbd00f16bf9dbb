#pragma once
/// strategy=gqcnn: Dex-Net 2.0's policy, antipodal candidates from depth edges ranked by the
/// GQ-CNN and refined by the cross-entropy method (gqcnn::PlanGqcnnGrasps; docs/gqcnn.md).

#include "service/core/contact_check.h"
#include "service/engine/strategy.h"
#include "service/gqcnn/policy.h"

namespace softgrasp::engine {

struct GqcnnOptions final : StrategyOptions {
  /// Sampling and refinement; `policy.num_grasps` is replaced by the request's top_k.
  gqcnn::PolicyParams policy;
};

/// What strategy=gqcnn adds to each grasp.
struct GqcnnGraspRecord final : GraspDetails {
  /// The grasp's image pose as the network saw it (depth = z of the grasp centre, metres).
  gqcnn::GraspImagePose pose;
  /// The contact check's verdict (firm grasps rank first).
  core::ContactHold contacts = core::ContactHold::kFirm;
  /// P(success) (the grasp's score) at or above the model's decision threshold.
  bool predicted_success = false;
};

/// What strategy=gqcnn did.
struct GqcnnStats final : PlanDetails {
  int edge_pixels = 0;
  int antipodal_pairs = 0;
  int evaluated = 0;  ///< crops the network scored
  double sample_ms = 0;
  double evaluate_ms = 0;
  /// The model's decision threshold (models::GqcnnModel::decision_threshold).
  double decision_threshold = 0.5;
};

/// The record of a strategy=gqcnn grasp; null for another strategy's.
const GqcnnGraspRecord* GqcnnRecordOf(const PlannedGrasp& grasp);
/// The statistics of a strategy=gqcnn plan; null for another strategy's.
const GqcnnStats* GqcnnStatsOf(const Plan& plan);

const Strategy& GqcnnStrategy();

}  // namespace softgrasp::engine
