#include "train/dataset.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "service/codec/json_codec.h"
#include "service/core/preprocess.h"
#include "service/models/stiffness_model.h"

namespace softgrasp::models {
namespace {

using core::ErrorCode;
using core::MakeError;

core::Result<nlohmann::json> ReadJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return MakeError(ErrorCode::kNotFound, "cannot open " + path.string(), "data");
  nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) {
    return MakeError(ErrorCode::kUnprocessable, path.string() + " is not valid JSON", "data");
  }
  return j;
}

core::Error FileError(const std::filesystem::path& path, const std::string& what) {
  return MakeError(ErrorCode::kUnprocessable, path.string() + ": " + what, "data");
}

/// Fills mostly_hidden_ids and category_of_id from the manifest's "objects"; entries without an
/// integer "instance_id" are skipped, missing "category" / "mostly_hidden" fields are absent.
void ReadObjectMarks(SceneSample* s) {
  const auto objects = s->manifest.find("objects");
  if (objects == s->manifest.end() || !objects->is_array()) return;
  for (const nlohmann::json& o : *objects) {
    if (!o.is_object()) continue;
    const auto id = o.find("instance_id");
    if (id == o.end() || !id->is_number_integer()) continue;
    const int instance_id = id->get<int>();
    const auto category = o.find("category");
    if (category != o.end() && category->is_string()) {
      s->category_of_id[instance_id] = category->get<std::string>();
    }
    const auto hidden = o.find("mostly_hidden");
    if (hidden != o.end() && hidden->is_boolean() && hidden->get<bool>()) {
      s->mostly_hidden_ids.push_back(instance_id);
    }
  }
  std::sort(s->mostly_hidden_ids.begin(), s->mostly_hidden_ids.end());
}

}  // namespace

core::Result<SceneDataset> SceneDataset::Open(const std::filesystem::path& dir) {
  auto index = ReadJson(dir / "index.json");
  if (!index.ok()) return index.error();
  SceneDataset ds;
  ds.dir_ = std::filesystem::absolute(dir);
  ds.index_ = std::move(index.value());
  const auto entries = ds.index_.find("entries");
  if (entries == ds.index_.end() || !entries->is_array()) {
    return FileError(dir / "index.json", "no \"entries\" array (not a softgrasp-sim dataset?)");
  }
  for (const auto& e : *entries) {
    if (!e.is_object() || !e.contains("manifest") || !e["manifest"].is_string()) {
      return FileError(dir / "index.json", "an entry has no \"manifest\" path");
    }
    SceneEntry entry;
    entry.manifest_path = ds.dir_ / e["manifest"].get<std::string>();
    std::filesystem::path stem = entry.manifest_path;
    entry.stem = stem.replace_extension("");
    if (e.contains("scene_seed") && e["scene_seed"].is_number_unsigned()) {
      entry.scene_seed = e["scene_seed"].get<std::uint64_t>();
    }
    ds.entries_.push_back(std::move(entry));
  }
  if (ds.entries_.empty()) return FileError(dir / "index.json", "the dataset has no scenes");
  return ds;
}

