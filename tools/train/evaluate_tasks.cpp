#include "tools/train/evaluate_tasks.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>

#include "service/cli/args.h"
#include "service/cli/files.h"
#include "service/cli/progress.h"
#include "service/codec/json_codec.h"
#include "service/core/fge_deformability.h"
#include "service/engine/engine.h"
#include "service/engine/strategies/deformability.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/segmentation/instance_metrics.h"
#include "sim/dataset/scene_gen.h"
#include "sim/grasp/execute.h"
#include "sim/render/render.h"
#include "tools/train/bootstrap.h"
#include "tools/train/cli_common.h"

namespace softgrasp::tools {
namespace {

using nlohmann::json;

constexpr int kBootstrapResamples = 2000;
constexpr std::uint64_t kBootstrapSeed = 1;
/// Brushes: the task succeeds when both finger contacts are at least this stiff (the handle is
/// 0.9, the head 0.2; docs/sim-catalogue.md).
constexpr float kHardPart = 0.5f;
/// Obstacles: the target is the non-sponge object with most sponge pixels in a ring this wide
/// around it, at least kMinSpongeRing of the ring.
constexpr int kRingPx = 10;
constexpr double kMinSpongeRing = 0.25;
/// Obstacles: a target must show at least this share of its own silhouette (nothing lies on it).
constexpr double kMinVisibleFraction = 0.8;
/// Bin clearing stops after this many failed picks in a row.
constexpr int kMaxFailuresInARow = 3;
/// The workspace ROI's margin inside the bin walls, pixels.
constexpr int kBinMarginPx = 3;

constexpr std::string_view kCommand = "evaluate-tasks";

enum class Task { kClutter, kBrushes, kObstacles };

const char* TaskName(Task t) {
  switch (t) {
    case Task::kClutter:
      return "clutter";
    case Task::kBrushes:
      return "brushes";
    case Task::kObstacles:
      return "obstacles";
  }
  return "?";
}

/// The scenes of each task: validation shapes (never seen in training), in the default bin.
sim::SceneSpec TaskSpec(Task task) {
  sim::SceneSpec spec;
  spec.split = sim::ShapeSplit::kVal;
  switch (task) {
    case Task::kClutter:  // Table 5.1: hollow objects
      spec.min_objects = 3;
      spec.max_objects = 8;
      spec.categories = {"bottle", "box", "can", "cup"};
      break;
    case Task::kBrushes:  // Table 5.2: six brushes in a pile
      spec.min_objects = 6;
      spec.max_objects = 6;
      spec.categories = {"brush"};
      break;
    case Task::kObstacles:  // Table 5.3: targets among sponges (six in ten draws are sponges)
      spec.min_objects = 6;
      spec.max_objects = 10;
      spec.categories = {"box",    "can",    "bottle", "block",  "sponge",
                         "sponge", "sponge", "sponge", "sponge", "sponge"};
      break;
  }
  return spec;
}

struct Planner {
  std::string strategy;  ///< a registered strategy's name
  core::TargetPolicy policy = core::TargetPolicy::kHighest;
  std::string name;
};

std::vector<Planner> Planners(bool stiffness_model) {
  std::vector<Planner> out = {{"fge", {}, "fge"}};
  if (stiffness_model) out.push_back({"stiffness", {}, "stiffness"});
  out.push_back({"deformability", core::TargetPolicy::kHighest, "deformability_highest"});
  out.push_back(
      {"deformability", core::TargetPolicy::kLeastDeformable, "deformability_least_deformable"});
  return out;
}

struct Models {
  engine::Models loaded;
  core::DeformabilityParams deformability;  ///< the policy is set per planner
};

struct Plan {
  std::vector<core::Grasp> grasps;
  double detect_ms = 0;        ///< the engine's whole call: preprocessing, models, planner
  double segmentation_ms = 0;  ///< of which segmenting and describing instances
  double planner_ms = 0;       ///< of which the grasp planner itself
  bool target_found = true;    ///< a named target matched an instance (deformability)
  std::optional<engine::DeformabilityRecord> best;  ///< the best grasp's (deformability)
  /// A named target planned on a model instance: IoU of that instance with the true mask.
  std::optional<double> target_iou;
};

/// Where a user would click to name the target: the innermost pixel of its visible mask
/// (farthest from its outline); none for an empty mask.
std::optional<cv::Point> ClickedPixel(const cv::Mat1b& mask) {
  cv::Mat1f distance;
  cv::Mat1b padded;
  cv::copyMakeBorder(mask, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  cv::distanceTransform(padded, distance, cv::DIST_L2, 3);
  cv::Point inside;
  double farthest = 0;
  cv::minMaxLoc(distance, nullptr, &farthest, nullptr, &inside);
  if (!(farthest > 0)) return std::nullopt;
  return cv::Point(inside.x - 1, inside.y - 1);
}

/// One planner's whole detection on one frame through the service's engine. Contacts inside the
/// bin's `roi` only (the walls stay obstacles). `target_mask` (may be empty): the named target's
/// true visible pixels; FGE and stiffness then grasp only there, deformability takes the
/// instance a user would click (ClickedPixel).
Plan RunPlanner(const Planner& p, const core::DepthImage& depth, const core::Camera& camera,
                const cv::Mat1b& roi, const cv::Mat1b& target_mask, const Models& models,
                const core::Gripper& gripper) {
  Plan out;
  engine::PlanOptions options;
  options.strategy = p.strategy;
  options.gripper = gripper;
  if (p.strategy == "deformability") {
    auto deformability = std::make_shared<engine::DeformabilityOptions>();
    deformability->params = models.deformability;
    deformability->params.policy = p.policy;
    options.strategy_options = std::move(deformability);
  }
  options.region_of_interest = roi;
  if (!target_mask.empty()) {
    if (engine::FindStrategy(p.strategy)->info().plans_target) {
      options.target_px = ClickedPixel(target_mask);
      if (!options.target_px) {
        out.target_found = false;
        return out;
      }
    } else {
      // A new buffer: assigning the expression to options.region_of_interest, which shares
      // `roi`'s pixels, would write the target into the task's workspace mask for every later
      // scene (obstacles scenes after the first then had no contact region at all).
      const cv::Mat1b target_in_roi = roi & target_mask;
      options.region_of_interest = target_in_roi;
    }
  }
  auto plan = engine::PlanGrasps(depth, camera, options, models.loaded);
  if (!plan.ok()) return out;
  out.target_found = !plan.value().target_not_found;
  // The named target's instance: the one that gave the grasps, else the one planned first.
  int chosen_id = 0;
  if (const engine::TargetChoice* t = engine::TargetChoiceOf(plan.value())) {
    chosen_id = t->id > 0 ? t->id : (t->tried_ids.empty() ? 0 : t->tried_ids.front());
  }
  if (!target_mask.empty() && chosen_id > 0 && plan.value().instances) {
    out.target_iou =
        segmentation::MaskIou(plan.value().instances->labels == chosen_id, target_mask);
  }
  for (const engine::PlannedGrasp& g : plan.value().grasps) out.grasps.push_back(g.grasp);
  if (!plan.value().grasps.empty()) {
    if (const auto* record = engine::DeformabilityRecordOf(plan.value().grasps.front())) {
      out.best = *record;
    }
  }
  out.detect_ms = plan.value().timing.total_ms;
  out.segmentation_ms = plan.value().timing.segmentation_ms;
  out.planner_ms = plan.value().timing.detect_ms;
  return out;
}

/// The 95 % interval of the mean of `per_scene` (NaN = no figure) over a scene bootstrap.
json MeanInterval(const std::vector<double>& per_scene) {
  if (per_scene.empty()) return json();
  const Interval ci = BootstrapInterval(
      static_cast<int>(per_scene.size()),
      [&per_scene](std::span<const int> k) { return SampleMean(per_scene, k); },
      kBootstrapResamples, kBootstrapSeed);
  return json::array({Num(ci.low), Num(ci.high)});
}

/// 0, 1, ..., n - 1: every scene once.
std::vector<int> AllScenes(std::size_t n) {
  std::vector<int> all(n);
  for (std::size_t i = 0; i < n; ++i) all[i] = static_cast<int>(i);
  return all;
}

struct CategoryStats {
  int grasps = 0, succeeded = 0, damaged = 0;
  Mean deformation;
};

/// One planner on one task's one-grasp scenes: per-scene figures in scene order (NaN: the
/// scene has no such figure) for the paired bootstrap.
struct Stats {
  int attempts = 0, no_grasp = 0, target_not_found = 0, succeeded = 0, task_successes = 0,
      damaged = 0, pressed = 0;
  std::map<std::string, int> outcomes;
  std::map<std::string, std::string> example_reason;
  std::map<std::string, CategoryStats> by_category;  // the object the fingers closed on
  Mean neighbour_deformation;
  std::vector<double> success, task, deformation, damage, detect_ms;
  json per_grasp;  // with --per-grasp: one record per executed grasp

  json ToJson() const {
    const std::size_t n = success.size();
    const std::vector<int> all = AllScenes(n);
    std::vector<double> ms = detect_ms;
    std::sort(ms.begin(), ms.end());
    json cats = json::object();
    for (const auto& [c, s] : by_category) {
      cats[c] = {{"grasps", s.grasps},
                 {"succeeded", s.succeeded},
                 {"damaged", s.damaged},
                 {"mean_deformation_rate", Num(s.deformation.value())}};
    }
    return {{"scenes", n},
            {"attempts", attempts},
            {"no_grasp", no_grasp},
            {"target_not_found", target_not_found},
            {"success_rate", Num(SampleMean(success, all))},
            {"task_success_rate", Num(SampleMean(task, all))},
            {"mean_deformation_rate", Num(SampleMean(deformation, all))},
            {"damage_rate", Num(SampleMean(damage, all))},
            {"ci95",
             {{"success_rate", MeanInterval(success)},
              {"task_success_rate", MeanInterval(task)},
              {"mean_deformation_rate", MeanInterval(deformation)},
              {"damage_rate", MeanInterval(damage)}}},
            {"grasps_pressing_neighbours", pressed},
            {"mean_neighbour_deformation_rate", Num(neighbour_deformation.value())},
            {"detect_ms",
             {{"median", ms.empty() ? json() : json(ms[ms.size() / 2])},
              {"p90", ms.empty() ? json() : json(ms[ms.size() * 9 / 10])},
              {"max", ms.empty() ? json() : json(ms.back())}}},
            {"outcomes", outcomes},
            {"example_reason", example_reason},
            {"by_category", cats},
            {"per_grasp", per_grasp}};
  }
};

/// Paired comparison with FGE on the same scenes: deformation as a ratio, success and task
/// success as differences, each with its 95 % interval.
json Versus(const Stats& s, const Stats& base) {
  const std::size_t n = base.success.size();
  if (n == 0 || s.success.size() != n) return json();
  const std::vector<std::pair<const char*, SceneStatistic>> statistics = {
      {"deformation_ratio",
       [&](std::span<const int> k) {
         return SampleMean(s.deformation, k) / SampleMean(base.deformation, k);
       }},
      {"damage_ratio",
       [&](std::span<const int> k) {
         return SampleMean(s.damage, k) / SampleMean(base.damage, k);
       }},
      {"success_difference",
       [&](std::span<const int> k) {
         return SampleMean(s.success, k) - SampleMean(base.success, k);
       }},
      {"task_success_difference",
       [&](std::span<const int> k) { return SampleMean(s.task, k) - SampleMean(base.task, k); }}};
  const std::vector<int> all = AllScenes(n);
  json out = json::object();
  for (const auto& [name, statistic] : statistics) {
    const Interval ci =
        BootstrapInterval(static_cast<int>(n), statistic, kBootstrapResamples, kBootstrapSeed);
    out[name] = {{"value", Num(statistic(all))},
                 {"ci95", json::array({Num(ci.low), Num(ci.high)})}};
  }
  return out;
}

std::string CategoryOf(const sim::SimScene& scene, int id) {
  const sim::PlacedObject* o = scene.Find(id);
  return o && o->object ? o->object->category : "support";
}

/// Executes a plan's best grasp and records it.
void Record(Task task, const sim::SimScene& scene, const sim::SceneRaycaster& raycaster,
            const Eigen::Isometry3d& world_from_camera, const Plan& plan, int target_id,
            bool per_grasp, const core::Gripper& gripper, Stats* s) {
  s->detect_ms.push_back(plan.detect_ms);
  s->success.push_back(0.0);
  s->task.push_back(0.0);
  s->deformation.push_back(std::nan(""));
  s->damage.push_back(std::nan(""));
  if (!plan.target_found) ++s->target_not_found;
  if (plan.grasps.empty()) {
    ++s->no_grasp;
    if (per_grasp && plan.target_iou) {
      s->per_grasp.push_back({{"scene", s->success.size() - 1},
                              {"outcome", "no_grasp"},
                              {"detect_ms", plan.detect_ms},
                              {"segmentation_ms", plan.segmentation_ms},
                              {"planner_ms", plan.planner_ms},
                              {"target_iou", *plan.target_iou}});
    }
    return;
  }
  ++s->attempts;
  auto exec = sim::ExecuteGrasp(
      scene, raycaster, sim::SimGraspFromCamera(plan.grasps.front(), world_from_camera), gripper);
  if (!exec.ok()) {
    ++s->outcomes["error"];
    return;
  }
  const sim::GraspExecution& e = exec.value();
  const char* outcome = sim::GraspOutcomeName(e.outcome);
  if (per_grasp) {
    const core::Grasp& g = plan.grasps.front();
    s->per_grasp.push_back({{"scene", s->success.size() - 1},
                            {"object", CategoryOf(scene, e.instance_id)},
                            {"outcome", outcome},
                            {"reason", e.reason},
                            {"opening_m", g.opening_m},
                            {"center_px", {g.center_u_px, g.center_v_px}},
                            {"contact_height_m", g.contact_height_m},
                            {"deformation_rate", e.deformation_rate},
                            {"detect_ms", plan.detect_ms},
                            {"segmentation_ms", plan.segmentation_ms},
                            {"planner_ms", plan.planner_ms}});
    if (plan.best) {
      s->per_grasp.back()["target_by"] = plan.best->target_by;
      s->per_grasp.back()["opening_fraction"] = plan.best->opening_fraction;
      s->per_grasp.back()["pressed_ids"] = plan.best->pressed_ids;
    }
    if (plan.target_iou) s->per_grasp.back()["target_iou"] = *plan.target_iou;
  }
  ++s->outcomes[outcome];
  s->example_reason.emplace(outcome, e.reason);
  CategoryStats& cat = s->by_category[CategoryOf(scene, e.instance_id)];
  ++cat.grasps;
  s->damage.back() = e.damaged ? 1.0 : 0.0;
  if (e.outcome == sim::GraspOutcome::kSucceeded || e.outcome == sim::GraspOutcome::kSlipped) {
    s->deformation.back() = e.deformation_rate;
    cat.deformation.Add(e.deformation_rate);
  }
  if (!e.pressed.empty()) ++s->pressed;
  for (const auto& p : e.pressed) s->neighbour_deformation.Add(p.deformation_rate);
  if (e.damaged) ++s->damaged, ++cat.damaged;
  if (!e.succeeded()) return;
  ++s->succeeded;
  ++cat.succeeded;
  s->success.back() = 1.0;
  bool task_ok = true;
  if (task == Task::kBrushes) {
    task_ok = std::min(e.stiffness_left, e.stiffness_right) >= kHardPart;
  } else if (task == Task::kObstacles) {
    task_ok = e.instance_id == target_id && !e.damaged;
  }
  if (task_ok) {
    ++s->task_successes;
    s->task.back() = 1.0;
  }
}

/// The narrowest horizontal extent of an object at rest, over 32 directions: wider than the
/// stroke, no top-down two-finger grasp can close on it.
double NarrowestWidthM(const sim::PlacedObject& placed) {
  double narrowest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 32; ++k) {
    const double a = 3.14159265358979323846 * k / 32;
    const Eigen::Vector3d dir(std::cos(a), std::sin(a), 0.0);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& v : placed.object->mesh_o.vertices) {
      const double x = dir.dot(placed.world_from_object * Eigen::Vector3d(v[0], v[1], v[2]));
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    narrowest = std::min(narrowest, hi - lo);
  }
  return narrowest;
}

/// Candidate targets of the obstacles task passed over because no planner could succeed on them.
struct TargetSkips {
  int wider_than_the_stroke = 0;  ///< wider than the stroke in every direction
  int covered = 0;                ///< less than kMinVisibleFraction of it in view
};

/// The share of an object's own silhouette (rendered alone on the support) that the camera
/// sees in the scene: below 1 where something lies on it or stands in front of it.
double VisibleFraction(const sim::SimScene& scene, const sim::PlacedObject& object,
                       const cv::Mat1w& labels, const sim::RenderOptions& render) {
  sim::SimScene alone;
  alone.support = scene.support;
  alone.objects = {object};
  auto raycaster = sim::SceneRaycaster::Build(alone);
  if (!raycaster.ok()) return 0;
  const int own =
      cv::countNonZero(sim::Render(raycaster.value(), render).labels == object.instance_id);
  return own > 0 ? static_cast<double>(cv::countNonZero(labels == object.instance_id)) / own : 0;
}

/// Obstacles: the non-sponge object with the largest sponge share of the ring around its
/// visible mask (at least kMinSpongeRing) that a two-finger grasp could take at all (as the
/// thesis' targets, placed among sponges, not under them): not wider than the stroke in every
/// direction and at least kMinVisibleFraction in view. 0 when none qualifies.
int PickTarget(const sim::SimScene& scene, const cv::Mat1w& labels,
               const sim::RenderOptions& render, double stroke_m, TargetSkips* skips) {
  cv::Mat1b sponge(labels.size(), static_cast<unsigned char>(0));
  for (const auto& o : scene.objects) {
    if (o.object && o.object->category == "sponge") sponge.setTo(255, labels == o.instance_id);
  }
  const cv::Mat kernel =
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * kRingPx + 1, 2 * kRingPx + 1));
  std::vector<std::pair<double, const sim::PlacedObject*>> candidates;  // (share, object)
  for (const auto& o : scene.objects) {
    if (!o.object || o.object->category == "sponge") continue;
    const cv::Mat1b mask = labels == o.instance_id;
    if (cv::countNonZero(mask) < 200) continue;  // mostly hidden: not a fair target
    cv::Mat1b ring;
    cv::dilate(mask, ring, kernel);
    ring &= ~mask;
    const int ring_px = cv::countNonZero(ring);
    if (ring_px == 0) continue;
    const double share = static_cast<double>(cv::countNonZero(ring & sponge)) / ring_px;
    if (share >= kMinSpongeRing) candidates.emplace_back(share, &o);
  }
  // The largest share first; among equal shares the later object.
  std::reverse(candidates.begin(), candidates.end());
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& [share, o] : candidates) {
    if (NarrowestWidthM(*o) > stroke_m) {
      ++skips->wider_than_the_stroke;
    } else if (VisibleFraction(scene, *o, labels, render) < kMinVisibleFraction) {
      ++skips->covered;
    } else {
      return o->instance_id;
    }
  }
  return 0;
}

