#include "service/engine/strategies/fge.h"

#include "service/core/fge.h"
#include "service/core/fge_stiffness.h"

namespace softgrasp::engine {
namespace {

class Fge final : public Strategy {
 public:
  const StrategyInfo& info() const override {
    static const StrategyInfo info{
        "fge", "FGE: grasps at the centre of the contact surface (graspability)",
        false, false,
        false, false,
        true};
    return info;
  }

  std::optional<core::Error> Plan(const PlanContext& c, const StrategyOptions* /*options*/,
                                  engine::Plan* plan) const override {
    for (const core::Grasp& g :
         core::DetectGraspsFge(c.scene, c.camera, c.options.gripper, c.options.fge)) {
      PlannedGrasp p;
      p.grasp = g;
      if (!c.stiffness.empty()) {
        p.grasp.mean_stiffness = core::ContactMeanStiffness(c.scene, c.stiffness, g);
      }
      plan->grasps.push_back(std::move(p));
    }
    return std::nullopt;
  }
};

}  // namespace

const Strategy& FgeStrategy() {
  static const Fge strategy;
  return strategy;
}

}  // namespace softgrasp::engine
