#include "service/segmentation/instance_metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace softgrasp::segmentation {
namespace {

/// Threshold k as a percentage: t_k = kThresholdPercent(k) / 100, compared exactly.
constexpr std::int64_t ThresholdPercent(int k) { return 50 + 5 * static_cast<std::int64_t>(k); }
/// Recall points r_j = j / 100, j = 0..100 (pycocotools' recThrs).
constexpr int kRecallPoints = 101;

/// True when inter / denominator >= t_k, in integers (no rounding at the boundary).
bool AtLeast(std::int64_t inter, std::int64_t denominator, int k) {
  return inter > 0 && 100 * inter >= ThresholdPercent(k) * denominator;
}

/// 101-point interpolated AP of a ranking (ignored detections already removed): cumulative true
/// positives tp[i] and false positives fp[i] after the first i + 1 detections, `truths` > 0.
double InterpolatedAp(const std::vector<int>& tp, const std::vector<int>& fp, int truths) {
  const std::size_t n = tp.size();
  std::vector<double> precision(n);
  for (std::size_t i = 0; i < n; ++i) precision[i] = static_cast<double>(tp[i]) / (tp[i] + fp[i]);
  // Envelope: the precision at i becomes the best precision at any recall >= recall[i].
  for (std::size_t i = n; i-- > 1;) precision[i - 1] = std::max(precision[i - 1], precision[i]);
  double sum = 0;
  std::size_t i = 0;  // first detection with recall >= r_j; recall is non-decreasing
  for (int j = 0; j < kRecallPoints; ++j) {
    while (i < n && 100 * static_cast<std::int64_t>(tp[i]) < static_cast<std::int64_t>(j) * truths)
      ++i;
    if (i == n) break;  // recall r_j never reached: precision 0 from here on
    sum += precision[i];
  }
  return sum / kRecallPoints;
}

}  // namespace

