#pragma once
/// Grouping the segmentation network's per-pixel heads into instances (docs/segmentation.md,
/// "Grouping"), as Panoptic-DeepLab does: centres are the peaks of the centre heatmap, and every
/// foreground pixel joins the centre nearest to where its offset points. Pure OpenCV, no libtorch.

#include <opencv2/core.hpp>

#include "service/segmentation/instances.h"

namespace softgrasp::models {

/// Grouping thresholds.
struct GroupingParams {
  float foreground_threshold = 0.5f;  ///< foreground probability above which a pixel is an object
  float centre_threshold = 0.1f;      ///< heatmap peaks below this start no instance
  int peak_window_px = 11;            ///< non-maximum suppression window, model pixels (odd)
  int max_instances = 100;            ///< strongest peaks kept
  int min_area_px = 60;               ///< at the output resolution; smaller instances are dropped
  /// A foreground pixel joins the nearest centre only when its offset lands within this many
  /// model pixels of it; farther votes join nothing (a stray blob far from every centre is not
  /// glued to the nearest object). 0 = no limit (plain Panoptic-DeepLab).
  float max_vote_distance_px = 24.0f;
  /// Instances with at least this many pixels on the image's outermost rows and columns are
  /// dropped (segmentation::DropCutByBorder), at 640 px width, scaled with the width: objects cut
  /// by the field of view and a wrist camera's own fingers. The PCL baseline's rule. 0 = keep.
  int max_border_px = 20;
};

/// The heads at model resolution (all the same size).
struct HeadMaps {
  cv::Mat1f foreground;   ///< probability [0, 1]
  cv::Mat1f centre;       ///< heatmap [0, 1], peaks at instance centres
  cv::Mat1f offset_u_px;  ///< from the pixel to its instance's centre, model pixels
  cv::Mat1f offset_v_px;
};

/// Instances at `output_size` (the input image's size; the heads are resized bilinearly and the
/// offsets scaled; `max_vote_distance_px` is scaled likewise). Score of an instance = its peak's
/// heatmap value x the mean foreground probability of its pixels. `foreground_out`, when given,
/// receives the foreground probability at output_size. Deterministic. @throws std::invalid_argument
/// if the maps differ in size or are empty.
segmentation::InstanceMasks GroupInstances(const HeadMaps& maps, cv::Size output_size,
                                           const GroupingParams& params = {},
                                           cv::Mat1f* foreground_out = nullptr);

}  // namespace softgrasp::models
