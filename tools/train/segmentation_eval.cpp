// softgrasp-train evaluate-segmentation: the segmentation model against the PCL baseline on
// validation sets (docs/segmentation.md, "Evaluation").

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "service/cli/args.h"
#include "service/cli/progress.h"
#include "service/core/metrics.h"
#include "service/core/preprocess.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/segmentation/fuse.h"
#include "service/segmentation/instance_metrics.h"
#include "service/segmentation/pcl_segmenter.h"
#include "tools/train/cli_common.h"
#include "tools/train/segmentation_cli.h"
#include "train/dataset.h"

namespace softgrasp::tools {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr std::string_view kCommand = "evaluate-segmentation";

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

json ScoresJson(const segmentation::MaskScores& s) {
  json per_category = json::object();
  for (const auto& [name, c] : s.per_category) {
    per_category[name] = {{"instances", c.instances},
                          {"recall50", Num(c.recall50)},
                          {"ar", Num(c.ar)},
                          {"mean_best_iou", Num(c.mean_best_iou)}};
  }
  return {{"ap", Num(s.ap)},
          {"ap50", Num(s.ap50)},
          {"ap75", Num(s.ap75)},
          {"ar", Num(s.ar)},
          {"images", s.images},
          {"truth_instances", s.truth_instances},
          {"predicted_instances", s.predicted_instances},
          {"confident_score_precision90", Num(s.confident_score)},
          {"confident_recall50", Num(s.confident_recall50)},
          {"per_category", per_category}};
}

/// Deformability errors of one method over a set: per-scene RMSE (0-255) and MSSIM (10 x 10
/// regions) averaged over scenes, and per category the RMSE over that category's true pixels.
struct DeformabilityStats {
  std::vector<double> rmse, mssim;
  std::map<std::string, std::pair<double, long long>> category_sq;  ///< sum of squares, pixels
  void Add(const cv::Mat1f& truth, const cv::Mat1f& predicted, const cv::Mat1w& labels,
           const std::map<int, std::string>& category_of_id) {
    rmse.push_back(core::StiffnessRmse255(truth, predicted).value());
    mssim.push_back(core::StiffnessMssim(truth, predicted).value());
    for (int v = 0; v < labels.rows; ++v) {
      for (int u = 0; u < labels.cols; ++u) {
        const int id = labels(v, u);
        if (id == 0) continue;
        const auto it = category_of_id.find(id);
        const std::string& name = it == category_of_id.end() ? std::string("unknown") : it->second;
        const double d = 255.0 * (truth(v, u) - predicted(v, u));
        auto& acc = category_sq[name];
        acc.first += d * d;
        acc.second += 1;
      }
    }
  }
  json ToJson() const {
    double r = 0, m = 0;
    for (double x : rmse) r += x;
    for (double x : mssim) m += x;
    json per_category = json::object();
    for (const auto& [name, acc] : category_sq) {
      per_category[name] = Num(std::sqrt(acc.first / std::max(1LL, acc.second)));
    }
    const double n = static_cast<double>(std::max<std::size_t>(1, rmse.size()));
    return {{"rmse_255", Num(r / n)},
            {"mssim", Num(m / n)},
            {"scenes", rmse.size()},
            {"rmse_255_per_category", per_category}};
  }
};

/// The instances FuseInstances added from the geometry alone: how many match a non-ignored
/// truth instance at IoU >= 0.5 (their precision calibrates FuseParams::geometry_score).
struct GeometryOnly {
  int instances = 0, true50 = 0;
  /// One scene's added instances against its truth.
  static GeometryOnly Of(const segmentation::TruthImage& truth,
                         const segmentation::InstanceMasks& fused,
                         const std::vector<bool>& from_geometry) {
    GeometryOnly scene;
    double max_truth = 0;
    cv::minMaxLoc(truth.labels, nullptr, &max_truth);
    for (int id = 1; id <= fused.count(); ++id) {
      if (!from_geometry[static_cast<std::size_t>(id - 1)]) continue;
      const cv::Mat1b mask = fused.labels == id;
      double best = 0, on_ignored = 0;
      for (int t = 1; t <= static_cast<int>(max_truth); ++t) {
        const cv::Mat1b object = truth.labels == t;
        if (std::find(truth.ignored_ids.begin(), truth.ignored_ids.end(), t) !=
            truth.ignored_ids.end()) {
          on_ignored += cv::countNonZero(mask & object);
          continue;
        }
        best = std::max(best, segmentation::MaskIou(mask, object));
      }
      // COCO's crowd rule: an unmatched detection mostly on ignored objects does not count.
      if (best < 0.5 && on_ignored >= 0.5 * cv::countNonZero(mask)) continue;
      ++scene.instances;
      if (best >= 0.5) ++scene.true50;
    }
    return scene;
  }
  void Add(const GeometryOnly& scene) {
    instances += scene.instances;
    true50 += scene.true50;
  }
  json ToJson() const {
    return {{"instances", instances},
            {"true50", true50},
            {"precision50",
             Num(instances > 0 ? static_cast<double>(true50) / instances : std::nan(""))}};
  }
};

struct SetResult {
  segmentation::MaskEvaluator model, pcl, fused;
  GeometryOnly geometry_only;
  DeformabilityStats model_def, baseline_def;
  std::vector<double> model_ms, pcl_ms;
  int scenes = 0, skipped = 0, ignored_instances = 0;
};

json SetJson(const SetResult& r, bool with_model) {
  json j = {{"scenes", r.scenes},
            {"skipped", r.skipped},
            {"ignored_mostly_hidden", r.ignored_instances},
            {"pcl", ScoresJson(r.pcl.Compute())},
            {"pcl_ms_median", Num(Median(r.pcl_ms))},
            {"deformability_baseline_pcl_constant", r.baseline_def.ToJson()}};
  if (with_model) {
    j["model"] = ScoresJson(r.model.Compute());
    j["model_ms_median"] = Num(Median(r.model_ms));
    j["deformability_model"] = r.model_def.ToJson();
    j["fused"] = ScoresJson(r.fused.Compute());
    j["fused_geometry_only"] = r.geometry_only.ToJson();
  }
  return j;
}

}  // namespace

