#pragma once
/// Internal to the models libraries (softgrasp::models_net): the pix2pix networks (Isola et al.
/// 2017) sized for CPU training. See docs/stiffness.md, "Network".

#include <torch/torch.h>

#include <filesystem>
#include <optional>
#include <vector>

#include "service/core/status.h"

namespace softgrasp::models {

/// Sizes that define both networks; stored in every model file so a file rebuilds its network.
struct NetworkConfig {
  int input_size = 256;    ///< square input and output side, pixels (a power of two)
  int base_channels = 16;  ///< channels of the first encoder level; doubled per level up to 8x
  int levels = 6;          ///< encoder levels (each halves the side): 256 -> 4 for 6 levels
  int disc_channels = 16;  ///< PatchGAN first-layer channels
  double dropout = 0.5;    ///< dropout in the innermost decoder levels (training only)
};

/// U-Net generator: 4x4 stride-2 convolutions down (LeakyReLU 0.2, group norm except on the first
/// and innermost), nearest x2 upsampling + 3x3 convolutions up (ReLU, group norm, dropout on the
/// two innermost), skip connections by concatenation, sigmoid output in [0, 1]. (Resize-convolution
/// instead of pix2pix's transposed convolutions and group instead of instance norm: the same
/// function class, but 5-10x faster on libtorch's CPU kernels, and no checkerboard artefacts.)
class UNetGeneratorImpl : public torch::nn::Module {
 public:
  explicit UNetGeneratorImpl(const NetworkConfig& config);
  /// x: [N, 1, S, S] normalised heights in [-1, 1] -> [N, 1, S, S] stiffness in [0, 1].
  torch::Tensor forward(const torch::Tensor& x);

 private:
  std::vector<torch::nn::Conv2d> down_;
  std::vector<torch::nn::GroupNorm> down_norm_;  ///< down_norm_[i] for level i >= 1
  std::vector<torch::nn::Conv2d> up_;          ///< up_[i]: 3x3 conv after upsampling to level i - 1
  std::vector<torch::nn::GroupNorm> up_norm_;  ///< up_norm_[i] for i >= 1 (not the output)
  std::vector<bool> up_dropout_;
  double dropout_ = 0.5;
};
TORCH_MODULE(UNetGenerator);

/// 70x70 PatchGAN: judges (input, stiffness) pairs per overlapping patch; returns logits
/// [N, 1, 30, 30] for a 256 input.
class PatchDiscriminatorImpl : public torch::nn::Module {
 public:
  explicit PatchDiscriminatorImpl(const NetworkConfig& config);
  torch::Tensor forward(const torch::Tensor& input, const torch::Tensor& stiffness);

 private:
  torch::nn::Sequential body_{nullptr};
};
TORCH_MODULE(PatchDiscriminator);

/// pix2pix initialisation: conv weights ~ N(0, 0.02), biases 0, norm scales ~ N(1, 0.02).
void InitWeights(torch::nn::Module& module);

/// Number of trainable scalars.
std::int64_t CountParameters(const torch::nn::Module& module);

/// Sets to zero every float parameter (and buffer) whose magnitude is below the smallest normal
/// float, 1.18e-38, and returns how many there were. Training left a fifth of the shipped
/// GQ-CNN's fc3 weights there, and x86 CPUs compute with such subnormal numbers many times
/// slower: flushed, that network scores 250 crops about 3x faster. No output changes by more
/// than the flushed values times the activations, far below float precision. For inference
/// models only: a training run resumed from a flushed checkpoint would differ from one that was
/// never interrupted.
std::int64_t FlushSubnormalParameters(torch::nn::Module& module);

/// The error for a model file trained on heights normalised with another range than this build's
/// kInputHeightRangeM (the network would see scaled heights); nullopt when they agree.
std::optional<core::Error> HeightRangeMismatch(const std::filesystem::path& path,
                                               double trained_range_m);

}  // namespace softgrasp::models

#include <filesystem>
#include <string>

#include "service/core/status.h"

namespace softgrasp::models {

/// Model file format version written by SaveGenerator and read by LoadGenerator.
inline constexpr std::int64_t kModelFormatVersion = 1;

/// Writes the generator (eval copy of its parameters) and its config to `path` (libtorch
/// archive: "config" = int64 [version, input_size, base_channels, levels, disc_channels],
/// "height_range_m" = float64 [1], "generator/..." = the parameters). Throws on I/O failure.
void SaveGenerator(const std::filesystem::path& path, UNetGenerator& generator,
                   const NetworkConfig& config, double height_range_m);

struct LoadedGenerator {
  UNetGenerator generator{nullptr};
  NetworkConfig config;
  double height_range_m = 0;
};
/// Reads what SaveGenerator wrote; never throws (kNotFound / kUnprocessable).
core::Result<LoadedGenerator> LoadGenerator(const std::filesystem::path& path);

}  // namespace softgrasp::models
