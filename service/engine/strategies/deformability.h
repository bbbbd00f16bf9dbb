#pragma once
/// strategy=deformability: Algorithm 1 on one target object with the segmentation model's
/// deformability map; the target is chosen by a policy or named by the request
/// (core::DetectGraspsDeformability; docs/deformability.md).

#include <vector>

#include "service/core/fge_deformability.h"
#include "service/engine/strategy.h"

namespace softgrasp::engine {

struct DeformabilityOptions final : StrategyOptions {
  /// K, L, M, R and the rest; `params.fge` and `params.target_id` are replaced by the request's.
  core::DeformabilityParams params;
};

/// What strategy=deformability knows about one of its grasps.
struct DeformabilityRecord final : GraspDetails {
  core::TargetPolicy policy = core::TargetPolicy::kHighest;
  const char* target_by = "policy";  ///< "policy", "request" or "fallback"
  double opening_fraction = 1.0;
  double mean_deformability = 0.0;  ///< NaN when unknown
  std::vector<int> pressed_ids;     ///< soft neighbours the fingers press aside
  double press_depth_m = 0.0;
};

/// The target strategy=deformability chose.
struct TargetChoice final : PlanDetails {
  int id = 0;  ///< 0 = none (no grasp, or the whole-scene fallback)
  core::TargetPolicy policy = core::TargetPolicy::kHighest;
  std::vector<int> tried_ids;
  bool fallback = false;
  /// The target's low-contrast soft-looking pixels were allowed as contact (no grasp kept out of
  /// them; core::DeformabilityResult::soft_part_allowed).
  bool soft_part_allowed = false;
};

/// The record of a strategy=deformability grasp; null for another strategy's.
const DeformabilityRecord* DeformabilityRecordOf(const PlannedGrasp& grasp);
/// The target a strategy=deformability plan chose; null for another strategy's.
const TargetChoice* TargetChoiceOf(const Plan& plan);

const Strategy& DeformabilityStrategy();

}  // namespace softgrasp::engine