int RunSegmentationEvaluate(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  std::string model_path, data;
  int max_scenes = 0, threads = 2;
  double baseline_deformability = 0.503;
  models::GroupingParams grouping;
  segmentation::FuseParams fuse;
  args.Required("--model", "MODEL|none", &model_path);
  args.Required("--data", "DIR[,DIR...]", &data);
  args.Int("--scenes", 1, 10000000, &max_scenes);
  args.Int("--threads", 1, 256, &threads);
  args.Number("--baseline-deformability", cli::Bounds::Closed(0, 1), &baseline_deformability);
  args.Number("--foreground-threshold", cli::Bounds::Closed(0, 1), &grouping.foreground_threshold);
  args.Number("--centre-threshold", cli::Bounds::Closed(0, 1), &grouping.centre_threshold);
  if (args.Int("--peak-window", 1, 99, &grouping.peak_window_px) &&
      grouping.peak_window_px % 2 == 0) {
    args.Fail("--peak-window must be odd, 1..99", "--peak-window");
  }
  args.Int("--min-area", 0, 1000000, &grouping.min_area_px);
  args.Number("--max-vote-distance", cli::Bounds::AtLeast(0), &grouping.max_vote_distance_px);
  double confident = fuse.confident_score, geometry = fuse.geometry_score;
  args.Number("--confident-score", cli::Bounds::Closed(0, 1), &confident);
  args.Number("--geometry-score", cli::Bounds::Closed(0, 1), &geometry);
  args.Number("--max-covered-fraction", cli::Bounds::Closed(0, 1), &fuse.max_covered_fraction);
  args.Number("--min-model-iou", cli::Bounds::Closed(0, 1), &fuse.min_model_iou);
  args.Number("--extend-min-inside-fraction", cli::Bounds::AtLeast(0),
              &fuse.extend_min_inside_fraction);
  fuse.confident_score = static_cast<float>(confident);
  fuse.geometry_score = static_cast<float>(geometry);
  if (const auto error = args.Finish()) return Fail(kCommand, error->message);
  models::SetTorchThreads(threads);
  std::optional<models::SegmentationModel> model;
  if (model_path != "none") {
    auto loaded = models::SegmentationModel::Load(model_path);
    if (!loaded.ok()) return Fail(kCommand, loaded.error().message);
    model.emplace(std::move(loaded.value()));
  }

  json out = {{"model", model ? json(model->description()) : json(nullptr)},
              {"grouping",
               {{"foreground_threshold", grouping.foreground_threshold},
                {"centre_threshold", grouping.centre_threshold},
                {"peak_window_px", grouping.peak_window_px},
                {"min_area_px", grouping.min_area_px},
                {"max_vote_distance_px", grouping.max_vote_distance_px}}},
              {"baseline_deformability", baseline_deformability},
              {"sets", json::object()}};
  SetResult all;
  std::stringstream dirs(data);
  std::string dir;
  while (std::getline(dirs, dir, ',')) {
    if (dir.empty()) continue;
    auto ds = models::SceneDataset::Open(dir);
    if (!ds.ok()) return Fail(kCommand, ds.error().message);
    const int count = max_scenes > 0 ? std::min(max_scenes, ds.value().size()) : ds.value().size();
    SetResult r;
    cli::ProgressBar bar("evaluating " + std::filesystem::path(dir).filename().string(), count);
    for (int i = 0; i < count; ++i) {
      auto sample = ds.value().Load(i);
      if (!sample.ok()) return Fail(kCommand, sample.error().message);
      const models::SceneSample& s = sample.value();
      auto scene = core::Preprocess(s.depth, s.camera);
      bar.Update(i + 1);
      if (!scene.ok()) {
        ++r.skipped;
        continue;
      }
      ++r.scenes;
      segmentation::TruthImage truth{s.labels, s.mostly_hidden_ids, s.category_of_id};
      r.ignored_instances += static_cast<int>(s.mostly_hidden_ids.size());
      cv::Mat1f def_truth(s.labels.size(), 0.0f);
      for (int v = 0; v < s.labels.rows; ++v) {
        for (int u = 0; u < s.labels.cols; ++u) {
          if (s.labels(v, u) > 0)
            def_truth(v, u) = 1.0f - std::clamp(s.stiffness(v, u), 0.0f, 1.0f);
        }
      }
      const auto t0 = Clock::now();
      auto pcl = segmentation::SegmentPcl(scene.value(), s.camera);
      const double pcl_ms = MillisecondsSince(t0);
      if (!pcl.ok()) return Fail(kCommand, pcl.error().message);
      r.pcl_ms.push_back(pcl_ms);
      r.pcl.Add(truth, pcl.value());
      all.pcl.Add(truth, pcl.value());
      cv::Mat1f def_baseline(s.labels.size(), 0.0f);
      def_baseline.setTo(static_cast<float>(baseline_deformability), pcl.value().labels > 0);
      r.baseline_def.Add(def_truth, def_baseline, s.labels, s.category_of_id);
      all.baseline_def.Add(def_truth, def_baseline, s.labels, s.category_of_id);
      if (model) {
        const auto t2 = Clock::now();
        const models::SegmentationOutput m = model->SegmentScene(scene.value(), grouping);
        r.model_ms.push_back(MillisecondsSince(t2));
        r.model.Add(truth, m.instances);
        all.model.Add(truth, m.instances);
        r.model_def.Add(def_truth, m.deformability, s.labels, s.category_of_id);
        all.model_def.Add(def_truth, m.deformability, s.labels, s.category_of_id);
        std::vector<bool> from_geometry;
        const segmentation::InstanceMasks fused =
            segmentation::FuseInstances(m.instances, pcl.value(), fuse, &from_geometry);
        r.fused.Add(truth, fused);
        all.fused.Add(truth, fused);
        const GeometryOnly added = GeometryOnly::Of(truth, fused, from_geometry);
        r.geometry_only.Add(added);
        all.geometry_only.Add(added);
      }
    }
    all.scenes += r.scenes;
    all.skipped += r.skipped;
    all.ignored_instances += r.ignored_instances;
    all.model_ms.insert(all.model_ms.end(), r.model_ms.begin(), r.model_ms.end());
    all.pcl_ms.insert(all.pcl_ms.end(), r.pcl_ms.begin(), r.pcl_ms.end());
    out["sets"][std::filesystem::path(dir).filename().string()] = SetJson(r, model.has_value());
  }
  out["all"] = SetJson(all, model.has_value());
  std::cout << out.dump(2) << std::endl;
  return 0;
}

}  // namespace softgrasp::tools
