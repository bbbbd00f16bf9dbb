#include "tools/train/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "service/cli/args.h"
#include "service/cli/progress.h"
#include "service/core/fge_stiffness.h"
#include "service/core/metrics.h"
#include "service/core/preprocess.h"
#include "service/engine/engine.h"
#include "service/engine/strategies/stiffness.h"
#include "service/models/stiffness_model.h"
#include "sim/dataset/scene_gen.h"
#include "sim/grasp/execute.h"
#include "tools/train/bootstrap.h"
#include "tools/train/cli_common.h"
#include "train/dataset.h"

namespace softgrasp::tools {
namespace {

using nlohmann::json;

constexpr std::string_view kCommand = "evaluate";

/// The mean of every training target pixel (background included): the constant baseline.
core::Result<double> TrainingMean(const std::filesystem::path& dir) {
  auto ds = models::SceneDataset::Open(dir);
  if (!ds.ok()) return ds.error();
  double sum = 0;
  double n = 0;
  for (int i = 0; i < ds.value().size(); ++i) {
    const std::string path = ds.value().entry(i).stem.string() + "_stiffness.png";
    const cv::Mat s = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (s.empty() || s.type() != CV_8UC1) {
      return core::MakeError(core::ErrorCode::kUnprocessable, "cannot read " + path, "train-data");
    }
    sum += cv::sum(s)[0] / 255.0;
    n += static_cast<double>(s.total());
  }
  return sum / n;
}

}  // namespace

cv::Mat1f HeuristicStiffness(const core::Scene& scene, const core::Camera& camera) {
  const cv::Mat1f& h = scene.height_m;
  const cv::Mat1b object = h > 0.005f;
  cv::Mat1b inner = object.clone();
  for (int v = 0; v < h.rows; ++v) {
    for (int u = 0; u < h.cols; ++u) {
      if (!object(v, u)) continue;
      const bool edge = (u + 1 < h.cols && std::abs(h(v, u + 1) - h(v, u)) > 0.005f) ||
                        (u > 0 && std::abs(h(v, u - 1) - h(v, u)) > 0.005f) ||
                        (v + 1 < h.rows && std::abs(h(v + 1, u) - h(v, u)) > 0.005f) ||
                        (v > 0 && std::abs(h(v - 1, u) - h(v, u)) > 0.005f);
      if (edge) inner(v, u) = 0;
    }
  }
  cv::Mat1f dist_px;
  cv::distanceTransform(inner, dist_px, cv::DIST_L2, 3);
  // Millimetres at the floor (fx pixels per metre at 1 m): fine for a baseline.
  const double floor_depth = std::abs(scene.floor.d / scene.floor.n[2]);
  const double px_per_mm = camera.fx / floor_depth / 1000.0;
  cv::Mat1f out(h.size(), 0.0f);
  for (int v = 0; v < h.rows; ++v) {
    for (int u = 0; u < h.cols; ++u) {
      if (!object(v, u)) continue;
      const double d_mm = dist_px(v, u) / px_per_mm;
      out(v, u) = static_cast<float>(0.3 + 0.5 * std::min(1.0, d_mm / 20.0));
    }
  }
  return out;
}

namespace {

/// The scene spec a dataset was generated with: the full spec when index.json has it (camera
/// included), else the fields older indexes held (the default camera).
core::Result<sim::SceneSpec> SpecFromIndex(const json& index) {
  if (index.contains("spec")) return sim::SceneSpecFromJson(index.at("spec"));
  sim::SceneSpec spec;
  try {
    spec.split = index.at("split").get<std::string>() == "val" ? sim::ShapeSplit::kVal
                                                               : sim::ShapeSplit::kTrain;
    spec.min_objects = index.at("objects").at(0).get<int>();
    spec.max_objects = index.at("objects").at(1).get<int>();
    const json& s = index.at("support");
    spec.support.kind = s.at("kind").get<std::string>() == "table" ? sim::Support::Kind::kTable
                                                                   : sim::Support::Kind::kBin;
    spec.support.inner_size_x_m = s.at("inner_size_m").at(0).get<double>();
    spec.support.inner_size_y_m = s.at("inner_size_m").at(1).get<double>();
    spec.support.wall_height_m = s.at("wall_height_m").get<double>();
    spec.support.wall_thickness_m = s.at("wall_thickness_m").get<double>();
    spec.support.thickness_m = s.at("thickness_m").get<double>();
    spec.support.ground_size_m = s.at("ground_size_m").get<double>();
    spec.render.noise.enabled = index.at("noise").get<bool>();
    spec.fractal_probability = index.at("fractal_probability").get<double>();
  } catch (const json::exception& e) {
    return core::MakeError(core::ErrorCode::kUnprocessable,
                           std::string("index.json lacks scene parameters: ") + e.what(), "data");
  }
  return spec;
}

// Bootstrap over grasp scenes for the 95 % intervals (tools/train/bootstrap.h): fixed, so the
// same evaluation prints the same intervals.
constexpr int kBootstrapResamples = 2000;
constexpr std::uint64_t kBootstrapSeed = 1;

Interval SceneInterval(std::size_t scenes, const SceneStatistic& statistic) {
  return BootstrapInterval(static_cast<int>(scenes), statistic, kBootstrapResamples,
                           kBootstrapSeed);
}

json IntervalJson(const Interval& ci) { return json::array({Num(ci.low), Num(ci.high)}); }

/// One planner's executed grasps on one catalogue category (the object under the grasp centre).
struct ObjectOutcomes {
  int grasps = 0;
  int succeeded = 0;
  int damaged = 0;
  Mean deformation_rate;  // as StrategyStats::deformation_rate
  json ToJson() const {
    return {{"grasps", grasps},
            {"succeeded", succeeded},
            {"damaged", damaged},
            {"mean_deformation_rate", Num(deformation_rate.value())}};
  }
};

struct StrategyStats {
  Mean gt_mean_stiffness;  // eq. 3.14 on the ground-truth map
  Mean deformation_rate;   // over grasps that closed on one object (succeeded or slipped)
  int attempts = 0;
  int no_grasp = 0;
  int succeeded = 0;
  int damaged = 0;
  std::map<std::string, int> outcomes;
  std::map<std::string, std::string> example_reason;  // first reason per outcome
  std::map<std::string, ObjectOutcomes> by_object;    // per category under the grasp centre
  json per_grasp = json::array();  // with --per-grasp: one record per executed top grasp
  // One entry per grasp scene, in scene order (the same for every planner), for the bootstrap:
  // NaN where the scene has no such figure (no grasp; no single-object contact to deform).
  std::vector<double> scene_gt_stiffness, scene_deformation, scene_success;
  json ToJson() const {
    json o = {{"scenes", attempts + no_grasp},
              {"grasps", attempts},
              {"no_grasp", no_grasp},
              {"mean_gt_stiffness_in_region", Num(gt_mean_stiffness.value())},
              {"mean_deformation_rate", Num(deformation_rate.value())},
              {"success_rate", attempts + no_grasp > 0
                                   ? json(static_cast<double>(succeeded) / (attempts + no_grasp))
                                   : json(nullptr)},
              {"damage_rate",
               attempts > 0 ? json(static_cast<double>(damaged) / attempts) : json(nullptr)},
              {"outcomes", outcomes},
              {"example_reason", example_reason},
              {"by_object", json::object()}};
    for (const auto& [category, counts] : by_object) o["by_object"][category] = counts.ToJson();
    if (!scene_success.empty()) {
      const auto mean_of = [](const std::vector<double>& v) {
        return [&v](std::span<const int> sample) { return SampleMean(v, sample); };
      };
      const std::size_t n = scene_success.size();
      o["ci95"] = {
          {"mean_gt_stiffness_in_region",
           IntervalJson(SceneInterval(n, mean_of(scene_gt_stiffness)))},
          {"mean_deformation_rate", IntervalJson(SceneInterval(n, mean_of(scene_deformation)))},
          {"success_rate", IntervalJson(SceneInterval(n, mean_of(scene_success)))}};
    }
    if (!per_grasp.empty()) o["per_grasp"] = per_grasp;
    return o;
  }
};

/// Planner `s` against planner `base` (classic FGE, or the first model's planner for
/// --compare), each figure with its 95 % interval over the same resampled scenes: mean true
/// stiffness in the grasp region as a gain (s / base - 1), mean deformation as a ratio
/// (s / base; the goal "at most half of FGE's" is a ratio <= 0.5), success as a difference
/// (s - base).
json Versus(const StrategyStats& s, const StrategyStats& base) {
  const std::size_t n = base.scene_success.size();
  if (n == 0 || s.scene_success.size() != n) return json();
  const auto gain = [&](std::span<const int> k) {
    return SampleMean(s.scene_gt_stiffness, k) / SampleMean(base.scene_gt_stiffness, k) - 1.0;
  };
  const auto ratio = [&](std::span<const int> k) {
    return SampleMean(s.scene_deformation, k) / SampleMean(base.scene_deformation, k);
  };
  const auto difference = [&](std::span<const int> k) {
    return SampleMean(s.scene_success, k) - SampleMean(base.scene_success, k);
  };
  std::vector<int> all(n);
  for (std::size_t i = 0; i < n; ++i) all[i] = static_cast<int>(i);
  json out = json::object();
  const std::vector<std::pair<const char*, SceneStatistic>> statistics = {
      {"stiffness_gain", gain}, {"deformation_ratio", ratio}, {"success_difference", difference}};
  for (const auto& [name, statistic] : statistics) {
    out[name] = {{"value", Num(statistic(all))},
                 {"ci95", IntervalJson(SceneInterval(n, statistic))}};
  }
  return out;
}

/// The model's map against the truth on one object category's visible pixels.
struct CategoryError {
  Mean truth, predicted, abs_error;
};

void AddCategoryErrors(const sim::SimScene& scene, const cv::Mat1w& labels, const cv::Mat1f& truth,
                       const cv::Mat1f& predicted, std::map<std::string, CategoryError>* out) {
  std::map<int, CategoryError*> by_id;
  for (const sim::PlacedObject& o : scene.objects) {
    by_id[o.instance_id] = &(*out)[o.object->category];
  }
  for (int r = 0; r < labels.rows; ++r) {
    for (int c = 0; c < labels.cols; ++c) {
      const auto it = by_id.find(labels(r, c));
      if (it == by_id.end() || !(truth(r, c) > 0)) continue;
      it->second->truth.Add(truth(r, c));
      it->second->predicted.Add(predicted(r, c));
      it->second->abs_error.Add(std::abs(predicted(r, c) - truth(r, c)));
    }
  }
}

json CategoryErrorsJson(const std::map<std::string, CategoryError>& by_category) {
  json out = json::object();
  for (const auto& [category, e] : by_category) {
    out[category] = {{"mean_truth", Num(e.truth.value())},
                     {"mean_predicted", Num(e.predicted.value())},
                     {"mean_abs_error", Num(e.abs_error.value())}};
  }
  return out;
}

void Execute(const sim::SimScene& scene, const sim::SceneRaycaster& raycaster,
             const Eigen::Isometry3d& world_from_camera, const std::vector<core::Grasp>& grasps,
             const core::Gripper& gripper, const cv::Mat1f& truth, const cv::Mat1w& labels,
             int scene_index, bool per_grasp, StrategyStats* stats) {
  stats->scene_gt_stiffness.push_back(std::nan(""));
  stats->scene_deformation.push_back(std::nan(""));
  stats->scene_success.push_back(0.0);
  if (grasps.empty()) {
    ++stats->no_grasp;
    return;
  }
  const core::Grasp& g = grasps.front();
  ++stats->attempts;
  const double true_mean = core::MeanStiffnessInGraspRegion(truth, g);
  stats->gt_mean_stiffness.Add(true_mean);
  stats->scene_gt_stiffness.back() = true_mean;
  // The object under the grasp centre (labels are instance ids, 0 = support).
  const int u = std::clamp(static_cast<int>(std::lround(g.center_u_px)), 0, labels.cols - 1);
  const int v = std::clamp(static_cast<int>(std::lround(g.center_v_px)), 0, labels.rows - 1);
  const sim::PlacedObject* object = scene.Find(labels(v, u));
  const std::string category = object ? object->object->category : "none";
  ObjectOutcomes& on_object = stats->by_object[category];
  ++on_object.grasps;
  auto exec =
      sim::ExecuteGrasp(scene, raycaster, sim::SimGraspFromCamera(g, world_from_camera), gripper);
  if (!exec.ok()) {
    ++stats->outcomes["error"];
    return;
  }
  const sim::GraspExecution& e = exec.value();
  if (per_grasp) {
    stats->per_grasp.push_back({{"scene", scene_index},
                                {"object", category},
                                {"outcome", sim::GraspOutcomeName(e.outcome)},
                                {"planner_mean_stiffness", Num(g.mean_stiffness)},
                                {"true_mean_stiffness", Num(true_mean)},
                                {"deformation_rate", Num(e.deformation_rate)},
                                {"center_px", {g.center_u_px, g.center_v_px}},
                                {"angle_rad", g.angle_rad}});
  }
  ++stats->outcomes[sim::GraspOutcomeName(e.outcome)];
  stats->example_reason.emplace(sim::GraspOutcomeName(e.outcome), e.reason);
  if (e.outcome == sim::GraspOutcome::kSucceeded || e.outcome == sim::GraspOutcome::kSlipped) {
    stats->deformation_rate.Add(e.deformation_rate);
    on_object.deformation_rate.Add(e.deformation_rate);
    stats->scene_deformation.back() = e.deformation_rate;
  }
  if (e.succeeded()) {
    ++stats->succeeded;
    ++on_object.succeeded;
    stats->scene_success.back() = 1.0;
  }
  if (e.damaged) {
    ++stats->damaged;
    ++on_object.damaged;
  }
}

/// evaluate's command line.
struct EvaluateOptions {
  std::string model_path, compare_path, data, train_data;
  int max_scenes = 0;
  int grasp_scenes = 50;
  int threads = 2;
  double constant = std::nan("");  ///< the constant baseline's value; NaN: --train-data's mean
  core::StiffnessFgeParams stiffness_params;
  bool per_grasp = false;
};

core::Result<EvaluateOptions> ParseEvaluateOptions(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  EvaluateOptions o;
  args.Required("--model", "MODEL", &o.model_path);
  args.Required("--data", "VALDIR", &o.data);
  args.Text("--train-data", &o.train_data);
  args.Text("--compare", &o.compare_path);
  args.Number("--constant", cli::Bounds::Closed(0, 1), &o.constant);
  args.Count("--scenes", &o.max_scenes);
  args.Count("--grasp-scenes", &o.grasp_scenes);
  o.per_grasp = args.Flag("--per-grasp");
  args.Number("--centre-weight", cli::Bounds::AtLeast(0), &o.stiffness_params.centre_weight);
  args.Int("--threads", 1, 256, &o.threads);
  if (const auto error = args.Finish()) return *error;
  if (o.train_data.empty() && !std::isfinite(o.constant)) {
    return core::MakeError(
        core::ErrorCode::kInvalidArgument,
        "the constant baseline needs --train-data DIR (its mean) or --constant C", "train-data");
  }
  return o;
}

/// What evaluate reads before the first scene.
struct EvaluateInputs {
  models::StiffnessModel model;
  /// --compare: a second model whose planner runs on the same scenes (paired with the first's).
  std::optional<models::StiffnessModel> compared;
  models::SceneDataset val;
  double constant = 0;  ///< the constant baseline's value
  sim::SceneSpec spec;  ///< the one the validation set was generated with
};

core::Result<EvaluateInputs> LoadEvaluateInputs(const EvaluateOptions& o) {
  auto model = models::StiffnessModel::Load(o.model_path);
  if (!model.ok()) return model.error();
  std::optional<models::StiffnessModel> compared;
  if (!o.compare_path.empty()) {
    auto loaded = models::StiffnessModel::Load(o.compare_path);
    if (!loaded.ok()) return loaded.error();
    compared.emplace(std::move(loaded).value());
  }
  auto val = models::SceneDataset::Open(o.data);
  if (!val.ok()) return val.error();
  double constant = o.constant;
  if (!std::isfinite(constant)) {
    auto mean = TrainingMean(o.train_data);
    if (!mean.ok()) return mean.error();
    constant = mean.value();
  }
  auto spec = SpecFromIndex(val.value().index());
  if (!spec.ok()) return spec.error();
  return EvaluateInputs{std::move(model).value(), std::move(compared), std::move(val).value(),
                        constant, std::move(spec).value()};
}

/// What evaluate gathers over the scenes: the maps' image metrics, prediction times, the map's
/// errors per category and each planner's executed grasps.
struct EvaluateTotals {
  Mean rmse_model, rmse_const, rmse_heur, mssim_model, mssim_const, mssim_heur;
  Mean rmse_compared, mssim_compared;
  std::vector<double> predict_ms;
  StrategyStats fge, stiff, oracle, stiff_compared;
  std::map<std::string, CategoryError> by_category;
  int skipped = 0, mismatched = 0;
};

/// One scene's maps, predicted on its preprocessed depth: the models', and the workspace ROI the
/// heuristic and the planners keep to (a bin's; empty on a table).
struct SceneMaps {
  cv::Mat1f predicted, predicted_compared;
  cv::Mat1b roi;
};

/// Predicts the scene's maps and adds their image metrics (and the heuristic's and the constant
/// baseline's) to `totals`; nothing when the depth cannot be preprocessed (counted as skipped).
std::optional<SceneMaps> ScoreMaps(const EvaluateInputs& in, const models::SceneSample& s,
                                   EvaluateTotals* totals) {
  const auto t0 = std::chrono::steady_clock::now();
  auto scene = core::Preprocess(s.depth, s.camera);
  if (!scene.ok()) {
    ++totals->skipped;
    return std::nullopt;
  }
  SceneMaps maps;
  maps.predicted = in.model.PredictScene(scene.value());
  totals->predict_ms.push_back(MillisecondsSince(t0));
  if (in.compared) maps.predicted_compared = in.compared->PredictScene(scene.value());
  const cv::Mat1f constant_map(s.stiffness.size(), static_cast<float>(in.constant));
  // The heuristic works inside the bin (a workspace ROI); the model sees it all.
  const bool bin = in.spec.support.kind == sim::Support::Kind::kBin;
  if (bin) maps.roi = sim::BinWorkspaceRoi(in.spec, s.camera, 3);
  core::Scene in_bin = scene.value();
  in_bin.height_m = in_bin.height_m.clone();  // masked below; the models saw the whole view
  if (bin) in_bin.height_m.setTo(0.0f, maps.roi == 0);
  const cv::Mat1f heuristic = HeuristicStiffness(in_bin, s.camera);
  if (in.compared) {
    totals->rmse_compared.Add(core::StiffnessRmse255(s.stiffness, maps.predicted_compared).value());
    totals->mssim_compared.Add(core::StiffnessMssim(s.stiffness, maps.predicted_compared).value());
  }
  totals->rmse_model.Add(core::StiffnessRmse255(s.stiffness, maps.predicted).value());
  totals->rmse_const.Add(core::StiffnessRmse255(s.stiffness, constant_map).value());
  totals->rmse_heur.Add(core::StiffnessRmse255(s.stiffness, heuristic).value());
  totals->mssim_model.Add(core::StiffnessMssim(s.stiffness, maps.predicted).value());
  totals->mssim_const.Add(core::StiffnessMssim(s.stiffness, constant_map).value());
  totals->mssim_heur.Add(core::StiffnessMssim(s.stiffness, heuristic).value());
  return maps;
}

/// Rebuilds scene `i` exactly (GenerateScene is deterministic in its seed) and executes each
/// planner's best grasp in it: classic FGE, stiffness FGE on the model's map, on the true map and
/// on the compared model's. A scene that does not rebuild to the stored labels (the set was made
/// with other parameters) is counted as mismatched and its grasps are skipped.
std::optional<core::Error> ExecuteGrasps(const EvaluateOptions& o, const EvaluateInputs& in,
                                         const models::SceneSample& s, int i, const SceneMaps& maps,
                                         EvaluateTotals* totals) {
  auto generated = sim::GenerateScene(in.spec, in.val.entry(i).scene_seed);
  if (!generated.ok()) return generated.error();
  const sim::GeneratedScene& g = generated.value();
  if (cv::norm(g.views.labels, s.labels, cv::NORM_INF) != 0) {
    ++totals->mismatched;  // the dataset was not made with these parameters: skip its grasps
    return std::nullopt;
  }
  AddCategoryErrors(g.scene, s.labels, s.stiffness, maps.predicted, &totals->by_category);
  auto raycaster = sim::SceneRaycaster::Build(g.scene);
  if (!raycaster.ok()) return raycaster.error();
  const Eigen::Isometry3d& world_from_camera = in.spec.render.world_from_camera;
  // The service's engine plans, with contacts inside the bin (the walls stay obstacles) and
  // the maps already computed above; planning and execution share one gripper.
  const engine::Models engine_models;  // none loaded: every map is given
  engine::PlanOptions options;
  options.region_of_interest = maps.roi;
  auto stiffness_options = std::make_shared<engine::StiffnessOptions>();
  stiffness_options->params = o.stiffness_params;
  const auto plan = [&](const std::string& strategy, const cv::Mat1f& map) {
    options.strategy = strategy;
    options.strategy_options = strategy == "stiffness" ? stiffness_options : nullptr;
    options.stiffness_map = map;
    std::vector<core::Grasp> grasps;
    auto planned = engine::PlanGrasps(s.depth, s.camera, options, engine_models);
    if (planned.ok()) {
      for (const engine::PlannedGrasp& p : planned.value().grasps) grasps.push_back(p.grasp);
    }
    return grasps;
  };
  const auto execute = [&](const std::vector<core::Grasp>& grasps, StrategyStats* stats) {
    Execute(g.scene, raycaster.value(), world_from_camera, grasps, options.gripper, s.stiffness,
            s.labels, i, o.per_grasp, stats);
  };
  execute(plan("fge", cv::Mat1f()), &totals->fge);
  execute(plan("stiffness", maps.predicted), &totals->stiff);
  execute(plan("stiffness", s.stiffness), &totals->oracle);
  if (in.compared) {
    execute(plan("stiffness", maps.predicted_compared), &totals->stiff_compared);
  }
  return std::nullopt;
}

/// evaluate's report: the image metrics of the model and the baselines, the prediction time, the
/// map's errors per category and the grasp figures of every planner against classic FGE.
json EvaluateJson(const EvaluateOptions& o, const EvaluateInputs& in, const EvaluateTotals& totals,
                  int n, int n_grasp) {
  std::vector<double> predict_ms = totals.predict_ms;
  std::sort(predict_ms.begin(), predict_ms.end());
  const double median_ms = predict_ms.empty() ? std::nan("") : predict_ms[predict_ms.size() / 2];
  const StrategyStats& fge = totals.fge;
  const StrategyStats& stiff = totals.stiff;
  const double fge_s = fge.gt_mean_stiffness.value();
  const double st_s = stiff.gt_mean_stiffness.value();
  json out = {
      {"model", o.model_path},
      {"model_description", in.model.description()},
      {"data", o.data},
      {"scenes", n - totals.skipped},
      {"skipped_scenes", totals.skipped},
      {"image_metrics",
       {{"model",
         {{"rmse_255", Num(totals.rmse_model.value())},
          {"mssim", Num(totals.mssim_model.value())}}},
        {"constant_baseline",
         {{"value", in.constant},
          {"rmse_255", Num(totals.rmse_const.value())},
          {"mssim", Num(totals.mssim_const.value())}}},
        {"heuristic_baseline",
         {{"rmse_255", Num(totals.rmse_heur.value())},
          {"mssim", Num(totals.mssim_heur.value())}}}}},
      {"predict_ms_median_incl_preprocess", Num(median_ms)},
      // Object pixels of the grasp scenes, per catalogue category: where the map is wrong.
      {"object_pixels_by_category", CategoryErrorsJson(totals.by_category)},
      {"grasp_metrics",
       {{"scenes", n_grasp},
        {"scenes_not_reproduced", totals.mismatched},
        {"fge", fge.ToJson()},
        {"stiffness_model", stiff.ToJson()},
        {"stiffness_ground_truth", totals.oracle.ToJson()},
        {"mean_stiffness_gain", Num(st_s / fge_s - 1.0)},
        // Paired percentile bootstrap over the grasp scenes (docs/stiffness.md, "Evaluation").
        {"versus_fge",
         {{"bootstrap", {{"resamples", kBootstrapResamples}, {"seed", kBootstrapSeed}}},
          {"stiffness_model", Versus(stiff, fge)},
          {"stiffness_ground_truth", Versus(totals.oracle, fge)}}}}},
  };
  if (in.compared) {
    // The second model: its map's scores, its planner's figures, and the paired comparison
    // of its planner with the first model's (compared / first).
    out["compared_model"] = {{"model", o.compare_path},
                             {"model_description", in.compared->description()},
                             {"image_metrics",
                              {{"rmse_255", Num(totals.rmse_compared.value())},
                               {"mssim", Num(totals.mssim_compared.value())}}}};
    out["grasp_metrics"]["stiffness_compared_model"] = totals.stiff_compared.ToJson();
    out["grasp_metrics"]["versus_fge"]["stiffness_compared_model"] =
        Versus(totals.stiff_compared, fge);
    out["grasp_metrics"]["compared_versus_model"] = Versus(totals.stiff_compared, stiff);
  }
  return out;
}

}  // namespace

int RunEvaluate(std::vector<std::string> argv) {
  auto options = ParseEvaluateOptions(std::move(argv));
  if (!options.ok()) return Fail(kCommand, options.error().message);
  const EvaluateOptions& o = options.value();
  models::SetTorchThreads(o.threads);
  cv::setNumThreads(o.threads);
  auto inputs = LoadEvaluateInputs(o);
  if (!inputs.ok()) return Fail(kCommand, inputs.error().message);
  const EvaluateInputs& in = inputs.value();

  const int n = o.max_scenes > 0 ? std::min(o.max_scenes, in.val.size()) : in.val.size();
  const int n_grasp = std::min(o.grasp_scenes, n);
  EvaluateTotals totals;
  cli::ProgressBar bar("evaluating", n);
  for (int i = 0; i < n; ++i) {
    bar.Update(i);
    auto sample = in.val.Load(i);
    if (!sample.ok()) return Fail(kCommand, sample.error().message);
    const models::SceneSample& s = sample.value();
    const std::optional<SceneMaps> maps = ScoreMaps(in, s, &totals);
    if (!maps || i >= n_grasp) continue;
    if (const auto error = ExecuteGrasps(o, in, s, i, *maps, &totals)) {
      return Fail(kCommand, error->message);
    }
  }
  bar.Update(n);
  std::cout << EvaluateJson(o, in, totals, n, n_grasp).dump(2) << std::endl;
  return 0;
}

}  // namespace softgrasp::tools