struct ClearingStats {
  int bins = 0, objects = 0, too_wide = 0, picked = 0, attempts = 0, damaged = 0;
  Mean deformation;
  std::vector<double> cleared_fraction, damage_rate, detect_ms;  // per bin (ms per attempt)
  json ToJson() const {
    const std::vector<int> all = AllScenes(cleared_fraction.size());
    std::vector<double> ms = detect_ms;
    std::sort(ms.begin(), ms.end());
    return {{"bins", bins},
            {"objects", objects},
            {"objects_wider_than_the_stroke", too_wide},
            {"picked", picked},
            {"attempts", attempts},
            {"damaged", damaged},
            {"cleared_fraction_of_clearable", Num(SampleMean(cleared_fraction, all))},
            {"damage_rate", Num(picked > 0 ? static_cast<double>(damaged) / picked : NAN)},
            {"mean_deformation_rate", Num(deformation.value())},
            {"ci95",
             {{"cleared_fraction_of_clearable", MeanInterval(cleared_fraction)},
              {"damage_rate_per_bin", MeanInterval(damage_rate)}}},
            {"detect_ms_median", ms.empty() ? json() : json(ms[ms.size() / 2])}};
  }
};

/// Paired comparison with FGE on the same bins: the difference of the cleared fractions, with its
/// 95 % interval over a bin bootstrap.
json VersusClearing(const ClearingStats& s, const ClearingStats& base) {
  const std::size_t n = base.cleared_fraction.size();
  if (n == 0 || s.cleared_fraction.size() != n) return json();
  const SceneStatistic difference = [&](std::span<const int> k) {
    return SampleMean(s.cleared_fraction, k) - SampleMean(base.cleared_fraction, k);
  };
  const Interval ci =
      BootstrapInterval(static_cast<int>(n), difference, kBootstrapResamples, kBootstrapSeed);
  return {{"cleared_fraction_difference",
           {{"value", Num(difference(AllScenes(n)))},
            {"ci95", json::array({Num(ci.low), Num(ci.high)})}}}};
}

