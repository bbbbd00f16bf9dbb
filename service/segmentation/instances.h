#pragma once
/// Object instances in a depth image: the common result of every segmenter (the learned model in
/// service/models, the PCL baseline here) and what the service reports about each instance.
/// See docs/segmentation.md.

#include <array>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "service/core/depth.h"
#include "service/core/preprocess.h"

namespace softgrasp::segmentation {

/// Which segmenter produced an InstanceMasks.
/// kFused: the model's instances plus the objects only the PCL baseline found (fuse.h).
enum class Method { kModel, kPcl, kFused };
const char* MethodName(Method method);  ///< "model" | "pcl" | "fused"

/// Instances as a label image: 0 = background (floor, bin, table, nothing), 1..N = instance ids,
/// dense (every id in 1..N has at least one pixel). scores[id - 1] in [0, 1] is the segmenter's
/// confidence in instance id.
struct InstanceMasks {
  cv::Mat1w labels;
  std::vector<float> scores;
  int count() const { return static_cast<int>(scores.size()); }
};

/// Renumbers `labels` (any ids, 0 = background) so ids become dense 1..N in order of decreasing
/// score (ties: larger area first, then smaller old id), dropping ids with fewer than
/// `min_area_px` pixels (they become 0). `score_of_old_id(old_id)` gives each old id's score.
/// Deterministic.
template <class ScoreFn>
InstanceMasks Compact(const cv::Mat1w& labels, int min_area_px, ScoreFn&& score_of_old_id);

/// Drops instances cut by the image border (objects reaching out of the field of view, or a
/// wrist camera's own gripper fingers): those with at least `max_border_px` pixels on the
/// outermost rows and columns. Survivors keep their order and scores, renumbered densely.
/// max_border_px <= 0 keeps everything.
InstanceMasks DropCutByBorder(const InstanceMasks& masks, int max_border_px);

/// What the service reports per instance (POST /v1/segmentation, docs/segmentation.md).
struct InstanceInfo {
  int id = 0;
  float score = 0;
  int area_px = 0;
  cv::Rect bbox_px;                         ///< tight bounding box, pixels
  std::array<double, 2> centroid_px{0, 0};  ///< mean (u, v) of the mask's pixels
  std::array<double, 3> centroid_m{0, 0,
                                   0};  ///< mean of the back-projected mask points, camera frame C
  double top_height_m = 0;              ///< highest surface above the fitted floor
  std::optional<double> mean_deformability;  ///< mean of the deformability map in the mask
  std::optional<double> mean_stiffness;      ///< mean of the stiffness map in the mask
};

/// Statistics of every instance of `masks` over the preprocessed `scene` (depth_filled_m,
/// height_m) seen by `camera`. `deformability` / `stiffness`, when non-empty, must have the
/// labels' size; their means fill the optional fields.
/// @throws std::invalid_argument on size mismatches.
std::vector<InstanceInfo> DescribeInstances(const InstanceMasks& masks, const core::Scene& scene,
                                            const core::Camera& camera,
                                            const cv::Mat1f& deformability = {},
                                            const cv::Mat1f& stiffness = {});

// ---- implementation of the template ----
namespace detail {
struct OldIdStats {
  int old_id = 0;
  int area_px = 0;
  float score = 0;
};
std::vector<OldIdStats> CountOldIds(const cv::Mat1w& labels);
InstanceMasks Renumber(const cv::Mat1w& labels, std::vector<OldIdStats> stats, int min_area_px);
}  // namespace detail

template <class ScoreFn>
InstanceMasks Compact(const cv::Mat1w& labels, int min_area_px, ScoreFn&& score_of_old_id) {
  std::vector<detail::OldIdStats> stats = detail::CountOldIds(labels);
  for (auto& s : stats) s.score = static_cast<float>(score_of_old_id(s.old_id));
  return detail::Renumber(labels, std::move(stats), min_area_px);
}

}  // namespace softgrasp::segmentation