core::Result<SceneSample> SceneDataset::Load(int i) const {
  if (i < 0 || i >= size()) {
    return MakeError(ErrorCode::kInvalidArgument, "scene index out of range", "scene");
  }
  const SceneEntry& e = entries_[static_cast<std::size_t>(i)];
  SceneSample s;
  auto manifest = ReadJson(e.manifest_path);
  if (!manifest.ok()) return manifest.error();
  s.manifest = std::move(manifest.value());
  const nlohmann::json absent;  // "camera must be a JSON object"
  const auto camera = codec::CameraFromJson(
      s.manifest.is_object() && s.manifest.contains("camera") ? s.manifest["camera"] : absent,
      "camera");
  if (!camera) return FileError(e.manifest_path, camera.error().message);
  s.camera = camera.value();
  const std::string stem = e.stem.string();
  const cv::Mat depth_mm = cv::imread(stem + "_depth.png", cv::IMREAD_UNCHANGED);
  const cv::Mat stiffness = cv::imread(stem + "_stiffness.png", cv::IMREAD_UNCHANGED);
  const cv::Mat labels = cv::imread(stem + "_labels.png", cv::IMREAD_UNCHANGED);
  if (depth_mm.empty() || depth_mm.type() != CV_16UC1) {
    return FileError(stem + "_depth.png", "missing or not a 16-bit single-channel PNG");
  }
  if (stiffness.empty() || stiffness.type() != CV_8UC1 || stiffness.size() != depth_mm.size()) {
    return FileError(stem + "_stiffness.png", "missing, not 8-bit or not the depth's size");
  }
  if (labels.empty() || labels.type() != CV_16UC1 || labels.size() != depth_mm.size()) {
    return FileError(stem + "_labels.png", "missing, not 16-bit or not the depth's size");
  }
  if (depth_mm.cols != s.camera.width || depth_mm.rows != s.camera.height) {
    return FileError(stem + "_depth.png", "size differs from the manifest's camera");
  }
  s.depth.depth_m.create(depth_mm.size());
  for (int r = 0; r < depth_mm.rows; ++r) {
    const auto* src = depth_mm.ptr<std::uint16_t>(r);
    float* dst = s.depth.depth_m.ptr<float>(r);
    for (int c = 0; c < depth_mm.cols; ++c) {
      dst[c] = src[c] == 0 ? std::numeric_limits<float>::quiet_NaN() : src[c] * 0.001f;
    }
  }
  stiffness.convertTo(s.stiffness, CV_32F, 1.0 / 255.0);
  s.labels = labels;
  ReadObjectMarks(&s);
  return s;
}

core::Result<TrainingSet> BuildTrainingSet(const SceneDataset& dataset, int side, int max_scenes,
                                           const std::function<void(int, int)>& progress) {
  TrainingSet set;
  set.side = side;
  const int n = max_scenes > 0 ? std::min(max_scenes, dataset.size()) : dataset.size();
  const std::size_t pixels = static_cast<std::size_t>(side) * side;
  double target_sum = 0;
  for (int i = 0; i < n; ++i) {
    auto sample = dataset.Load(i);
    if (!sample.ok()) return sample.error();
    auto scene = core::Preprocess(sample.value().depth, sample.value().camera);
    if (!scene.ok()) {
      ++set.skipped;  // e.g. an all-missing frame: nothing to learn from
      if (progress) progress(i + 1, n);
      continue;
    }
    const cv::Mat1f input = MakeModelInput(scene.value(), side);
    cv::Mat1f target;
    cv::resize(sample.value().stiffness, target, cv::Size(side, side), 0, 0, cv::INTER_AREA);
    std::vector<std::int16_t> in(pixels);
    std::vector<std::uint8_t> out(pixels);
    for (int r = 0; r < side; ++r) {
      for (int c = 0; c < side; ++c) {
        const std::size_t k = static_cast<std::size_t>(r) * side + c;
        in[k] = static_cast<std::int16_t>(std::lround(input(r, c) * 32767.0f));
        const float t = std::clamp(target(r, c), 0.0f, 1.0f);
        out[k] = static_cast<std::uint8_t>(std::lround(t * 255.0f));
        target_sum += out[k] / 255.0;
      }
    }
    set.inputs.push_back(std::move(in));
    set.targets.push_back(std::move(out));
    if (progress) progress(i + 1, n);
  }
  if (set.inputs.empty()) {
    return MakeError(ErrorCode::kUnprocessable,
                     "no usable scene in " + dataset.dir().string() + " (all failed preprocessing)",
                     "data");
  }
  set.mean_target = target_sum / (static_cast<double>(pixels) * set.size());
  return set;
}

}  // namespace softgrasp::models