/// Picks until the bin is empty, the planner finds nothing, or kMaxFailuresInARow picks fail
/// in a row; the camera re-renders the bin after every pick (picked objects leave; the others
/// stay where they lay). Nothing moves after a failed pick in the simulator, so the robot
/// remembers where it failed until the next pick changes the bin: contacts within half the
/// failed grasp's opening of its centre are left out of the next attempts (every planner alike;
/// otherwise each would repeat its failed grasp until the failures end the episode).
void ClearBin(const sim::GeneratedScene& generated, const sim::SceneSpec& spec,
              const Planner& planner, const Models& models, const core::Gripper& gripper,
              int max_attempts, ClearingStats* stats) {
  sim::SimScene scene = generated.scene;
  const core::Camera& camera = spec.render.camera;
  const cv::Mat1b roi = sim::BinWorkspaceRoi(spec, camera, kBinMarginPx);
  int clearable = 0;
  for (const auto& o : scene.objects) {
    if (NarrowestWidthM(o) > gripper.opening_stroke_m) {
      ++stats->too_wide;
    } else {
      ++clearable;
    }
  }
  ++stats->bins;
  stats->objects += static_cast<int>(scene.objects.size());
  int picked = 0, damaged = 0, failures = 0;
  cv::Mat1b allowed = roi.clone();  // the workspace less the places of failed picks
  for (int attempt = 0;
       attempt < max_attempts && !scene.objects.empty() && failures < kMaxFailuresInARow;
       ++attempt) {
    auto raycaster = sim::SceneRaycaster::Build(scene);
    if (!raycaster.ok()) break;
    sim::RenderOptions render = spec.render;
    render.noise.seed = generated.scene_seed + static_cast<std::uint64_t>(attempt) * 7919u;
    const sim::RenderedViews views = sim::Render(raycaster.value(), render);
    const Plan plan = RunPlanner(planner, views.depth, camera, allowed, {}, models, gripper);
    stats->detect_ms.push_back(plan.detect_ms);
    if (plan.grasps.empty()) break;  // nothing changes until something is picked
    ++stats->attempts;
    auto exec = sim::ExecuteGrasp(
        scene, raycaster.value(),
        sim::SimGraspFromCamera(plan.grasps.front(), render.world_from_camera), gripper);
    if (!exec.ok() || !exec.value().succeeded()) {
      ++failures;
      const core::Grasp& failed = plan.grasps.front();
      cv::circle(allowed,
                 cv::Point(static_cast<int>(std::lround(failed.center_u_px)),
                           static_cast<int>(std::lround(failed.center_v_px))),
                 std::max(1, static_cast<int>(std::lround(failed.opening_px / 2))), cv::Scalar(0),
                 cv::FILLED);
      continue;
    }
    failures = 0;
    roi.copyTo(allowed);
    const sim::GraspExecution& e = exec.value();
    ++picked;
    damaged += e.damaged ? 1 : 0;
    stats->deformation.Add(e.deformation_rate);
    scene.Remove(e.instance_id);
  }
  stats->picked += picked;
  stats->damaged += damaged;
  stats->cleared_fraction.push_back(
      clearable > 0 ? std::min(1.0, static_cast<double>(picked) / clearable) : std::nan(""));
  stats->damage_rate.push_back(picked > 0 ? static_cast<double>(damaged) / picked : std::nan(""));
}

