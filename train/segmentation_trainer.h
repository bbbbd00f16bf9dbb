#pragma once
/// Training the segmentation network on CPU with libtorch (docs/segmentation.md, "Training"):
/// foreground BCE + centre-heatmap MSE + centre-offset L1 + deformability L1 and SSIM.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <opencv2/core.hpp>
#include <vector>

#include "service/core/status.h"
#include "service/models/segmentation_network.h"
#include "train/dataset.h"

namespace softgrasp::models {

/// Scenes at model resolution, preprocessed once and kept compactly in memory: inputs as int16
/// (MakeModelInput value * 32767), instance labels (nearest-neighbour resized, 0 = support) and
/// deformability targets (1 - stiffness on objects, 0 elsewhere; round(255 d), INTER_AREA).
struct SegmentationSet {
  cv::Size size{320, 240};
  std::vector<std::vector<std::int16_t>> inputs;
  std::vector<std::vector<std::uint16_t>> labels;
  std::vector<std::vector<std::uint8_t>> deformability;
  int skipped = 0;                       ///< scenes whose depth could not be preprocessed
  double mean_object_deformability = 0;  ///< over object pixels of every scene (a baseline)
  int count() const { return static_cast<int>(inputs.size()); }
};

/// Loads and preprocesses every scene of each dataset (at most `max_scenes_per_set` of each if
/// > 0). `progress(done, total)` after each scene. Errors: a scene that fails to load, or no
/// usable scene at all.
core::Result<SegmentationSet> BuildSegmentationSet(
    const std::vector<SceneDataset>& datasets, cv::Size size, int max_scenes_per_set = 0,
    const std::function<void(int, int)>& progress = {});

/// Per-pixel targets of one sample (model resolution), from its labels: the foreground (labels
/// > 0), a heatmap with a Gaussian of sigma `centre_sigma_px` at each instance's centroid (max
/// over instances), and offsets from each object pixel to its instance's centroid divided by
/// kOffsetScalePx (0 on background).
struct SegmentationTargets {
  cv::Mat1f foreground, centre, offset_u, offset_v;
};
SegmentationTargets MakeSegmentationTargets(const cv::Mat1w& labels, double centre_sigma_px = 3.0);

struct SegmentationTrainOptions {
  std::filesystem::path out;  ///< model file; OUT.ckpt, OUT_loss.csv, OUT_loss.png beside it
  int steps = 4000;
  std::uint64_t seed = 1;
  int batch = 4;
  double learning_rate = 1e-3;   ///< Adam; 100-step warm-up, then cosine decay to 5 % at `steps`
  double centre_weight = 200.0;  ///< on the heatmap MSE (Panoptic-DeepLab's weight)
  double offset_weight = 1.0;    ///< on the offset L1 (offsets / kOffsetScalePx)
  double ssim_weight = 1.0;      ///< on 1 - SSIM of the deformability map (plus its L1 x 1)
  int checkpoint_every = 250;
  bool resume = false;
  int stop_after_step = 0;  ///< stop (checkpointing) after this step; 0 = run to `steps`
  /// Fine-tuning: start from this saved model's weights (same network config) with a fresh
  /// optimiser and schedule. Empty = random initialisation. A checkpoint being resumed wins.
  std::filesystem::path init;
  SegmentationNetConfig network;
};

struct SegmentationLossRecord {
  int step = 0;
  double total = 0;
  double foreground = 0;     ///< BCE
  double centre = 0;         ///< MSE (not weighted)
  double offset = 0;         ///< L1 on object pixels (not weighted)
  double deformability = 0;  ///< L1
  double ssim = 0;           ///< 1 - SSIM
};

struct SegmentationTrainReport {
  int start_step = 0;
  int end_step = 0;
  double seconds = 0;
  std::vector<SegmentationLossRecord> history;  ///< every step from 1 (resumed ones included)
};

using SegmentationProgress = std::function<void(const SegmentationLossRecord&, int total_steps)>;

/// Trains on `set`. Deterministic given the seed and thread count (batches and flips drawn from
/// (seed, step) streams; a resumed run draws what an uninterrupted one would). Errors:
/// kInvalidArgument for bad options, kUnprocessable for an unreadable or mismatched checkpoint,
/// kInternal when the loss stops being finite.
core::Result<SegmentationTrainReport> TrainSegmentation(const SegmentationTrainOptions& options,
                                                        const SegmentationSet& set,
                                                        const SegmentationProgress& progress = {});

/// Writes the history as CSV and PNG (all losses, weighted as trained).
void WriteSegmentationLossCurve(const std::vector<SegmentationLossRecord>& history,
                                const SegmentationTrainOptions& options,
                                const std::filesystem::path& csv, const std::filesystem::path& png);

}  // namespace softgrasp::models
