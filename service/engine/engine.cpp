#include "service/engine/engine.h"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "service/core/fge_deformability.h"
#include "service/core/fge_stiffness.h"
#include "service/engine/contact_region.h"

namespace softgrasp::engine {
namespace {

using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// What a planner works with: the restricted scene, the maps, the instances and the target.
struct PlanContext {
  const Models& models;
  const core::Scene& scene;
  const core::Camera& camera;
  const PlanOptions& options;
  const cv::Mat1f& stiffness;  ///< empty unless needed or wanted
  const Instances* instances;  ///< null unless needed or asked for
  int target_id;               ///< > 0: the requested target
};

using PlanError = std::optional<core::Error>;

PlanError PlanFge(const PlanContext& c, Plan* plan) {
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

PlanError PlanGqcnn(const PlanContext& c, Plan* plan) {
  gqcnn::PolicyParams params = c.options.gqcnn;
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
    PlannedGrasp out;
    out.grasp = g.grasp;
    out.gqcnn_pose = g.image_pose;
    out.gqcnn_contacts = g.contacts;
    out.gqcnn_predicted_success = g.quality >= model.decision_threshold();
    plan->grasps.push_back(std::move(out));
  }
  plan->gqcnn = GqcnnStats{p.edge_pixels,      p.antipodal_pairs,    p.evaluated,
                           p.timing.sample_ms, p.timing.evaluate_ms, model.decision_threshold()};
  return std::nullopt;
}

PlanError PlanStiffness(const PlanContext& c, Plan* plan) {
  core::StiffnessFgeParams params = c.options.stiffness;
  params.fge = c.options.fge;
  for (const core::Grasp& g :
       core::DetectGraspsStiffness(c.scene, c.camera, c.stiffness, c.options.gripper, params)) {
    PlannedGrasp p;
    p.grasp = g;
    plan->grasps.push_back(std::move(p));
  }
  return std::nullopt;
}

PlanError PlanDeformability(const PlanContext& c, Plan* plan) {
  core::DeformabilityParams params = c.options.deformability;
  params.fge = c.options.fge;
  params.target_id = c.target_id;
  if (c.target_id > 0) params.target_px = c.options.target_px;
  const Instances& in = *c.instances;
  const core::DeformabilityResult planned = core::DetectGraspsDeformability(
      c.scene, c.camera, {in.labels, in.scores, in.deformability, in.foreground}, c.options.gripper,
      params);
  for (const core::DeformabilityGrasp& dg : planned.grasps) {
    PlannedGrasp p;
    p.grasp = dg.grasp;
    p.instance_id = dg.instance_id;
    p.deformability = DeformabilityRecord{
        params.policy,
        planned.fallback ? "fallback" : (c.target_id > 0 ? "request" : "policy"),
        dg.opening_fraction,
        dg.mean_deformability,
        dg.pressed_ids,
        dg.press_depth_m};
    plan->grasps.push_back(std::move(p));
  }
  plan->target = TargetChoice{planned.target_id, params.policy, planned.tried_ids, planned.fallback,
                              planned.soft_part_allowed};
  return std::nullopt;
}

// Why a strategy cannot plan with these options (its own parameters; FGE's search parameters
// and the gripper are checked for every strategy).
PlanError ValidateNothing(const PlanOptions&, const core::Camera&) { return std::nullopt; }

PlanError ValidateGqcnn(const PlanOptions& o, const core::Camera&) {
  return gqcnn::ValidatePolicyParams(o.gqcnn);
}

PlanError ValidateStiffness(const PlanOptions& o, const core::Camera& camera) {
  core::StiffnessFgeParams params = o.stiffness;
  params.fge = o.fge;
  return core::ValidateStiffnessFgeInputs(camera, o.gripper, params);
}

PlanError ValidateDeformability(const PlanOptions& o, const core::Camera&) {
  return core::ValidateDeformabilityParams(o.deformability, o.gripper);
}

using Planner = PlanError (*)(const PlanContext&, Plan*);
using Validator = PlanError (*)(const PlanOptions&, const core::Camera&);

struct Registered {
  StrategyInfo info;
  Validator validate;
  Planner plan;
};

// The one place strategies are registered, in order of preference (the default strategy is the
// last one the loaded models serve).
const std::vector<Registered>& Registry() {
  static const std::vector<Registered> registry = {
      {{Strategy::kFge, "fge", false, false, false, false, true}, &ValidateNothing, &PlanFge},
      {{Strategy::kGqcnn, "gqcnn", false, false, true, false, false}, &ValidateGqcnn, &PlanGqcnn},
      {{Strategy::kStiffness, "stiffness", true, false, false, false, true},
       &ValidateStiffness,
       &PlanStiffness},
      {{Strategy::kDeformability, "deformability", false, true, false, true, true},
       &ValidateDeformability,
       &PlanDeformability},
  };
  return registry;
}

const Registered& Find(Strategy strategy) {
  for (const Registered& r : Registry()) {
    if (r.info.strategy == strategy) return r;
  }
  throw std::invalid_argument("engine: unregistered strategy " +
                              std::to_string(static_cast<int>(strategy)));
}

// "'fge', 'stiffness' or 'deformability'"
std::string QuotedList(const std::vector<Strategy>& strategies) {
  std::string out;
  for (std::size_t i = 0; i < strategies.size(); ++i) {
    if (i > 0) out += i + 1 == strategies.size() ? " or " : ", ";
    out += std::string("'") + StrategyName(strategies[i]) + "'";
  }
  return out;
}

core::Error Missing(const Models& models, Strategy strategy) {
  const StrategyInfo& info = InfoOf(strategy);
  const char* missing =
      info.needs_segmentation_model && !models.segmentation
          ? "a segmentation model and none is loaded (start the server with "
            "--segmentation-model)"
      : info.needs_gqcnn_model && !models.gqcnn
          ? "a GQ-CNN model and none is loaded (start the server with --gqcnn-model)"
          : "a stiffness model and none is loaded (start the server with --stiffness-model)";
  return core::MakeError(core::ErrorCode::kInvalidArgument,
                         std::string("strategy '") + info.name + "' needs " + missing +
                             "; use strategy " + QuotedList(ServedStrategies(models)),
                         "strategy");
}

core::Error Invalid(const std::string& message, const std::string& field) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, message, field);
}