/// evaluate-tasks' command line.
struct TasksOptions {
  std::string segmentation_path, stiffness_path, out_path;
  std::vector<Task> tasks;
  int clutter_scenes = 600, brush_scenes = 100, obstacle_scenes = 100, bins = 100,
      max_attempts = 30, threads = 2;
  std::uint64_t seed = 7;
  bool per_grasp = false;
  core::Gripper gripper;                    ///< planning and execution: the same one
  core::DeformabilityParams deformability;  ///< --openings; the policy is set per planner
};

/// --tasks: task names, comma-separated.
core::Result<std::vector<Task>> ParseTasks(const std::string& text) {
  std::vector<Task> tasks;
  for (std::size_t start = 0; start <= text.size();) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string name = text.substr(start, comma - start);
    if (name == "clutter") {
      tasks.push_back(Task::kClutter);
    } else if (name == "brushes") {
      tasks.push_back(Task::kBrushes);
    } else if (name == "obstacles") {
      tasks.push_back(Task::kObstacles);
    } else {
      return core::MakeError(
          core::ErrorCode::kInvalidArgument,
          "--tasks takes clutter, brushes and obstacles, comma-separated; got '" + name + "'",
          "--tasks");
    }
    start = comma + 1;
  }
  return tasks;
}

/// --openings: increasing fractions of the stroke in (0, 1], comma-separated.
core::Result<std::vector<double>> ParseOpenings(const std::string& text) {
  std::vector<double> fractions;
  for (std::size_t start = 0; start <= text.size();) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    double f = 0;
    if (!cli::ParseNumber(text.substr(start, comma - start), &f) || !(f > 0 && f <= 1) ||
        (!fractions.empty() && !(f > fractions.back()))) {
      return core::MakeError(core::ErrorCode::kInvalidArgument,
                             "--openings takes increasing fractions of the stroke in (0, 1], "
                             "comma-separated",
                             "--openings");
    }
    fractions.push_back(f);
    start = comma + 1;
  }
  return fractions;
}

