#pragma once
/// GQ-CNN inference (docs/gqcnn.md): the probability that a parallel-jaw grasp succeeds, from
/// its grasp-aligned 32x32 depth crop and its grasp depth (Dex-Net 2.0). The header does not
/// include libtorch.
///
///   auto model = models::GqcnnModel::Load("models/gqcnn.pt");
///   if (!model.ok()) return model.error();
///   std::vector<float> p = model.value().Predict(crops_depth_m, grasp_depths_m);

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "service/core/status.h"

namespace softgrasp::models {

class GqcnnModel {
 public:
  /// Reads a model file written by `softgrasp-train gqcnn`. Never throws. Errors: kNotFound (no
  /// such file), kUnprocessable (not a GQ-CNN model file, truncated, corrupted, a format version
  /// this build does not read, an implausible config or normalisation, a card decision threshold
  /// outside (0, 1)); the message names the path and the reason.
  static core::Result<GqcnnModel> Load(const std::filesystem::path& path);

  /// P(grasp succeeds) in [0, 1] for each of n grasps. `crops_depth_m`: n x gqcnn::kCropPixels
  /// row-major crops (gqcnn/dataset_format.h: absolute depth in metres, 0 = missing; non-finite
  /// values are taken as missing too); `grasp_depths_m`: n. Normalisation (the training set's
  /// statistics) happens inside. Runs without gradients in batches of up to 256 crops.
  /// Thread-safe: concurrent calls are serialised (one forward at a time; the 2-core budget is
  /// shared anyway). `clearances_m`: n x 3 (jaws, palm, floor; gqcnn::GripperClearance, in
  /// metres), read when the network takes them (takes_clearances()), may be empty otherwise.
  /// @throws std::invalid_argument when crops_depth_m.size() != grasp_depths_m.size() *
  /// kCropPixels, or clearances_m is neither empty nor 3 per grasp, or empty when they are taken.
  std::vector<float> Predict(std::span<const float> crops_depth_m,
                             std::span<const float> grasp_depths_m,
                             std::span<const float> clearances_m = {}) const;

  /// Whether the network takes the gripper's clearance besides crop and grasp depth.
  bool takes_clearances() const;

  /// The model card stored in the file: training data, steps, time, validation metrics,
  /// normalisation, architecture, parameter count, the baseline fitted on the training split.
  const nlohmann::json& Card() const;

  /// Where P(success) is cut into "predicted to succeed": the card's `decision_threshold.p`,
  /// written by `softgrasp-train gqcnn-calibrate` (chosen on labelled objects of the kind the
  /// network is used on; docs/gqcnn.md), or 0.5 for a card without one.
  double decision_threshold() const;
  /// The card's `decision_threshold` object, or null for a card without one.
  const nlohmann::json& decision_threshold_card() const;

  std::int64_t parameter_count() const;
  const std::string& description() const;  ///< one line: architecture and parameter count

  GqcnnModel(GqcnnModel&&) noexcept;
  GqcnnModel& operator=(GqcnnModel&&) noexcept;
  ~GqcnnModel();

  struct Impl;  // service/models/gqcnn_model.cpp

 private:
  explicit GqcnnModel(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace softgrasp::models
