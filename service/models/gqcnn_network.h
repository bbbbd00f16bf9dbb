#pragma once
/// Internal to the models libraries (softgrasp::models_net): the GQ-CNN (Dex-Net 2.0 grasp
/// quality network, Mahler et al. RSS 2017) scaled for CPU training on 2 cores (docs/gqcnn.md,
/// "Network"), and its model-file format.
///
/// Structure as Dex-Net 2.0 (REFERENCE §2.1): an image stream conv1_1 (k1 x k1) - conv1_2 (k2 x
/// k2) - LRN - max-pool 2 - conv2_1 (3x3) - conv2_2 (3x3) - LRN - max-pool 2 - fc3, a pose stream
/// pc1 on the grasp depth, a merge layer fc4 on (fc3 || pc1), and a 2-way output fc5 (logits of
/// "fails", "succeeds"). ReLU after every layer but fc5. Inputs are already normalised (see
/// GqcnnNormalisation); the widths are in GqcnnNetConfig and stored in every model file.

#include <torch/torch.h>

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "service/core/status.h"

namespace softgrasp::models {

/// Defaults: the CPU-sized variant (docs/gqcnn.md, "What was scaled"): about 2 M
/// multiply-accumulates per crop instead of Dex-Net's 132 M, so that ranking a frame's few hundred
/// candidates fits the planner's 200 ms on 2 cores.
struct GqcnnNetConfig {
  int conv1_channels = 8;   ///< conv1_1 and conv1_2 (Dex-Net: 64)
  int conv2_channels = 16;  ///< conv2_1 and conv2_2 (Dex-Net: 64)
  int conv1_1_kernel = 7;   ///< Dex-Net: 7
  int conv1_2_kernel = 3;   ///< Dex-Net: 5 (the most expensive layer: 105 of its 132 M MAC)
  int fc3_units = 128;      ///< Dex-Net: 1024
  int pc1_units = 16;       ///< Dex-Net: 16
  int fc4_units = 128;      ///< Dex-Net: 1024
  /// Dex-Net's LRN (radius 2, alpha 2e-5, beta 0.75, bias 1). Off: on inputs of order 1 it
  /// divides by ~1.0, and libtorch's CPU LRN made training 10x slower (docs/gqcnn.md).
  bool local_response_norm = false;
  /// The two outputs of fc5. false: Dex-Net's softmax over (fails, succeeds). true ("factored"):
  /// independent logits of "the gripper reaches the grasp without collision" and "the robust
  /// quality is above the label threshold"; P(succeeds) = sigmoid(a) * sigmoid(b), and training
  /// supervises each factor with its own label besides the product (docs/gqcnn.md).
  bool factored = false;
  /// The pose stream also takes the gripper's clearance (gqcnn/clearance.h: jaws, palm, floor),
  /// measured at the depth image's full resolution, which the 32x32 crop resolves to about 4 mm
  /// (docs/gqcnn.md, "Clearance as an input"). Not in Dex-Net 2.0.
  bool clearance_inputs = false;