core::Result<TasksOptions> ParseTasksOptions(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  TasksOptions o;
  std::string openings_text, tasks_text = "clutter,brushes,obstacles";
  int stroke_mm = 85;
  args.Required("--segmentation-model", "FILE", &o.segmentation_path);
  args.Text("--stiffness-model", &o.stiffness_path);
  args.Text("--out", &o.out_path);
  args.Text("--tasks", &tasks_text);
  args.Text("--openings", &openings_text);
  args.Count("--clutter-scenes", &o.clutter_scenes);
  args.Count("--brush-scenes", &o.brush_scenes);
  args.Count("--obstacle-scenes", &o.obstacle_scenes);
  args.Count("--bins", &o.bins);
  args.Count("--max-attempts", &o.max_attempts);
  args.Int("--seed", 0, cli::kNoLimit, &o.seed);
  args.Int("--threads", 1, 256, &o.threads);
  args.Int("--stroke-mm", 10, 300, &stroke_mm);
  o.per_grasp = args.Flag("--per-grasp");
  if (const auto error = args.Finish()) return *error;
  o.gripper.opening_stroke_m = stroke_mm * 1e-3;
  auto tasks = ParseTasks(tasks_text);
  if (!tasks.ok()) return tasks.error();
  o.tasks = std::move(tasks).value();
  if (!openings_text.empty()) {
    auto openings = ParseOpenings(openings_text);
    if (!openings.ok()) return openings.error();
    o.deformability.opening_fractions = std::move(openings).value();
  }
  return o;
}

