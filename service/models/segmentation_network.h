#pragma once
/// Internal to the models libraries (softgrasp::models_net): the segmentation network
/// (docs/segmentation.md, "Network").
/// A U-Net on normalised heights with four heads at the input resolution: foreground logit,
/// instance-centre heatmap logit, centre offset (du, dv) in units of kOffsetScalePx model pixels,
/// deformability logit.

#include <torch/torch.h>

#include <cstdint>
#include <filesystem>
#include <vector>

#include "service/core/status.h"

namespace softgrasp::models {

/// Offsets are regressed divided by this (model pixels), so their targets are O(1).
inline constexpr float kOffsetScalePx = 16.0f;

/// Output channels of SegmentationNet.
enum SegmentationHead : int {
  kHeadForeground = 0,
  kHeadCentre = 1,
  kHeadOffsetU = 2,
  kHeadOffsetV = 3,
  kHeadDeformability = 4,
  kHeadCount = 5
};

struct SegmentationNetConfig {
  int width = 320;  ///< model input width, pixels (divisible by 2^levels)
  int height = 240;
  int base_channels = 16;  ///< channels at full resolution; doubled per level up to 8x
  int levels = 4;          ///< stride-2 encoder levels
};

class SegmentationNetImpl : public torch::nn::Module {
 public:
  explicit SegmentationNetImpl(const SegmentationNetConfig& config);
  /// x: [N, 1, H, W] heights in [-1, 1] -> [N, kHeadCount, H, W] raw head outputs.
  torch::Tensor forward(const torch::Tensor& x);

 private:
  torch::nn::Conv2d stem_{nullptr};
  torch::nn::GroupNorm stem_norm_{nullptr};
  std::vector<torch::nn::Conv2d> down_;
  std::vector<torch::nn::GroupNorm> down_norm_;
  torch::nn::Conv2d bottleneck_{nullptr};
  torch::nn::GroupNorm bottleneck_norm_{nullptr};
  std::vector<torch::nn::Conv2d> up_;  ///< up_[i]: after upsampling to level i, concat skip i
  std::vector<torch::nn::GroupNorm> up_norm_;
  torch::nn::Conv2d head_hidden_{nullptr};
  torch::nn::Conv2d head_out_{nullptr};
};
TORCH_MODULE(SegmentationNet);

/// Model file format version of segmentation models.
inline constexpr std::int64_t kSegmentationFormatVersion = 1;

/// Writes the network (eval copy) and its config: "kind" = "segmentation" marker, "config" =
/// int64 [version, width, height, base_channels, levels], "height_range_m", "net/...".
/// Writes to a temporary file and renames. Throws on I/O failure.
void SaveSegmentationNet(const std::filesystem::path& path, SegmentationNet& net,
                         const SegmentationNetConfig& config, double height_range_m);

struct LoadedSegmentationNet {
  SegmentationNet net{nullptr};
  SegmentationNetConfig config;
  double height_range_m = 0;
};
/// Reads what SaveSegmentationNet wrote; never throws (kNotFound / kUnprocessable, field "model").
core::Result<LoadedSegmentationNet> LoadSegmentationNet(const std::filesystem::path& path);

}  // namespace softgrasp::models
