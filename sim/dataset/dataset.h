#pragma once
/// Training / validation datasets on disk: `softgrasp-sim generate` (docs/simulator.md).
///
/// Layout: OUT/index.json and OUT/shard_NNNN/scene_NNNNNN_{depth,stiffness,deformability,
/// labels}.png + scene_NNNNNN.json. depth: 16-bit PNG, millimetres, 0 = missing; stiffness and
/// deformability: 8-bit PNG, round(255 * value); labels: 16-bit PNG, instance ids (0 = support).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <opencv2/core.hpp>
#include <string>

#include "service/core/status.h"
#include "sim/dataset/scene_gen.h"
#include "sim/tasks/array_tasks.h"

namespace softgrasp::sim {

struct DatasetParams {
  int scenes = 10;
  std::uint64_t seed = 0;
  int shard_size = 100;  ///< scenes per shard folder; 1..100000
  SceneSpec spec;
  std::filesystem::path out_dir;
  /// Task K of N makes only its part of the scenes and a partial index (sim/tasks/array_tasks.h);
  /// merging the N partial indexes gives the index.json of one process. Default: the whole batch.
  ArrayTask task;
};

/// Depth in metres -> 16-bit millimetres (rounded; NaN, <= 0 and > 65.535 m become 0).
cv::Mat1w DepthToMillimetres(const cv::Mat1f& depth_m);
/// A [0, 1] map -> 8-bit round(255 * value) (clamped).
cv::Mat1b UnitToByte(const cv::Mat1f& map);

/// Writes the four PNGs and the manifest of one scene as DIR/STEM_*.png and DIR/STEM.json.
std::optional<core::Error> WriteSceneFiles(const SceneSpec& spec, const GeneratedScene& generated,
                                           const std::filesystem::path& dir,
                                           const std::string& stem);

/// Generates `scenes` scenes (task K of N: its part of them) and writes them with an index.json
/// (a partial index for N > 1); `progress(done)` after each. Same params -> the same bytes, and
/// every scene's bytes do not depend on the split into tasks. Errors: kInvalidArgument (bad params,
/// unwritable folder), or the first scene error.
core::Result<std::filesystem::path> GenerateDataset(
    const DatasetParams& params, const std::function<void(int done)>& progress = {});

}  // namespace softgrasp::sim