/// The segmentation model and, with --stiffness-model, the stiffness model.
core::Result<Models> LoadTaskModels(const TasksOptions& o) {
  Models models{{}, o.deformability};
  auto segmentation = models::SegmentationModel::Load(o.segmentation_path);
  if (!segmentation.ok()) return segmentation.error();
  models.loaded.segmentation =
      std::make_shared<const models::SegmentationModel>(std::move(segmentation).value());
  if (!o.stiffness_path.empty()) {
    auto stiffness = models::StiffnessModel::Load(o.stiffness_path);
    if (!stiffness.ok()) return stiffness.error();
    models.loaded.stiffness =
        std::make_shared<const models::StiffnessModel>(std::move(stiffness).value());
  }
  return models;
}

/// One task's one-grasp scenes: `wanted` scenes of validation shapes (obstacles: draws without a
/// fair target among sponges are passed over), on each of which every planner plans once and
/// its best grasp is executed. The task's report without bin clearing.
core::Result<json> RunTaskScenes(Task task, const sim::SceneSpec& spec, int wanted,
                                 const TasksOptions& o, const Models& models,
                                 const std::vector<Planner>& planners, cli::ProgressBar* bar) {
  const cv::Mat1b roi = sim::BinWorkspaceRoi(spec, spec.render.camera, kBinMarginPx);
  std::vector<Stats> stats(planners.size());
  int used = 0, skipped = 0;
  TargetSkips target_skips;
  for (int i = 0; used < wanted && i < 5 * wanted + 10; ++i) {
    bar->Update(used);
    const std::uint64_t scene_seed =
        sim::SceneSeed(o.seed + static_cast<int>(task) * 1000003u, i, sim::ShapeSplit::kVal);
    auto generated = sim::GenerateScene(spec, scene_seed);
    if (!generated.ok()) return generated.error();
    const sim::GeneratedScene& g = generated.value();
    int target_id = 0;
    cv::Mat1b target_mask;
    if (task == Task::kObstacles) {
      target_id = PickTarget(g.scene, g.views.labels, spec.render, o.gripper.opening_stroke_m,
                             &target_skips);
      if (target_id == 0) {
        ++skipped;  // no object packed among sponges in this draw
        continue;
      }
      target_mask = g.views.labels == target_id;
    }
    auto raycaster = sim::SceneRaycaster::Build(g.scene);
    if (!raycaster.ok()) return raycaster.error();
    for (std::size_t p = 0; p < planners.size(); ++p) {
      const Plan plan = RunPlanner(planners[p], g.views.depth, spec.render.camera, roi, target_mask,
                                   models, o.gripper);
      Record(task, g.scene, raycaster.value(), spec.render.world_from_camera, plan, target_id,
             o.per_grasp, o.gripper, &stats[p]);
    }
    ++used;
  }
  bar->Update(wanted);
  json task_json = {{"scenes", used},
                    {"draws_without_a_target_among_sponges", skipped},
                    {"candidate_targets_passed_over",
                     {{"wider_than_the_stroke", target_skips.wider_than_the_stroke},
                      {"covered", target_skips.covered}}},
                    {"spec", sim::SceneSpecToJson(spec)},
                    {"planners", json::object()},
                    {"versus_fge", json::object()}};
  for (std::size_t p = 0; p < planners.size(); ++p) {
    task_json["planners"][planners[p].name] = stats[p].ToJson();
    if (p > 0) task_json["versus_fge"][planners[p].name] = Versus(stats[p], stats[0]);
  }
  return task_json;
}

