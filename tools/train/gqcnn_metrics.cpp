#include "tools/train/gqcnn_metrics.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

namespace softgrasp::tools {
namespace {

double Ratio(double a, double b) { return b > 0 ? a / b : std::nan(""); }

void Finish(GqcnnMetrics& m, double images, double top1, double any_positive) {
  const double n = m.tp + m.fp + m.tn + m.fn;
  m.accuracy = Ratio(m.tp + m.tn, n);
  m.recall = Ratio(m.tp, m.tp + m.fn);
  m.precision = Ratio(m.tp, m.tp + m.fp);
  m.balanced_accuracy = 0.5 * (m.recall + Ratio(m.tn, m.tn + m.fp));
  m.positive_rate = Ratio(m.tp + m.fn, n);
  m.top1_precision = Ratio(top1, images);
  m.images_with_a_positive = Ratio(any_positive, images);
}

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

GqcnnMetrics ComputeGqcnnMetrics(const GqcnnScored& s, double threshold,
                                 std::vector<GqcnnObjectCounts>* per_object) {
  const std::size_t n = s.labels.size();
  if (s.probabilities.size() != n || s.object_keys.size() != n || s.image_keys.size() != n ||
      (!s.thresholds.empty() && s.thresholds.size() != n)) {
    throw std::invalid_argument("ComputeGqcnnMetrics: spans of different sizes");
  }
  std::map<std::uint32_t, std::size_t> objects;  // key -> dense index, first appearance
  std::vector<GqcnnObjectCounts> counts;
  struct Image {
    std::size_t best = 0;   ///< first grasp with the image's highest probability
    int tied = 0;           ///< grasps with that probability ...
    int tied_positive = 0;  ///< ... and the positives among them
    bool any_positive = false;
  };
  std::map<std::uint32_t, Image> images;
  for (std::size_t i = 0; i < n; ++i) {
    const auto [it, inserted] = objects.try_emplace(s.object_keys[i], counts.size());
    if (inserted) counts.emplace_back();
    GqcnnObjectCounts& c = counts[it->second];
    const bool label = s.labels[i] != 0;
    const bool predicted =
        s.probabilities[i] >= (s.thresholds.empty() ? threshold : s.thresholds[i]);
    c.tp += label && predicted;
    c.fp += !label && predicted;
    c.tn += !label && !predicted;
    c.fn += label && !predicted;
    const auto [im, first] = images.try_emplace(s.image_keys[i], Image{i, 1, label, label});
    if (!first) {
      Image& image = im->second;
      const float top = s.probabilities[image.best];
      if (s.probabilities[i] > top) {
        image = Image{i, 1, label, image.any_positive || label};
      } else {
        if (s.probabilities[i] == top) {
          image.tied += 1;
          image.tied_positive += label;
        }
        image.any_positive = image.any_positive || label;
      }
    }
  }
  for (const auto& [key, image] : images) {
    // An image belongs to the object of its top-ranked grasp (one object per image in
    // single-object datasets).
    GqcnnObjectCounts& c = counts[objects.at(s.object_keys[image.best])];
    c.images += 1;
    // Ties at the top are broken at random: the expected outcome, so a constant predictor
    // (the majority baseline) scores the image's positive rate, not the file order's luck.
    c.top1_positive += static_cast<double>(image.tied_positive) / image.tied;
    c.images_with_a_positive += image.any_positive;
  }
  std::vector<int> all(counts.size());
  for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
  GqcnnMetrics m = MetricsOfSample(counts, all);
  m.grasps = static_cast<std::int64_t>(n);
  if (per_object) *per_object = std::move(counts);
  return m;
}

ThresholdChoice ChooseBalancedAccuracyThreshold(std::span<const std::uint8_t> labels,
                                                std::span<const float> probabilities) {
  if (labels.size() != probabilities.size()) {
    throw std::invalid_argument("ChooseBalancedAccuracyThreshold: spans of different sizes");
  }
  constexpr int kSteps = 100;  // thresholds k / kSteps, k = 1 .. kSteps - 1
  // Per grid cell, how many positives and negatives have a probability that clears exactly the
  // thresholds up to it: cell k counts p in [k / kSteps, (k + 1) / kSteps), with the same
  // comparison as ComputeGqcnnMetrics (float p against the double threshold).
  std::vector<double> positives(kSteps, 0.0), negatives(kSteps, 0.0);
  for (std::size_t i = 0; i < labels.size(); ++i) {
    int cleared = 0;  // the highest k with p >= k / kSteps (0: below the grid, or NaN)
    const double p = probabilities[i];
    if (p >= 1.0 / kSteps) {
      // Clamped before the cast: any float, infinity too, lands in the grid.
      cleared = static_cast<int>(std::min<double>(kSteps - 1, std::floor(p * kSteps)));
      while (cleared < kSteps - 1 && p >= static_cast<double>(cleared + 1) / kSteps) ++cleared;
      while (cleared > 0 && !(p >= static_cast<double>(cleared) / kSteps)) --cleared;
    }
    (labels[i] != 0 ? positives : negatives)[static_cast<std::size_t>(cleared)] += 1;
  }
  double total_positive = 0, total_negative = 0;
  for (int k = 0; k < kSteps; ++k) {
    total_positive += positives[static_cast<std::size_t>(k)];
    total_negative += negatives[static_cast<std::size_t>(k)];
  }
  if (total_positive == 0 || total_negative == 0) {
    throw std::invalid_argument(
        "ChooseBalancedAccuracyThreshold: the labels need both successes and failures");
  }
  // Walk the thresholds upwards: at k, the grasps of cells 0 .. k-1 are predicted to fail.
  ThresholdChoice best{0.5, -1.0};
  double below_positive = 0, below_negative = 0;
  for (int k = 1; k < kSteps; ++k) {
    below_positive += positives[static_cast<std::size_t>(k - 1)];
    below_negative += negatives[static_cast<std::size_t>(k - 1)];
    const double t = static_cast<double>(k) / kSteps;
    const double ba = 0.5 * ((total_positive - below_positive) / total_positive +
                             below_negative / total_negative);
    const bool nearer = std::abs(t - 0.5) < std::abs(best.threshold - 0.5);
    if (ba > best.balanced_accuracy || (ba == best.balanced_accuracy && nearer)) best = {t, ba};
  }
  return best;
}

GqcnnMetrics MetricsOfSample(const std::vector<GqcnnObjectCounts>& per_object,
                             std::span<const int> sample) {
  GqcnnMetrics m;
  double images = 0, top1 = 0, any = 0;
  for (const int k : sample) {
    const GqcnnObjectCounts& c = per_object.at(static_cast<std::size_t>(k));
    m.tp += c.tp;
    m.fp += c.fp;
    m.tn += c.tn;
    m.fn += c.fn;
    images += c.images;
    top1 += c.top1_positive;
    any += c.images_with_a_positive;
  }
  m.grasps = static_cast<std::int64_t>(m.tp + m.fp + m.tn + m.fn);
  m.images = static_cast<std::int64_t>(images);
  m.objects = static_cast<std::int64_t>(sample.size());
  Finish(m, images, top1, any);
  return m;
}

GqcnnIntervals BootstrapGqcnnMetrics(const std::vector<GqcnnObjectCounts>& per_object,
                                     int resamples, std::uint64_t seed) {
  GqcnnIntervals ci;
  const int units = static_cast<int>(per_object.size());
  if (units < 1) return ci;
  auto interval = [&](double GqcnnMetrics::*field) {
    return BootstrapInterval(
        units,
        [&](std::span<const int> sample) { return MetricsOfSample(per_object, sample).*field; },
        resamples, seed);
  };
  // The same seed for every figure: each is computed on the same resamples of objects.
  ci.accuracy = interval(&GqcnnMetrics::accuracy);
  ci.balanced_accuracy = interval(&GqcnnMetrics::balanced_accuracy);
  ci.precision = interval(&GqcnnMetrics::precision);
  ci.recall = interval(&GqcnnMetrics::recall);
  ci.top1_precision = interval(&GqcnnMetrics::top1_precision);
  return ci;
}

nlohmann::json GqcnnMetricsJson(const GqcnnMetrics& m, const GqcnnIntervals& ci) {
  auto pair = [](const Interval& i) {
    return nlohmann::json::array({Number(i.low), Number(i.high)});
  };
  return {{"grasps", m.grasps},
          {"images", m.images},
          {"objects", m.objects},
          {"confusion", {{"tp", m.tp}, {"fp", m.fp}, {"tn", m.tn}, {"fn", m.fn}}},
          {"positive_rate", Number(m.positive_rate)},
          {"accuracy", Number(m.accuracy)},
          {"accuracy_ci95", pair(ci.accuracy)},
          {"balanced_accuracy", Number(m.balanced_accuracy)},
          {"balanced_accuracy_ci95", pair(ci.balanced_accuracy)},
          {"precision", Number(m.precision)},
          {"precision_ci95", pair(ci.precision)},
          {"recall", Number(m.recall)},
          {"recall_ci95", pair(ci.recall)},
          {"top1_precision", Number(m.top1_precision)},
          {"top1_precision_ci95", pair(ci.top1_precision)},
          {"images_with_a_positive", Number(m.images_with_a_positive)}};
}

}  // namespace softgrasp::tools
