#include "service/engine/strategies/gqcnn.h"

#include <span>

namespace softgrasp::engine {
namespace {

using Fields = FieldsOf<GqcnnOptions>;

class Gqcnn final : public Strategy {
 public:
  const StrategyInfo& info() const override {
    static const StrategyInfo info{
        "gqcnn", "Dex-Net 2.0's policy: antipodal candidates ranked by the GQ-CNN, CEM-refined",
        false,   false,
        true,    false,
        false};
    return info;
  }

  const std::vector<StrategyField>& fields() const override {
    static const std::vector<StrategyField> fields = {
        Fields::Integer(
            "gqcnn_seed_samples", "", 1, 10000, "antipodal candidates scored before refinement",
            [](auto& o) -> auto& { return o.policy.seed_samples; }),
        Fields::Integer(
            "cem_iterations", "", 0, 20, "cross-entropy rounds",
            [](auto& o) -> auto& { return o.policy.cem_iterations; }),
        Fields::Integer(
            "cem_samples", "", 1, 10000, "new candidates per round",
            [](auto& o) -> auto& { return o.policy.cem_samples; }),
        Fields::Integer(
            "gqcnn_seed", "", 0, 9007199254740991.0, "sampling seed (same seed, same grasps)",
            [](auto& o) -> auto& { return o.policy.seed; }),
    };
    return fields;
  }

  std::shared_ptr<StrategyOptions> DefaultOptions() const override {
    return std::make_shared<GqcnnOptions>();
  }

  std::optional<core::Error> Validate(const StrategyOptions* options, const PlanOptions& /*common*/,
                                      const core::Camera& /*camera*/) const override {
    return gqcnn::ValidatePolicyParams(OptionsOr<GqcnnOptions>(options).policy);
  }

  std::optional<core::Error> Plan(const PlanContext& c, const StrategyOptions* options,
                                  engine::Plan* plan) const override {
    gqcnn::PolicyParams params = OptionsOr<GqcnnOptions>(options).policy;
    params.num_grasps = c.options.fge.top_k;
    const models::GqcnnModel& model = *c.models.gqcnn;
    auto planned =
        gqcnn::PlanGqcnnGrasps(c.scene, c.camera, c.options.gripper, params,
                               [&model](std::span<const float> crops, std::span<const float> depths,
                                        std::span<const float> clearances) {
                                 return model.Predict(crops, depths, clearances);
                               });
    if (!planned.ok()) return planned.error();
    const gqcnn::PolicyPlan& p = planned.value();
    for (const gqcnn::PolicyGrasp& g : p.grasps) {
      auto record = std::make_shared<GqcnnGraspRecord>();
      record->pose = g.image_pose;
      record->contacts = g.contacts;
      record->predicted_success = g.quality >= model.decision_threshold();
      PlannedGrasp out;
      out.grasp = g.grasp;
      out.details = std::move(record);
      plan->grasps.push_back(std::move(out));
    }
    auto stats = std::make_shared<GqcnnStats>();
    stats->edge_pixels = p.edge_pixels;
    stats->antipodal_pairs = p.antipodal_pairs;
    stats->evaluated = p.evaluated;
    stats->sample_ms = p.timing.sample_ms;
    stats->evaluate_ms = p.timing.evaluate_ms;
    stats->decision_threshold = model.decision_threshold();
    plan->details = std::move(stats);
    return std::nullopt;
  }

  const char* grasp_details_key() const override { return "gqcnn"; }

  nlohmann::json GraspDetailsJson(const PlannedGrasp& grasp) const override {
    const GqcnnGraspRecord* r = GqcnnRecordOf(grasp);
    if (!r) return nullptr;
    // The network's input besides the crop: how deep below the camera the jaws' centre goes.
    return {{"predicted_quality", grasp.grasp.score},
            {"grasp_depth_m", r->pose.depth_m},
            {"contacts", r->contacts == core::ContactHold::kStable ? "stable" : "firm"},
            {"predicted_success", r->predicted_success}};
  }

  void WritePlanJson(const engine::Plan& plan, nlohmann::json* body) const override {
    const GqcnnStats* g = GqcnnStatsOf(plan);
    if (!g) return;
    (*body)["gqcnn"] = {
        {"edge_pixels", g->edge_pixels}, {"antipodal_pairs", g->antipodal_pairs},
        {"evaluated", g->evaluated},     {"sample_ms", g->sample_ms},
        {"evaluate_ms", g->evaluate_ms}, {"decision_threshold", g->decision_threshold}};
  }
};

}  // namespace

const GqcnnGraspRecord* GqcnnRecordOf(const PlannedGrasp& grasp) {
  return dynamic_cast<const GqcnnGraspRecord*>(grasp.details.get());
}

const GqcnnStats* GqcnnStatsOf(const Plan& plan) {
  return dynamic_cast<const GqcnnStats*>(plan.details.get());
}

const Strategy& GqcnnStrategy() {
  static const Gqcnn strategy;
  return strategy;
}

}  // namespace softgrasp::engine
