#pragma once
/// Reads datasets written by `softgrasp-sim generate` (docs/simulator.md) for training and
/// evaluation: DIR/index.json, per scene a 16-bit depth PNG (mm, 0 = missing), an 8-bit
/// stiffness PNG (round(255 s), 0 = background), a 16-bit label PNG and a JSON manifest.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "service/core/depth.h"
#include "service/core/status.h"

namespace softgrasp::models {

struct SceneEntry {
  std::filesystem::path manifest_path;  ///< absolute
  std::filesystem::path stem;           ///< manifest path without ".json"
  std::uint64_t scene_seed = 0;
};

/// One scene as stored.
struct SceneSample {
  core::DepthImage depth;  ///< metres, NaN where the PNG holds 0
  cv::Mat1f stiffness;     ///< [0, 1], 0 = background
  cv::Mat1w labels;        ///< instance ids, 0 = support
  core::Camera camera;     ///< from the manifest
  nlohmann::json manifest;
  /// Instance ids the manifest marks "mostly_hidden" (visible_fraction < 0.10, see
  /// docs/simulator.md), ascending; empty for datasets written before the field existed.
  std::vector<int> mostly_hidden_ids;
  /// Each manifest object's "instance_id" -> "category" (empty when the manifest lists none).
  std::map<int, std::string> category_of_id;
};

class SceneDataset {
 public:
  /// Reads DIR/index.json. Errors: kNotFound (no index), kUnprocessable (malformed index or
  /// zero scenes); field "data".
  static core::Result<SceneDataset> Open(const std::filesystem::path& dir);

  int size() const { return static_cast<int>(entries_.size()); }
  const SceneEntry& entry(int i) const { return entries_.at(static_cast<std::size_t>(i)); }
  const nlohmann::json& index() const { return index_; }
  const std::filesystem::path& dir() const { return dir_; }

  /// Loads scene i. Errors: kUnprocessable naming the file (missing, wrong size or bit depth).
  core::Result<SceneSample> Load(int i) const;

 private:
  std::filesystem::path dir_;
  nlohmann::json index_;
  std::vector<SceneEntry> entries_;
};

/// Training pairs at model resolution, preprocessed once and kept in memory compactly:
/// inputs as int16 (value * 32767, see MakeModelInput), targets as uint8 (0-255).
struct TrainingSet {
  int side = 256;
  std::vector<std::vector<std::int16_t>> inputs;
  std::vector<std::vector<std::uint8_t>> targets;
  int skipped = 0;         ///< scenes whose depth could not be preprocessed
  double mean_target = 0;  ///< mean of all target pixels (0-1, background included)
  int size() const { return static_cast<int>(inputs.size()); }
};

/// Loads and preprocesses every scene of `dataset` (at most `max_scenes` if > 0) to side x
/// side: input = MakeModelInput(Preprocess(depth)), target = stiffness resized with INTER_AREA.
/// `progress(done, total)` after each. Errors: a scene that fails to load (I/O) or a set with
/// no usable scene.
core::Result<TrainingSet> BuildTrainingSet(const SceneDataset& dataset, int side,
                                           int max_scenes = 0,
                                           const std::function<void(int, int)>& progress = {});

}  // namespace softgrasp::models