/// Bin clearing in `o.bins` clutter bins, every planner on the same bins: the clutter task's
/// "bin_clearing" and "bin_clearing_versus_fge".
core::Result<json> RunBinClearing(const sim::SceneSpec& spec, const TasksOptions& o,
                                  const Models& models, const std::vector<Planner>& planners,
                                  cli::ProgressBar* bar) {
  std::vector<ClearingStats> clearing(planners.size());
  for (int b = 0; b < o.bins; ++b) {
    bar->Update(b);
    auto generated =
        sim::GenerateScene(spec, sim::SceneSeed(o.seed + 77u, b, sim::ShapeSplit::kVal));
    if (!generated.ok()) return generated.error();
    for (std::size_t p = 0; p < planners.size(); ++p) {
      ClearBin(generated.value(), spec, planners[p], models, o.gripper, o.max_attempts,
               &clearing[p]);
    }
  }
  bar->Update(o.bins);
  json bin_json = json::object();
  for (std::size_t p = 0; p < planners.size(); ++p) {
    bin_json[planners[p].name] = clearing[p].ToJson();
  }
  json versus = json::object();
  for (std::size_t p = 1; p < planners.size(); ++p) {
    versus[planners[p].name] = VersusClearing(clearing[p], clearing[0]);
  }
  return json{{"bin_clearing", bin_json}, {"bin_clearing_versus_fge", versus}};
}

}  // namespace

