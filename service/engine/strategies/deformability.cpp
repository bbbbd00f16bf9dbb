#include "service/engine/strategies/deformability.h"

#include <cmath>
#include <string>

namespace softgrasp::engine {
namespace {

using Fields = FieldsOf<DeformabilityOptions>;

// Optional numbers: null when not finite.
nlohmann::json FiniteOrNull(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

class Deformability final : public Strategy {
 public:
  const StrategyInfo& info() const override {
    static const StrategyInfo info{
        "deformability",
        "Algorithm 1: grasps on the least deformable part of one target, soft neighbours pressed "
        "aside",
        false,
        true,
        false,
        true,
        true};
    return info;
  }

  const std::vector<StrategyField>& fields() const override {
    static const std::vector<StrategyField> fields = {
        Fields::Choice(
            "target_policy", {"highest", "least_deformable"},
            "which confident object becomes the target",
            [](auto& o) -> auto& { return o.params.policy; }),
        Fields::Number(
            "min_target_area_px", "px", 0, 1e6,
            "K: the first slice is where the target's area exceeds this",
            [](auto& o) -> auto& { return o.params.min_target_area_px; }),
        Fields::Number(
            "slice_step_mm", "mm", 1, 200,
            "L: slice spacing and how far below the contact the fingertips go; at most "
            "finger_length_mm",
            [](auto& o) -> auto& { return o.params.slice_step_m; }, 1000.0),
        Fields::Integer(
            "num_slices", "", 1, 20, "M: slices searched",
            [](auto& o) -> auto& { return o.params.num_slices; }),
        Fields::Number(
            "min_score", "", 0, 1,
            "R: instances scoring below are never targets (0.25 = 90 % precision of the "
            "shipped model)",
            [](auto& o) -> auto& { return o.params.min_score; }),
        Fields::NumberList(
            "opening_fractions", "", 0, 1, true, 8,
            "pre-grasp openings tried, fractions of the stroke in (0, 1], increasing, "
            "comma-separated, at most 8",
            [](auto& o) -> auto& { return o.params.opening_fractions; }),
        Fields::Number(
            "stiff_part_fraction", "", 0, 1,
            "target pixels below this fraction of the target's maximum stiffness are never "
            "contact",
            [](auto& o) -> auto& { return o.params.stiff_part_fraction; }),
        Fields::Number(
            "min_part_contrast", "", 0, 1,
            "when no target gives a grasp with its soft part kept out, targets are planned "
            "again with soft-looking pixels allowed as contact where the two parts differ "
            "by less than this in mean stiffness, and a named target that still gives none "
            "is planned whole (0 = never, neither; target.soft_part_allowed says so)",
            [](auto& o) -> auto& { return o.params.min_part_contrast; }),
        Fields::Number(
            "soft_obstacle_threshold", "", 0, 2,
            "neighbour pixels with a deformability above this may be pressed (above 1 = "
            "never)",
            [](auto& o) -> auto& { return o.params.soft_obstacle_threshold; }),
        Fields::Number(
            "max_press_depth_mm", "mm", 0, 200, "how far a finger may press into a soft neighbour",
            [](auto& o) -> auto& { return o.params.max_press_depth_m; }, 1000.0),
        Fields::Integer(
            "max_targets", "", 1, 64,
            "candidate targets planned at most, in policy order, until one gives grasps",
            [](auto& o) -> auto& { return o.params.max_targets; }),
    };
    return fields;
  }

  std::shared_ptr<StrategyOptions> DefaultOptions() const override {
    return std::make_shared<DeformabilityOptions>();
  }

  std::optional<core::Error> Validate(const StrategyOptions* options, const PlanOptions& common,
                                      const core::Camera& /*camera*/) const override {
    const core::DeformabilityParams& params = OptionsOr<DeformabilityOptions>(options).params;
    if (params.slice_step_m > common.gripper.finger_length_m) {
      return core::MakeError(core::ErrorCode::kInvalidArgument,
                             "slice_step_mm must not exceed finger_length_mm (the fingertips go "
                             "one slice step below the contact)",
                             "slice_step_mm");
    }
    return core::ValidateDeformabilityParams(params, common.gripper);
  }

  std::optional<core::Error> Plan(const PlanContext& c, const StrategyOptions* options,
                                  engine::Plan* plan) const override {
    core::DeformabilityParams params = OptionsOr<DeformabilityOptions>(options).params;
    params.fge = c.options.fge;
    params.target_id = c.target_id;
    if (c.target_id > 0) params.target_px = c.options.target_px;
    const Instances& in = *c.instances;
    const core::DeformabilityResult planned = core::DetectGraspsDeformability(
        c.scene, c.camera, {in.labels, in.scores, in.deformability, in.foreground},
        c.options.gripper, params);
    const char* target_by =
        planned.fallback ? "fallback" : (c.target_id > 0 ? "request" : "policy");
    for (const core::DeformabilityGrasp& dg : planned.grasps) {
      auto record = std::make_shared<DeformabilityRecord>();
      record->policy = params.policy;
      record->target_by = target_by;
      record->opening_fraction = dg.opening_fraction;
      record->mean_deformability = dg.mean_deformability;
      record->pressed_ids = dg.pressed_ids;
      record->press_depth_m = dg.press_depth_m;
      PlannedGrasp p;
      p.grasp = dg.grasp;
      p.instance_id = dg.instance_id;
      p.details = std::move(record);
      plan->grasps.push_back(std::move(p));
    }
    auto target = std::make_shared<TargetChoice>();
    target->id = planned.target_id;
    target->policy = params.policy;
    target->tried_ids = planned.tried_ids;
    target->fallback = planned.fallback;
    target->soft_part_allowed = planned.soft_part_allowed;
    plan->chosen_target_id = planned.target_id;
    plan->details = std::move(target);
    return std::nullopt;
  }

  const char* grasp_details_key() const override { return "deformability"; }

  nlohmann::json GraspDetailsJson(const PlannedGrasp& grasp) const override {
    const DeformabilityRecord* d = DeformabilityRecordOf(grasp);
    if (!d) return nullptr;
    return {{"target_policy", core::TargetPolicyName(d->policy)},
            {"target_by", d->target_by},
            {"slice", grasp.grasp.height_step},
            {"opening_fraction", d->opening_fraction},
            {"mean_deformability", FiniteOrNull(d->mean_deformability)},
            {"pressed_instances", d->pressed_ids},
            {"press_depth_m", d->press_depth_m}};
  }

  void WritePlanJson(const engine::Plan& plan, nlohmann::json* body) const override {
    const TargetChoice* t = TargetChoiceOf(plan);
    if (!t) return;
    (*body)["target"] = {{"id", t->id > 0 ? nlohmann::json(t->id) : nlohmann::json()},
                         {"policy", core::TargetPolicyName(t->policy)},
                         {"tried", t->tried_ids},
                         {"fallback", t->fallback},
                         {"soft_part_allowed", t->soft_part_allowed}};
  }
};

}  // namespace

const DeformabilityRecord* DeformabilityRecordOf(const PlannedGrasp& grasp) {
  return dynamic_cast<const DeformabilityRecord*>(grasp.details.get());
}

const TargetChoice* TargetChoiceOf(const Plan& plan) {
  return dynamic_cast<const TargetChoice*>(plan.details.get());
}

const Strategy& DeformabilityStrategy() {
  static const Deformability strategy;
  return strategy;
}

}  // namespace softgrasp::engine