  bool operator==(const GqcnnNetConfig&) const = default;
};

/// Inputs of the pose stream: the grasp depth, then the three clearances when the config takes
/// them.
inline int GqcnnPoseInputs(const GqcnnNetConfig& config) { return config.clearance_inputs ? 4 : 1; }

/// A clearance (metres) as the network takes it: clamped to +-kGqcnnClearanceClampM (beyond
/// that the gripper is clear, or blocked, either way) and divided by kGqcnnClearanceScaleM.
/// Non-finite values (not measured) become 0.
inline constexpr double kGqcnnClearanceClampM = 0.06;
inline constexpr double kGqcnnClearanceScaleM = 0.02;
float GqcnnClearanceInput(double clearance_m);

/// P(succeeds) [N] from fc5's logits [N, 2], as `config.factored` says.
torch::Tensor GqcnnSuccessProbability(const torch::Tensor& logits, const GqcnnNetConfig& config);

/// Mean cross-entropy of P(succeeds) against labels [N] (int64 0/1), with optional weights
/// {w_fail, w_succeed} (empty: unweighted; weighted means divide by the summed weights, as
/// torch's nll_loss). `sum` returns the sum instead of the mean.
torch::Tensor GqcnnSuccessLoss(const torch::Tensor& logits, const torch::Tensor& labels,
                               const GqcnnNetConfig& config, const torch::Tensor& class_weights,
                               bool sum = false);

/// Multiply-accumulates of one forward pass of one 32x32 crop (convolutions and linear layers).
std::int64_t GqcnnForwardMacs(const GqcnnNetConfig& config);

/// Input normalisation (Dex-Net's POSE_STREAM mode): image (depth - im_mean) / im_std with scalar
/// statistics over the valid training pixels, missing pixels (0) set to 0 after normalisation
/// (= the training mean); pose (grasp depth - pose_mean) / pose_std.
struct GqcnnNormalisation {
  double im_mean_m = 0.0;
  double im_std_m = 1.0;
  double pose_mean_m = 0.0;
  double pose_std_m = 1.0;
  bool operator==(const GqcnnNormalisation&) const = default;
};

class GqcnnNetImpl : public torch::nn::Module {
 public:
  /// Throws std::invalid_argument for widths outside 1..1024 or even/out-of-range kernels.
  explicit GqcnnNetImpl(const GqcnnNetConfig& config);
  /// image: [N, 1, 32, 32] normalised; pose: [N, GqcnnPoseInputs] normalised -> logits [N, 2].
  torch::Tensor forward(const torch::Tensor& image, const torch::Tensor& pose);

 private:
  GqcnnNetConfig config_;
  torch::nn::Conv2d conv1_1_{nullptr}, conv1_2_{nullptr}, conv2_1_{nullptr}, conv2_2_{nullptr};
  torch::nn::LocalResponseNorm lrn_{nullptr};
  torch::nn::Linear fc3_{nullptr}, pc1_{nullptr}, fc4_{nullptr}, fc5_{nullptr};
};
TORCH_MODULE(GqcnnNet);

/// He initialisation as Dex-Net (truncated normal, std sqrt(2 / fan_in)), biases 0.
void InitGqcnnWeights(GqcnnNet& net);

/// Normalises raw crops (n x 32 x 32 absolute depths in metres, 0 or non-finite = missing),
/// grasp depths and, when `config.clearance_inputs`, clearances (n x 3: jaws, palm, floor, in
/// metres; otherwise ignored and may be null) into network inputs: images [n, 1, 32, 32] and
/// poses [n, GqcnnPoseInputs(config)].
void NormaliseGqcnnInputs(const float* crops_depth_m, const float* grasp_depths_m,
                          const float* clearances_m, std::int64_t n, const GqcnnNetConfig& config,
                          const GqcnnNormalisation& norm, torch::Tensor* images,
                          torch::Tensor* poses);

/// Model file format version of GQ-CNN models. Version 2 adds the `factored` flag to the config,
/// version 3 `clearance_inputs`; versions 1 (softmax output) and 2 still load.
inline constexpr std::int64_t kGqcnnFormatVersion = 3;

/// Writes the network (its parameters), config, normalisation and `card` (JSON, stored as UTF-8
/// bytes) to `path` as a libtorch archive: "kind" marker, "config" = int64 [version, 7 sizes, LRN,
/// factored, clearance inputs],
/// "normalisation" = float64 [4], "card" = uint8 [bytes], "net/...". Writes a temporary file and
/// renames it. Throws on I/O failure.
void SaveGqcnnNet(const std::filesystem::path& path, GqcnnNet& net, const GqcnnNetConfig& config,
                  const GqcnnNormalisation& norm, const nlohmann::json& card);

struct LoadedGqcnnNet {
  GqcnnNet net{nullptr};
  GqcnnNetConfig config;
  GqcnnNormalisation normalisation;
  nlohmann::json card;
};
/// Reads what SaveGqcnnNet wrote, network in eval mode; never throws (kNotFound / kUnprocessable,
/// field "model", the message naming the path and the reason).
core::Result<LoadedGqcnnNet> LoadGqcnnNet(const std::filesystem::path& path);

/// The config as JSON (for model cards) and a one-line description.
nlohmann::json GqcnnConfigJson(const GqcnnNetConfig& config);

}  // namespace softgrasp::models
