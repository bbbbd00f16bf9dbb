#pragma once
/// COCO-style instance mask metrics computed by our own code (docs/segmentation-metrics.md):
/// mask AP averaged over IoU 0.50:0.05:0.95, AP50, AP75 and AR (at most 100 detections per
/// image), class-agnostic, over a set of images. Ground-truth instances marked as ignored (e.g.
/// mostly hidden ones, < 10 % visible) count neither as misses nor, when a prediction matches
/// them, as false positives, exactly as COCO treats "crowd"/ignored regions.

#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "service/segmentation/instances.h"

namespace softgrasp::segmentation {

/// One image's ground truth: a label image (0 = background, ids > 0 objects), the ids to
/// ignore, and optionally each id's category (for per-category recall).
struct TruthImage {
  cv::Mat1w labels;
  std::vector<int> ignored_ids;
  std::map<int, std::string> category_of_id;
};

/// Recall of one category's non-ignored truth instances under the class-agnostic matching
/// (truth ids without an entry in TruthImage::category_of_id belong to no category).
struct CategoryScores {
  int instances = 0;         ///< non-ignored ground-truth instances of the category
  double recall50 = 0;       ///< fraction matched by a detection at IoU >= 0.5
  double ar = 0;             ///< recall averaged over IoU 0.50:0.05:0.95
  double mean_best_iou = 0;  ///< mean over its instances of the best IoU of any evaluated
                             ///< detection (0 for an instance no detection overlaps)
};

/// Scores over every image added. ap, ap50, ap75 and ar are -1 when no image holds a
/// non-ignored truth instance (undefined, as pycocotools reports it), 0 with truth but no
/// detection.
struct MaskScores {
  double ap = 0;    ///< mean over the 10 IoU thresholds of the 101-point interpolated AP
  double ap50 = 0;  ///< the 101-point interpolated AP at IoU 0.50
  double ap75 = 0;  ///< the 101-point interpolated AP at IoU 0.75
  double ar = 0;    ///< mean over the 10 thresholds of the recall (max 100 detections per image)
  int images = 0;
  int truth_instances = 0;      ///< not ignored
  int predicted_instances = 0;  ///< detections evaluated (at most 100 per image)
  /// A calibrated "confident" threshold: the lowest detection score s such that, of the
  /// detections scored >= s, at least kConfidentPrecision are true positives at IoU 0.50
  /// (detections ignored by the crowd rule not counted); -1 when no score reaches it.
  double confident_score = -1;
  double confident_recall50 = 0;  ///< recall at IoU 0.50 of the detections scored >= that
  std::map<std::string, CategoryScores> per_category;
};

/// Number of IoU thresholds: t_k = (50 + 5 k) / 100 for k = 0..9, i.e. 0.50:0.05:0.95.
inline constexpr int kMaskIouThresholds = 10;
/// The precision at IoU 0.50 that defines MaskScores::confident_score.
inline constexpr double kConfidentPrecision = 0.9;
/// At most this many detections per image (the highest-scored ones) are evaluated.
inline constexpr int kMaxDetectionsPerImage = 100;

/// Accumulates images, then computes the scores over all of them (COCO pools detections across
/// images before ranking by score). The exact definition is in docs/segmentation-metrics.md:
/// per image, the (at most 100) detections in decreasing score order match greedily, at each
/// threshold t, the unmatched non-ignored truth of highest IoU >= t (IoU compared exactly, as
/// integer pixel ratios); a detection with no such truth is ignored when some ignored truth
/// covers at least a fraction t of the detection (COCO's crowd rule: intersection / detection
/// area), a false positive otherwise. AP is the 101-point interpolated precision of the pooled
/// ranking. With no non-ignored truth at all, ap, ap50, ap75 and ar are -1 (as pycocotools).
class MaskEvaluator {
 public:
  /// Evaluates one image's detections against its truth and keeps the outcome (the pixels are
  /// not kept). `predicted` may have an empty label image when it holds no instance.
  /// @throws std::invalid_argument when the label images differ in size, when a predicted
  /// label exceeds predicted.count(), or when a score is not finite.
  void Add(const TruthImage& truth, const InstanceMasks& predicted);
  MaskScores Compute() const;

 private:
  /// What one evaluated detection is at one threshold.
  enum class Outcome : unsigned char { kFalsePositive, kTruePositive, kIgnored };
  struct Detection {
    float score = 0;
    int image = 0;
    Outcome outcome[kMaskIouThresholds] = {};
  };
  /// Per category, sums over its non-ignored truth instances.
  struct CategoryTally {
    int instances = 0;
    int matched[kMaskIouThresholds] = {};  ///< instances matched at threshold k
    double best_iou_sum = 0;
  };
  std::vector<Detection> detections_;
  std::map<std::string, CategoryTally> categories_;
  int images_ = 0;
  int truth_instances_ = 0;  ///< non-ignored, over all images
};

/// IoU of two binary masks (non-zero = inside); 0 when both are empty.
/// @throws std::invalid_argument when the sizes differ.
double MaskIou(const cv::Mat1b& a, const cv::Mat1b& b);

}  // namespace softgrasp::segmentation
