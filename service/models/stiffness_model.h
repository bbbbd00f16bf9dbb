#pragma once
/// pix2stiffness inference: a depth image in, a per-pixel stiffness map in [0, 1] out (1 = hard,
/// 0 = background). See docs/stiffness.md. The header does not include libtorch.
///
///   auto model = models::StiffnessModel::Load("models/pix2stiffness.pt");
///   if (!model.ok()) return model.error();
///   auto map = model.value().Predict(depth, camera);  // cv::Mat1f, same size as depth

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "service/core/depth.h"
#include "service/core/preprocess.h"
#include "service/core/status.h"

namespace softgrasp::models {

/// Model input: heights above the fitted floor, clamped to [0, kInputHeightRangeM] and mapped
/// linearly to [-1, 1] (a fixed contrast stretch: the same height gives the same value in every
/// image, whatever the camera distance).
inline constexpr double kInputHeightRangeM = 0.30;

/// The network input for one preprocessed scene: heights resized (stretched, INTER_AREA) to
/// `size` and normalised as above. Returns a CV_32F image of that size in [-1, 1].
cv::Mat1f MakeModelInput(const core::Scene& scene, cv::Size size);
/// The same, square (side x side).
inline cv::Mat1f MakeModelInput(const core::Scene& scene, int side) {
  return MakeModelInput(scene, cv::Size(side, side));
}

/// Output pixels below this are background (0): stiffness levels are 0.1 ... 1.0 and background
/// is 0, so half the softest level separates them (the thesis' "pre-processed" map S_pre).
/// Without it a sigmoid's small background residue dominates SSIM on background regions.
inline constexpr float kBackgroundThreshold = 0.05f;

/// Threads libtorch uses for intra-op parallelism (process-wide): n, or one per online CPU when
/// n <= 0 (libtorch itself counts physical cores: one on a 2-vCPU VM).
void SetTorchThreads(int n);

class StiffnessModel {
 public:
  /// Reads a model file written by the trainer (a generator and its config). Errors:
  /// kNotFound (no such file), kUnprocessable (not a model file, truncated or corrupted, or a
  /// format version this build does not read); the message names the path.
  static core::Result<StiffnessModel> Load(const std::filesystem::path& path);

  /// Stiffness map of `depth` (metres, NaN = missing), same size as the input, values in [0, 1].
  /// Runs core::Preprocess (errors propagate: kInvalidArgument / kUnprocessable), resizes the
  /// heights to the model's side (stretch), runs the generator and resizes back (bilinear).
  core::Result<cv::Mat1f> Predict(const core::DepthImage& depth, const core::Camera& camera,
                                  const core::PreprocessParams& params = {}) const;
  /// Same for an already preprocessed scene (skips a second Preprocess when the caller has
  /// one). Values below kBackgroundThreshold become 0.
  cv::Mat1f PredictScene(const core::Scene& scene) const;
  /// Raw model resolution: input (side x side, from MakeModelInput) -> map (side x side), raw
  /// sigmoid output (no background threshold).
  cv::Mat1f PredictModelInput(const cv::Mat1f& input) const;

  int input_size() const;  ///< model side, pixels (256)
  std::int64_t parameter_count() const;
  const std::string& description() const;  ///< the config line stored in the file

  StiffnessModel(StiffnessModel&&) noexcept;
  StiffnessModel& operator=(StiffnessModel&&) noexcept;
  ~StiffnessModel();

  struct Impl;  // service/models/stiffness_model.cpp

 private:
  explicit StiffnessModel(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace softgrasp::models