void MaskEvaluator::Add(const TruthImage& truth, const InstanceMasks& predicted) {
  const int detections = predicted.count();
  const bool no_predicted_image = predicted.labels.empty();
  if (no_predicted_image && detections > 0) {
    throw std::invalid_argument("MaskEvaluator::Add: predicted scores without a label image");
  }
  if (!no_predicted_image && predicted.labels.size() != truth.labels.size()) {
    throw std::invalid_argument(
        "MaskEvaluator::Add: truth and predicted label images differ in size");
  }
  for (float s : predicted.scores) {
    if (!std::isfinite(s)) throw std::invalid_argument("MaskEvaluator::Add: non-finite score");
  }

  // Truth ids present in the image, densely indexed from 1 in increasing id order (0 = background).
  std::vector<int> truth_index(std::numeric_limits<std::uint16_t>::max() + 1, 0);
  for (int v = 0; v < truth.labels.rows; ++v) {
    const std::uint16_t* row = truth.labels[v];
    for (int u = 0; u < truth.labels.cols; ++u) truth_index[row[u]] = 1;
  }
  truth_index[0] = 0;
  std::vector<int> truth_ids;  // truth_ids[index - 1] = id
  for (std::size_t id = 1; id < truth_index.size(); ++id) {
    if (truth_index[id] != 0) {
      truth_ids.push_back(static_cast<int>(id));
      truth_index[id] = static_cast<int>(truth_ids.size());
    }
  }
  const int truths = static_cast<int>(truth_ids.size());

  // One pass over the pixels: joint[t * stride + p] counts pixels of truth index t (0 =
  // background) and predicted id p (0 = background). Areas are its row and column sums.
  const auto stride = static_cast<std::size_t>(detections) + 1;
  std::vector<std::int64_t> joint((static_cast<std::size_t>(truths) + 1) * stride, 0);
  for (int v = 0; v < truth.labels.rows; ++v) {
    const std::uint16_t* truth_row = truth.labels[v];
    const std::uint16_t* predicted_row = no_predicted_image ? nullptr : predicted.labels[v];
    for (int u = 0; u < truth.labels.cols; ++u) {
      const int p = predicted_row != nullptr ? predicted_row[u] : 0;
      if (p > detections) {
        throw std::invalid_argument("MaskEvaluator::Add: predicted label " + std::to_string(p) +
                                    " exceeds the " + std::to_string(detections) + " scores");
      }
      ++joint[static_cast<std::size_t>(truth_index[truth_row[u]]) * stride +
              static_cast<std::size_t>(p)];
    }
  }
  const auto at = [&](int t, int p) {
    return joint[static_cast<std::size_t>(t) * stride + static_cast<std::size_t>(p)];
  };
  std::vector<std::int64_t> truth_area(static_cast<std::size_t>(truths) + 1, 0);
  std::vector<std::int64_t> predicted_area(stride, 0);
  for (int t = 0; t <= truths; ++t) {
    for (int p = 0; p <= detections; ++p) {
      truth_area[static_cast<std::size_t>(t)] += at(t, p);
      predicted_area[static_cast<std::size_t>(p)] += at(t, p);
    }
  }

  // Truth indices, non-ignored and ignored (each in increasing id order).
  std::vector<int> counted, ignored;
  for (int t = 1; t <= truths; ++t) {
    const int id = truth_ids[static_cast<std::size_t>(t - 1)];
    const bool is_ignored = std::find(truth.ignored_ids.begin(), truth.ignored_ids.end(), id) !=
                            truth.ignored_ids.end();
    (is_ignored ? ignored : counted).push_back(t);
  }

  // Detections by decreasing score (ties: lower id first), at most kMaxDetectionsPerImage.
  std::vector<int> order(static_cast<std::size_t>(detections));
  std::iota(order.begin(), order.end(), 1);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return predicted.scores[static_cast<std::size_t>(a - 1)] >
           predicted.scores[static_cast<std::size_t>(b - 1)];
  });
  if (order.size() > static_cast<std::size_t>(kMaxDetectionsPerImage))
    order.resize(kMaxDetectionsPerImage);

  const std::size_t first_detection = detections_.size();
  for (std::size_t r = 0; r < order.size(); ++r) {
    Detection d;
    d.score = predicted.scores[static_cast<std::size_t>(order[r] - 1)];
    d.image = images_;
    detections_.push_back(d);
  }

  // Categories of the non-ignored truths (nullptr: none).
  std::vector<CategoryTally*> tally(counted.size(), nullptr);
  for (std::size_t j = 0; j < counted.size(); ++j) {
    const int id = truth_ids[static_cast<std::size_t>(counted[j] - 1)];
    const auto category = truth.category_of_id.find(id);
    if (category == truth.category_of_id.end()) continue;
    tally[j] = &categories_[category->second];
    ++tally[j]->instances;
  }

  // Greedy matching, independently at each threshold.
  std::vector<char> matched(counted.size());
  for (int k = 0; k < kMaskIouThresholds; ++k) {
    std::fill(matched.begin(), matched.end(), 0);
    for (std::size_t r = 0; r < order.size(); ++r) {
      const int p = order[r];
      const std::int64_t area_p = predicted_area[static_cast<std::size_t>(p)];
      // The unmatched non-ignored truth of highest IoU >= t_k (ties: the lower id).
      int best = -1;
      std::int64_t best_inter = 0, best_union = 1;
      for (std::size_t j = 0; j < counted.size(); ++j) {
        if (matched[j] != 0) continue;
        const int t = counted[j];
        const std::int64_t inter = at(t, p);
        const std::int64_t uni = truth_area[static_cast<std::size_t>(t)] + area_p - inter;
        if (!AtLeast(inter, uni, k)) continue;
        if (best < 0 || inter * best_union > best_inter * uni) {
          best = static_cast<int>(j);
          best_inter = inter;
          best_union = uni;
        }
      }
      Outcome& outcome = detections_[first_detection + r].outcome[k];
      if (best >= 0) {
        outcome = Outcome::kTruePositive;
        matched[static_cast<std::size_t>(best)] = 1;
        if (CategoryTally* c = tally[static_cast<std::size_t>(best)]) ++c->matched[k];
        continue;
      }
      // COCO's crowd rule: an ignored truth absorbs the detection when it covers at least t_k
      // of the detection's area; an ignored truth absorbs any number of detections.
      const bool on_ignored = std::any_of(ignored.begin(), ignored.end(),
                                          [&](int t) { return AtLeast(at(t, p), area_p, k); });
      outcome = on_ignored ? Outcome::kIgnored : Outcome::kFalsePositive;
    }
  }

  // Best IoU of any evaluated detection, per categorised truth.
  for (std::size_t j = 0; j < counted.size(); ++j) {
    if (tally[j] == nullptr) continue;
    const int t = counted[j];
    double best_iou = 0;
    for (int p : order) {
      const std::int64_t inter = at(t, p);
      if (inter == 0) continue;
      const std::int64_t uni = truth_area[static_cast<std::size_t>(t)] +
                               predicted_area[static_cast<std::size_t>(p)] - inter;
      best_iou = std::max(best_iou, static_cast<double>(inter) / static_cast<double>(uni));
    }
    tally[j]->best_iou_sum += best_iou;
  }

  truth_instances_ += static_cast<int>(counted.size());
  ++images_;
}