std::string SizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

}  // namespace

const std::vector<StrategyInfo>& Strategies() {
  static const std::vector<StrategyInfo> infos = [] {
    std::vector<StrategyInfo> out;
    for (const Registered& r : Registry()) out.push_back(r.info);
    return out;
  }();
  return infos;
}

const StrategyInfo& InfoOf(Strategy strategy) { return Find(strategy).info; }

const char* StrategyName(Strategy strategy) { return InfoOf(strategy).name; }

std::optional<Strategy> StrategyByName(std::string_view name) {
  for (const StrategyInfo& info : Strategies()) {
    if (name == info.name) return info.strategy;
  }
  return std::nullopt;
}

bool Serves(const Models& models, Strategy strategy) {
  const StrategyInfo& info = InfoOf(strategy);
  return (!info.needs_stiffness_model || models.stiffness) &&
         (!info.needs_segmentation_model || models.segmentation) &&
         (!info.needs_gqcnn_model || models.gqcnn);
}

std::optional<core::Error> Unserved(const Models& models, Strategy strategy) {
  if (Serves(models, strategy)) return std::nullopt;
  return Missing(models, strategy);
}

Strategy DefaultStrategy(const Models& models) { return ServedStrategies(models).back(); }

std::vector<Strategy> ServedStrategies(const Models& models) {
  std::vector<Strategy> out;
  for (const StrategyInfo& info : Strategies()) {
    if (Serves(models, info.strategy)) out.push_back(info.strategy);
  }
  return out;
}

