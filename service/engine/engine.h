#pragma once
/// The planning engine: one call from a decoded depth image, its camera, the options and the
/// loaded models to the scene, the maps it computed, ranked grasps and timings. The REST handler
/// and the evaluation tools call it alike. Strategies are rooms (strategy.h,
/// service/engine/strategies/); the engine dispatches on them by name.
///
///   engine::PlanOptions options;
///   options.strategy = "stiffness";
///   auto plan = engine::PlanGrasps(depth, camera, options, {stiffness_model, nullptr});
///   if (!plan.ok()) return plan.error();
///   for (const engine::PlannedGrasp& g : plan.value().grasps) ...

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "service/core/depth.h"
#include "service/core/preprocess.h"
#include "service/core/status.h"
#include "service/engine/instances.h"
#include "service/engine/plan.h"
#include "service/engine/strategy.h"

namespace softgrasp::engine {

/// Every registered strategy, in order of preference (AllStrategies()).
const std::vector<const Strategy*>& Strategies();
/// The registered strategy of this name; null when none.
const Strategy* FindStrategy(std::string_view name);
/// The same, or kInvalidArgument (field "strategy") listing the registered names.
core::Result<const Strategy*> StrategyNamed(std::string_view name);
/// Whether `models` has what `strategy` needs.
bool Serves(const Models& models, const Strategy& strategy);
/// The last strategy the loaded models serve.
const Strategy& DefaultStrategy(const Models& models);
/// The names of the strategies `models` serve, in Strategies() order.
std::vector<std::string> ServedStrategies(const Models& models);

/// Checks the options (the strategy's name, the models it needs, FGE's search and the gripper,
/// the strategy's own options), preprocesses the depth, finds instances when something uses
/// them, applies the contact region (contact_region.h), runs the models the strategy, the options
/// and the wanted maps need, and plans. Errors: kInvalidArgument naming the field for options
/// out of range or a strategy the models do not serve ("strategy"; "mean_stiffness" when no
/// stiffness model is loaded for it), kUnprocessable for a segmask of another size, and
/// core::Preprocess's and InstancesForPlan's.
/// @throws std::invalid_argument if options.strategy_options is not of the strategy's type.
core::Result<Plan> PlanGrasps(const core::DepthImage& depth, const core::Camera& camera,
                              const PlanOptions& options, const Models& models);

/// What a segmentation (POST /v1/segmentation) asks for.
struct SegmentOptions {
  /// The segmenter; unset: the model when one is loaded, else pcl.
  std::optional<segmentation::Method> method;
  /// Describe every instance (DescribeSceneInstances; with the stiffness model's mean when one
  /// is loaded).
  bool describe = false;
};

struct SegmentTimings {
  double preprocess_ms = 0;
  double segment_ms = 0;
  double stiffness_ms = 0;  ///< 0 when the stiffness model did not run
  double describe_ms = 0;   ///< describing, the stiffness model's time excluded
};

struct Segmentation {
  core::Scene scene;  ///< preprocessed
  SceneInstances instances;
  std::vector<segmentation::InstanceInfo> described;  ///< filled when options.describe
  SegmentTimings timing;
};

/// Preprocesses the depth and segments it into object instances. Errors: core::Preprocess's
/// (kUnprocessable), ResolveSegmentationMethod's (field "method") and SegmentInstances'.
core::Result<Segmentation> Segment(const core::DepthImage& depth, const core::Camera& camera,
                                   const SegmentOptions& options, const Models& models);

}  // namespace softgrasp::engine