MaskScores MaskEvaluator::Compute() const {
  MaskScores scores;
  scores.images = images_;
  scores.truth_instances = truth_instances_;
  scores.predicted_instances = static_cast<int>(detections_.size());
  for (const auto& [name, tally] : categories_) {
    CategoryScores c;
    c.instances = tally.instances;
    if (tally.instances > 0) {
      const double n = tally.instances;
      c.recall50 = tally.matched[0] / n;
      double recall_sum = 0;
      for (int k = 0; k < kMaskIouThresholds; ++k) recall_sum += tally.matched[k] / n;
      c.ar = recall_sum / kMaskIouThresholds;
      c.mean_best_iou = tally.best_iou_sum / n;
    }
    scores.per_category[name] = c;
  }
  if (truth_instances_ == 0) {
    scores.ap = scores.ap50 = scores.ap75 = scores.ar = -1;
    return scores;
  }

  // Pooled ranking: decreasing score; ties keep the order of addition (image, then rank), as
  // pycocotools' stable sort does.
  std::vector<std::size_t> ranking(detections_.size());
  std::iota(ranking.begin(), ranking.end(), std::size_t{0});
  std::stable_sort(ranking.begin(), ranking.end(), [&](std::size_t a, std::size_t b) {
    return detections_[a].score > detections_[b].score;
  });

  double ap_sum = 0, ar_sum = 0;
  std::vector<int> tp, fp;
  for (int k = 0; k < kMaskIouThresholds; ++k) {
    tp.clear();
    fp.clear();
    int tp_count = 0, fp_count = 0;
    for (std::size_t r = 0; r < ranking.size(); ++r) {
      const Detection& d = detections_[ranking[r]];
      const Outcome o = d.outcome[k];
      if (o == Outcome::kIgnored) continue;
      (o == Outcome::kTruePositive ? tp_count : fp_count) += 1;
      tp.push_back(tp_count);
      fp.push_back(fp_count);
      // A cut between two different scores: everything scored >= d.score is above it.
      const bool cut = r + 1 == ranking.size() || detections_[ranking[r + 1]].score < d.score;
      if (k == 0 && cut && tp_count >= kConfidentPrecision * (tp_count + fp_count)) {
        scores.confident_score = d.score;
        scores.confident_recall50 = static_cast<double>(tp_count) / truth_instances_;
      }
    }
    const double ap = InterpolatedAp(tp, fp, truth_instances_);
    ap_sum += ap;
    ar_sum += static_cast<double>(tp_count) / truth_instances_;
    if (k == 0) scores.ap50 = ap;
    if (k == 5) scores.ap75 = ap;
  }
  scores.ap = ap_sum / kMaskIouThresholds;
  scores.ar = ar_sum / kMaskIouThresholds;
  return scores;
}

double MaskIou(const cv::Mat1b& a, const cv::Mat1b& b) {
  if (a.size() != b.size()) throw std::invalid_argument("MaskIou: masks differ in size");
  std::int64_t inter = 0, uni = 0;
  for (int v = 0; v < a.rows; ++v) {
    const std::uint8_t* row_a = a[v];
    const std::uint8_t* row_b = b[v];
    for (int u = 0; u < a.cols; ++u) {
      const bool in_a = row_a[u] != 0, in_b = row_b[u] != 0;
      inter += in_a && in_b;
      uni += in_a || in_b;
    }
  }
  return uni == 0 ? 0.0 : static_cast<double>(inter) / static_cast<double>(uni);
}

}  // namespace softgrasp::segmentation
