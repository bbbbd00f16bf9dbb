#include "service/engine/engine.h"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <typeinfo>

#include "service/engine/contact_region.h"

namespace softgrasp::engine {
namespace {

using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// "'fge', 'stiffness' or 'deformability'"
std::string QuotedList(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += i + 1 == names.size() ? " or " : ", ";
    out += "'" + names[i] + "'";
  }
  return out;
}

core::Error Missing(const Models& models, const StrategyInfo& info) {
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

const std::vector<const Strategy*>& Strategies() { return AllStrategies(); }

const Strategy* FindStrategy(std::string_view name) {
  for (const Strategy* s : Strategies()) {
    if (name == s->info().name) return s;
  }
  return nullptr;
}

core::Result<const Strategy*> StrategyNamed(std::string_view name) {
  if (const Strategy* s = FindStrategy(name)) return s;
  std::vector<std::string> names;
  for (const Strategy* s : Strategies()) names.emplace_back(s->info().name);
  return Invalid("strategy must be " + QuotedList(names) + ", got '" + std::string(name) + "'",
                 "strategy");
}

bool Serves(const Models& models, const Strategy& strategy) {
  const StrategyInfo& info = strategy.info();
  return (!info.needs_stiffness_model || models.stiffness) &&
         (!info.needs_segmentation_model || models.segmentation) &&
         (!info.needs_gqcnn_model || models.gqcnn);
}

const Strategy& DefaultStrategy(const Models& models) {
  const Strategy* last = Strategies().front();
  for (const Strategy* s : Strategies()) {
    if (Serves(models, *s)) last = s;
  }
  return *last;
}

std::vector<std::string> ServedStrategies(const Models& models) {
  std::vector<std::string> out;
  for (const Strategy* s : Strategies()) {
    if (Serves(models, *s)) out.emplace_back(s->info().name);
  }
  return out;
}

core::Result<Plan> PlanGrasps(const core::DepthImage& depth, const core::Camera& camera,
                              const PlanOptions& options, const Models& models) {
  const auto start = Clock::now();
  auto named = StrategyNamed(options.strategy);
  if (!named.ok()) return named.error();
  const Strategy& strategy = *named.value();
  const StrategyInfo& info = strategy.info();
  const StrategyOptions* own_options = options.strategy_options.get();
  if (own_options) {
    const auto defaults = strategy.DefaultOptions();
    if (!defaults || typeid(*own_options) != typeid(*defaults)) {
      throw std::invalid_argument(std::string("PlanGrasps: options of another type for strategy ") +
                                  info.name);
    }
  }
  const bool given_map = !options.stiffness_map.empty();
  // A given stiffness map stands in for the stiffness model.
  if ((info.needs_stiffness_model && !given_map && !models.stiffness) ||
      (info.needs_segmentation_model && !models.segmentation) ||
      (info.needs_gqcnn_model && !models.gqcnn)) {
    return Missing(models, info);
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
  if (auto error = strategy.Validate(own_options, options, camera)) return *error;

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
    if (auto error = strategy.Plan(context, own_options, &plan)) return *error;
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
