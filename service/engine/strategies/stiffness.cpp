#include "service/engine/strategies/stiffness.h"

namespace softgrasp::engine {
namespace {

core::StiffnessFgeParams ParamsFor(const StrategyOptions* options, const PlanOptions& common) {
  core::StiffnessFgeParams params = OptionsOr<StiffnessOptions>(options).params;
  params.fge = common.fge;
  return params;
}

class Stiffness final : public Strategy {
 public:
  const StrategyInfo& info() const override {
    static const StrategyInfo info{
        "stiffness", "stiffness-aware FGE: grasps on the stiffest contact surfaces of the map",
        true,        false,
        false,       false,
        true};
    return info;
  }

  std::shared_ptr<StrategyOptions> DefaultOptions() const override {
    return std::make_shared<StiffnessOptions>();
  }

  std::optional<core::Error> Validate(const StrategyOptions* options, const PlanOptions& common,
                                      const core::Camera& camera) const override {
    return core::ValidateStiffnessFgeInputs(camera, common.gripper, ParamsFor(options, common));
  }

  std::optional<core::Error> Plan(const PlanContext& c, const StrategyOptions* options,
                                  engine::Plan* plan) const override {
    for (const core::Grasp& g : core::DetectGraspsStiffness(
             c.scene, c.camera, c.stiffness, c.options.gripper, ParamsFor(options, c.options))) {
      PlannedGrasp p;
      p.grasp = g;
      plan->grasps.push_back(std::move(p));
    }
    return std::nullopt;
  }
};

}  // namespace

const Strategy& StiffnessStrategy() {
  static const Stiffness strategy;
  return strategy;
}

}  // namespace softgrasp::engine