int RunEvaluateTasks(std::vector<std::string> argv) {
  auto options = ParseTasksOptions(std::move(argv));
  if (!options.ok()) return Fail(kCommand, options.error().message);
  const TasksOptions& o = options.value();
  models::SetTorchThreads(o.threads);
  cv::setNumThreads(o.threads);
  auto loaded = LoadTaskModels(o);
  if (!loaded.ok()) return Fail(kCommand, loaded.error().message);
  const Models& models = loaded.value();
  const std::vector<Planner> planners = Planners(models.loaded.stiffness != nullptr);

  json out = {{"segmentation_model", o.segmentation_path},
              {"stiffness_model", o.stiffness_path.empty() ? json() : json(o.stiffness_path)},
              {"seed", o.seed},
              {"opening_fractions", models.deformability.opening_fractions},
              {"gripper", codec::ToJson(o.gripper)},
              {"bootstrap", {{"resamples", kBootstrapResamples}, {"seed", kBootstrapSeed}}},
              {"tasks", json::object()}};
  for (const Task task : o.tasks) {
    const sim::SceneSpec spec = TaskSpec(task);
    const int wanted = task == Task::kClutter   ? o.clutter_scenes
                       : task == Task::kBrushes ? o.brush_scenes
                                                : o.obstacle_scenes;
    cli::ProgressBar bar(std::string(TaskName(task)) + " scenes", wanted);
    auto task_json = RunTaskScenes(task, spec, wanted, o, models, planners, &bar);
    if (!task_json.ok()) return Fail(kCommand, task_json.error().message);
    if (task == Task::kClutter && o.bins > 0) {
      cli::ProgressBar bin_bar("bin clearing", o.bins);
      auto clearing = RunBinClearing(spec, o, models, planners, &bin_bar);
      if (!clearing.ok()) return Fail(kCommand, clearing.error().message);
      task_json.value().update(clearing.value());
    }
    out["tasks"][TaskName(task)] = task_json.value();
  }
  const std::string text = out.dump(2);
  std::cout << text << std::endl;
  if (!o.out_path.empty()) {
    if (const auto error = cli::WriteFile(o.out_path, text + "\n")) {
      return Fail(kCommand, error->message);
    }
  }
  return 0;
}

}  // namespace softgrasp::tools
