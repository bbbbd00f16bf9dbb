#pragma once
/// `softgrasp-train gqcnn-eval`'s figures (docs/gqcnn.md, "Evaluation"): classification at a
/// threshold and precision of the top-ranked grasp per image, with percentile-bootstrap
/// intervals that resample objects (a held-out object's grasps are not independent of each
/// other, so the unit of the resample is the object).

#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "tools/train/bootstrap.h"

namespace softgrasp::tools {

/// Grasps to score: one entry per grasp in every span (equal sizes).
struct GqcnnScored {
  std::span<const std::uint8_t> labels;        ///< 1 = the grasp succeeds
  std::span<const float> probabilities;        ///< predicted P(success)
  std::span<const std::uint32_t> object_keys;  ///< any integers; the bootstrap's units
  std::span<const std::uint32_t> image_keys;   ///< grasps of one rendered image share a key
  /// Per grasp, its own decision threshold (calibrated per dataset); empty: the threshold
  /// argument of ComputeGqcnnMetrics for every grasp.
  std::span<const double> thresholds = {};
};

struct GqcnnMetrics {
  std::int64_t grasps = 0, images = 0, objects = 0;
  double tp = 0, fp = 0, tn = 0, fn = 0;  ///< at the threshold (p >= threshold is "succeeds")
  double accuracy = 0;
  double balanced_accuracy = 0;  ///< (recall + specificity) / 2; NaN without both classes
  double precision = 0;          ///< NaN when nothing is predicted positive
  double recall = 0;             ///< NaN without positives
  double positive_rate = 0;      ///< of the labels
  /// Over images: is the grasp with the highest probability (the first on ties) a positive?
  double top1_precision = 0;
  /// Over images: does the image have any positive grasp (the ceiling of top1_precision)?
  double images_with_a_positive = 0;
};

/// Per object, the counts a resample adds up.
struct GqcnnObjectCounts {
  double tp = 0, fp = 0, tn = 0, fn = 0;
  double images = 0, top1_positive = 0, images_with_a_positive = 0;
};

/// Counts per object (in order of first appearance) and the metrics of all grasps.
/// @throws std::invalid_argument when the spans differ in size.
GqcnnMetrics ComputeGqcnnMetrics(const GqcnnScored& scored, double threshold,
                                 std::vector<GqcnnObjectCounts>* per_object = nullptr);

/// A decision threshold chosen on labelled grasps of another kind than the network was trained
/// on (docs/gqcnn.md, "A decision threshold calibrated on real meshes").
struct ThresholdChoice {
  double threshold = 0.5;
  double balanced_accuracy = 0;  ///< on the grasps it was chosen on
};
/// The threshold of highest balanced accuracy among 0.01, 0.02, ..., 0.99 (p >= threshold is
/// "succeeds", as in ComputeGqcnnMetrics); of equal ones, the nearest 0.5, then the lower.
/// @throws std::invalid_argument when the spans differ in size or the labels lack a class.
ThresholdChoice ChooseBalancedAccuracyThreshold(std::span<const std::uint8_t> labels,
                                                std::span<const float> probabilities);

/// Metrics of the objects in `sample` (indices into per_object, with repetition).
GqcnnMetrics MetricsOfSample(const std::vector<GqcnnObjectCounts>& per_object,
                             std::span<const int> sample);

struct GqcnnIntervals {
  Interval accuracy, balanced_accuracy, precision, recall, top1_precision;
};
/// 95 % percentile intervals, resampling objects (BootstrapInterval's rules: NaN when too few).
GqcnnIntervals BootstrapGqcnnMetrics(const std::vector<GqcnnObjectCounts>& per_object,
                                     int resamples, std::uint64_t seed);

/// {"accuracy": x, "accuracy_ci95": [lo, hi], ...} with NaN written as null.
nlohmann::json GqcnnMetricsJson(const GqcnnMetrics& m, const GqcnnIntervals& ci);

}  // namespace softgrasp::tools
