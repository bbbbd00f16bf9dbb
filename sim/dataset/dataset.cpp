#include "sim/dataset/dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <system_error>

#include "service/cli/files.h"
#include "service/io/depth_codec.h"

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

std::string Numbered(const char* prefix, int width, int n) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%s%0*d", prefix, width, n);
  return buffer;
}

}  // namespace

cv::Mat1w DepthToMillimetres(const cv::Mat1f& depth_m) {
  cv::Mat1w mm(depth_m.size(), 0);
  for (int v = 0; v < depth_m.rows; ++v) {
    for (int u = 0; u < depth_m.cols; ++u) {
      const double z_mm = std::round(static_cast<double>(depth_m(v, u)) * 1000.0);
      if (std::isfinite(z_mm) && z_mm > 0.0 && z_mm <= 65535.0)
        mm(v, u) = static_cast<std::uint16_t>(z_mm);
    }
  }
  return mm;
}

cv::Mat1b UnitToByte(const cv::Mat1f& map) {
  cv::Mat1b out(map.size(), 0);
  for (int v = 0; v < map.rows; ++v) {
    for (int u = 0; u < map.cols; ++u) {
      const float x = map(v, u);
      out(v, u) = std::isfinite(x)
                      ? static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f))
                      : 0;
    }
  }
  return out;
}

std::optional<core::Error> WriteSceneFiles(const SceneSpec& spec, const GeneratedScene& generated,
                                           const std::filesystem::path& dir,
                                           const std::string& stem) {
  const RenderedViews& views = generated.views;
  json manifest = SceneManifest(spec, generated);
  auto visibility = MeasureVisibility(generated, spec.render);
  if (!visibility.ok()) return visibility.error();
  for (json& object : manifest["objects"]) {
    const int id = object.at("instance_id").get<int>();
    for (const ObjectVisibility& v : visibility.value()) {
      if (v.instance_id != id) continue;
      object["visible_px"] = v.visible_px;
      object["amodal_px"] = v.amodal_px;
      object["visible_fraction"] = v.visible_fraction;
      object["mostly_hidden"] = v.mostly_hidden;
    }
  }
  manifest["visibility"] = {
      {"mostly_hidden_below_fraction", kMostlyHiddenVisibleFraction},
      {"amodal_px", "pixels the object covers rendered alone on the support, same camera"}};
  manifest["files"] = {{"depth", stem + "_depth.png"},
                       {"stiffness", stem + "_stiffness.png"},
                       {"deformability", stem + "_deformability.png"},
                       {"labels", stem + "_labels.png"}};
  manifest["encodings"] = {
      {"depth", "uint16 millimetres, 0 = missing"},
      {"stiffness", "uint8 round(255 * stiffness), 0 = background"},
      {"deformability", "uint8 round(255 * (1 - stiffness)) on objects, 0 = background"},
      {"labels", "uint16 instance_id, 0 = support or nothing"}};
  const std::pair<std::string, std::string> files[] = {
      {stem + "_depth.png", io::EncodePng(DepthToMillimetres(views.depth.depth_m))},
      {stem + "_stiffness.png", io::EncodePng(UnitToByte(views.stiffness))},
      {stem + "_deformability.png", io::EncodePng(UnitToByte(views.deformability))},
      {stem + "_labels.png", io::EncodePng(views.labels)},
      {stem + ".json", manifest.dump(2) + "\n"},
  };
  for (const auto& [name, bytes] : files) {
    if (auto error = cli::WriteFile(dir / name, bytes)) {
      return MakeError(ErrorCode::kInvalidArgument, error->message, "out");
    }
  }
  return std::nullopt;
}

core::Result<std::filesystem::path> GenerateDataset(const DatasetParams& params,
                                                    const std::function<void(int done)>& progress) {
  if (params.scenes < 1)
    return MakeError(ErrorCode::kInvalidArgument, "scenes must be >= 1", "scenes");
  if (params.shard_size < 1 || params.shard_size > 100000) {
    return MakeError(ErrorCode::kInvalidArgument, "shard_size must be in 1..100000", "shard_size");
  }
  if (auto invalid = ValidateSceneSpec(params.spec)) return *invalid;
  if (const std::string bad = CheckArrayTask(params.task, params.scenes); !bad.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, bad, "task");
  }
  const ItemRange items = TaskItems(params.task, params.scenes);

  json scenes = json::array();
  for (int i = items.first; i < items.end; ++i) {
    const std::string shard = Numbered("shard_", 4, i / params.shard_size);
    const std::string stem = Numbered("scene_", 6, i);
    const std::filesystem::path dir = params.out_dir / shard;
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "cannot create " + dir.string() + ": " + ec.message(), "out");
    }
    const std::uint64_t scene_seed = SceneSeed(params.seed, i, params.spec.split);
    auto generated = GenerateScene(params.spec, scene_seed);
    if (!generated.ok()) return generated.error();
    if (auto error = WriteSceneFiles(params.spec, generated.value(), dir, stem)) return *error;
    json categories = json::array();
    for (const PlacedObject& p : generated.value().scene.objects)
      categories.push_back(p.object->category);
    scenes.push_back({{"manifest", shard + "/" + stem + ".json"},
                      {"scene_seed", scene_seed},
                      {"categories", categories}});
    if (progress) progress(i + 1 - items.first);
  }
  const SceneSpec& spec = params.spec;
  const json index = {
      {"generator", "softgrasp-sim generate"},
      {"format_version", 1},
      {"seed", params.seed},
      {"split", ShapeSplitName(spec.split)},
      {"scenes", params.scenes},
      {"shard_size", params.shard_size},
      {"objects", {spec.min_objects, spec.max_objects}},
      {"support", SupportToJson(spec.support)},
      {"noise", spec.render.noise.enabled},
      {"fractal_probability", spec.fractal_probability},
      // Everything a scene is rebuilt from (camera pose and intrinsics included), so a tool can
      // regenerate any scene from its seed exactly as `generate` made it.
      {"spec", SceneSpecToJson(spec)},
      {"entries", scenes},
  };
  std::error_code ec;
  std::filesystem::create_directories(params.out_dir, ec);  // a task may have no shard folder
  return WriteTaskIndex(params.out_dir, index, params.task, items, "entries");
}

}  // namespace softgrasp::sim