core::Result<Plan> PlanGrasps(const core::DepthImage& depth, const core::Camera& camera,
                              const PlanOptions& options, const Models& models) {
  const auto start = Clock::now();
  const Registered& strategy = Find(options.strategy);
  const StrategyInfo& info = strategy.info;
  const bool given_map = !options.stiffness_map.empty();
  // A given stiffness map stands in for the stiffness model.
  if ((info.needs_stiffness_model && !given_map && !models.stiffness) ||
      (info.needs_segmentation_model && !models.segmentation) ||
      (info.needs_gqcnn_model && !models.gqcnn)) {
    return Missing(models, options.strategy);
  }
  // Strategies without a map of their own report the stiffness model's mean on request.
  const bool own_map = info.needs_stiffness_model || info.needs_segmentation_model;
  const bool mean_stiffness = options.mean_stiffness && !own_map;
  if (!given_map && !models.stiffness && (mean_stiffness || options.want_stiffness_map)) {
    return Invalid("the stiffness map needs a stiffness model and none is loaded",
                   mean_stiffness ? "mean_stiffness" : "overlay");
  }
  const cv::Size image(depth.width(), depth.height());
  if (!options.region_of_interest.empty() && options.region_of_interest.size() != image) {
    return core::MakeError(core::ErrorCode::kUnprocessable,
                           "segmask is " + SizeText(options.region_of_interest.size()) +
                               " but the depth image is " + SizeText(image),
                           "segmask");
  }
  if (given_map && options.stiffness_map.size() != image) {
    return Invalid("the stiffness map is " + SizeText(options.stiffness_map.size()) +
                       " but the depth image is " + SizeText(image),
                   "stiffness_map");
  }
  if (!(std::isfinite(options.min_depth_m) && options.min_depth_m >= 0)) {
    return Invalid("min_depth_m must be finite and >= 0", "min_depth_m");
  }
  if (auto error = core::ValidateFgeInputs(camera, options.gripper, options.fge)) return *error;
  if (auto error = strategy.validate(options, camera)) return *error;

  Plan plan;
  const auto preprocess_start = Clock::now();
  auto preprocessed = core::Preprocess(depth, camera);
  if (!preprocessed.ok()) return preprocessed.error();
  plan.scene = std::move(preprocessed).value();
  plan.timing.preprocess_ms = MillisecondsSince(preprocess_start);

  // Instances only when something uses them: segmenting is not free.
  const bool wants_target = options.target_id > 0 || options.target_px.has_value();
  if (options.report_instances || wants_target || info.needs_segmentation_model ||
      options.want_deformability_map) {
    InstanceRequest request = options.instances;
    request.need_deformability = info.needs_segmentation_model || options.want_deformability_map;
    request.target_id = options.target_id;
    auto found = InstancesForPlan(request, plan.scene, camera, models.segmentation.get());
    if (!found.ok()) return found.error();
    plan.instances = std::move(found).value();
    plan.timing.segmentation_ms = plan.instances->milliseconds;
  }
  int target_id = options.target_id;
  if (options.target_px) {
    target_id = InstanceAt(plan.instances->labels, options.target_px->x, options.target_px->y);
    plan.target_not_found = target_id == 0;
  }
  plan.target_id = target_id;
  // One contact region for every strategy; a target restricts contacts to that instance (every
  // other object stays an obstacle) unless the strategy plans its own target.
  const auto region_start = Clock::now();
  const cv::Mat1b region = ApplyContactRegion(
      &plan.scene, camera, options.gripper, options.fge,
      {options.region_of_interest, options.min_depth_m,
       target_id > 0 && !info.plans_target ? cv::Mat1b(plan.instances->labels == target_id)
                                           : cv::Mat1b(),
       !info.finds_free_surfaces});
  core::Scene planner_scene_storage;
  const core::Scene* planner_scene = &plan.scene;
  if (!region.empty()) {
    planner_scene_storage = plan.scene;
    planner_scene_storage.contact_allowed = region;
    planner_scene = &planner_scene_storage;
  }
  plan.timing.preprocess_ms += MillisecondsSince(region_start);

  const auto stiffness_start = Clock::now();
  if (given_map) {
    plan.stiffness = options.stiffness_map;
  } else if (info.needs_stiffness_model || options.want_stiffness_map || mean_stiffness) {
    plan.stiffness = models.stiffness->PredictScene(plan.scene);
    plan.timing.stiffness_ran = true;
    plan.timing.stiffness_ms = MillisecondsSince(stiffness_start);
  }

  if (options.plan && !plan.target_not_found) {
    const auto detect_start = Clock::now();
    const PlanContext context{models,   *planner_scene, camera,
                              options,  plan.stiffness, plan.instances ? &*plan.instances : nullptr,
                              target_id};
    if (auto error = strategy.plan(context, &plan)) return *error;
    // What a planner given the region as its mask proposes outside it is not a grasp (a planner
    // that samples edge pairs can still close on a finger's tip beside allowed pixels). FGE's
    // planners keep their contact surfaces on the free surfaces by construction.
    if (planner_scene != &plan.scene) {
      std::erase_if(plan.grasps, [&](const PlannedGrasp& g) {
        return !ClosesInRegion(plan.scene, region, g.grasp);
      });
    }
    if (plan.instances) {
      const Instances& in = *plan.instances;
      for (PlannedGrasp& g : plan.grasps) {
        if (!g.instance_id)
          g.instance_id = InstanceAt(in.labels, g.grasp.center_u_px, g.grasp.center_v_px);
        const auto id = static_cast<std::size_t>(*g.instance_id);
        if (id > 0 && id < in.mean_deformability.size() && in.mean_deformability[id] &&
            std::isfinite(*in.mean_deformability[id])) {
          g.instance_deformability = in.mean_deformability[id];
        }
      }
    }
    plan.timing.detect_ms = MillisecondsSince(detect_start);
  }
  plan.timing.total_ms = MillisecondsSince(start);
  return plan;
}

core::Result<Segmentation> Segment(const core::DepthImage& depth, const core::Camera& camera,
                                   const SegmentOptions& options, const Models& models) {
  auto method = ResolveSegmentationMethod(options.method, models.segmentation != nullptr, "method");
  if (!method.ok()) return method.error();
  const auto preprocess_start = Clock::now();
  auto preprocessed = core::Preprocess(depth, camera);
  if (!preprocessed.ok()) return preprocessed.error();
  Segmentation out;
  out.scene = std::move(preprocessed).value();
  out.timing.preprocess_ms = MillisecondsSince(preprocess_start);

  auto segmented = SegmentInstances(out.scene, camera, method.value(), models.segmentation.get());
  if (!segmented.ok()) return segmented.error();
  out.instances = std::move(segmented).value();
  out.timing.segment_ms = out.instances.milliseconds;
  if (options.describe) {
    const auto describe_start = Clock::now();
    out.described = DescribeSceneInstances(out.instances, out.scene, camera, models.stiffness.get(),
                                           &out.timing.stiffness_ms);
    out.timing.describe_ms = MillisecondsSince(describe_start) - out.timing.stiffness_ms;
  }
  return out;
}

}  // namespace softgrasp::engine
