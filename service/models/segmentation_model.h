#pragma once
/// Instance segmentation and deformability from one depth image (thesis ch. 5;
/// docs/segmentation.md): a U-Net with four heads (foreground, instance-centre heatmap, centre
/// offsets, deformability) whose centre votes are grouped into instances. The header does not
/// include libtorch.
///
///   auto model = models::SegmentationModel::Load("models/segmentation.pt");
///   if (!model.ok()) return model.error();
///   auto out = model.value().SegmentScene(scene);  // labels, scores, deformability map

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "service/core/preprocess.h"
#include "service/core/status.h"
#include "service/models/segmentation_grouping.h"
#include "service/segmentation/instances.h"

namespace softgrasp::models {

struct SegmentationOutput {
  segmentation::InstanceMasks instances;  ///< labels at the scene's size, scores in [0, 1]
  cv::Mat1f deformability;                ///< [0, 1] (0 rigid ... 1 very soft), 0 on background
  cv::Mat1f foreground;                   ///< foreground probability [0, 1]
};

class SegmentationModel {
 public:
  /// Reads a model file written by `softgrasp-train segmentation`. Errors: kNotFound (no such
  /// file), kUnprocessable (not a segmentation model file, truncated, corrupted, or a format
  /// version this build does not read); the message names the path.
  static core::Result<SegmentationModel> Load(const std::filesystem::path& path);

  /// Segments a preprocessed scene (core::Preprocess). Outputs have the scene's size.
  SegmentationOutput SegmentScene(const core::Scene& scene,
                                  const GroupingParams& grouping = {}) const;

  int input_width() const;  ///< model input, pixels
  int input_height() const;
  std::int64_t parameter_count() const;
  const std::string& description() const;  ///< the config line stored in the file

  SegmentationModel(SegmentationModel&&) noexcept;
  SegmentationModel& operator=(SegmentationModel&&) noexcept;
  ~SegmentationModel();

  struct Impl;  // service/models/segmentation_model.cpp

 private:
  explicit SegmentationModel(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace softgrasp::models
