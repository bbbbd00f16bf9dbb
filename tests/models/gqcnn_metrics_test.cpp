// gqcnn-eval's figures on a hand-made set whose confusion matrix and top-ranked grasps are
// worked out below, and the object-wise bootstrap.
#include "tools/train/gqcnn_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace softgrasp::tools {
namespace {

// Object 10: image 1 = (+, 0.9) (-, 0.8) (-, 0.1); image 2 = (-, 0.7) (+, 0.6).
// Object 20: image 3 = (+, 0.4) (-, 0.2); image 4 = (-, 0.3) (-, 0.6).
// At 0.5: TP 2 (0.9, 0.6), FP 3 (0.8, 0.7, 0.6), TN 3 (0.1, 0.2, 0.3), FN 1 (0.4).
// Top-ranked: image 1 -> + , image 2 -> -, image 3 -> +, image 4 -> -.
struct HandMade {
  std::vector<std::uint8_t> labels{1, 0, 0, 0, 1, 1, 0, 0, 0};
  std::vector<float> p{0.9f, 0.8f, 0.1f, 0.7f, 0.6f, 0.4f, 0.2f, 0.3f, 0.6f};
  std::vector<std::uint32_t> objects{10, 10, 10, 10, 10, 20, 20, 20, 20};
  std::vector<std::uint32_t> images{1, 1, 1, 2, 2, 3, 3, 4, 4};
  GqcnnScored Scored() const { return {labels, p, objects, images}; }
};

TEST(GqcnnMetricsTest, KnownConfusionMatrixAndTopRankedGrasps) {
  const HandMade h;
  std::vector<GqcnnObjectCounts> per_object;
  const GqcnnMetrics m = ComputeGqcnnMetrics(h.Scored(), 0.5, &per_object);
  EXPECT_EQ(m.grasps, 9);
  EXPECT_EQ(m.images, 4);
  EXPECT_EQ(m.objects, 2);
  EXPECT_EQ(m.tp, 2);
  EXPECT_EQ(m.fp, 3);
  EXPECT_EQ(m.tn, 3);
  EXPECT_EQ(m.fn, 1);
  EXPECT_DOUBLE_EQ(m.accuracy, 5.0 / 9.0);
  EXPECT_DOUBLE_EQ(m.recall, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(m.precision, 2.0 / 5.0);
  EXPECT_DOUBLE_EQ(m.balanced_accuracy, 0.5 * (2.0 / 3.0 + 3.0 / 6.0));
  EXPECT_DOUBLE_EQ(m.positive_rate, 3.0 / 9.0);
  EXPECT_DOUBLE_EQ(m.top1_precision, 0.5);
  EXPECT_DOUBLE_EQ(m.images_with_a_positive, 0.75);
  ASSERT_EQ(per_object.size(), 2u);
  EXPECT_EQ(per_object[0].tp, 2);
  EXPECT_EQ(per_object[0].fp, 2);
  EXPECT_EQ(per_object[1].fn, 1);
  EXPECT_EQ(per_object[1].top1_positive, 1);

  // Object 10 drawn twice: its counts doubled.
  const std::vector<int> twice{0, 0};
  const GqcnnMetrics a = MetricsOfSample(per_object, twice);
  EXPECT_DOUBLE_EQ(a.accuracy, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(a.balanced_accuracy, 0.5 * (1.0 + 1.0 / 3.0));
  EXPECT_EQ(a.grasps, 10);

  // A higher threshold predicts fewer positives.
  const GqcnnMetrics strict = ComputeGqcnnMetrics(h.Scored(), 0.85, nullptr);
  EXPECT_EQ(strict.tp, 1);
  EXPECT_EQ(strict.fp, 0);
  EXPECT_DOUBLE_EQ(strict.precision, 1.0);
  EXPECT_DOUBLE_EQ(strict.top1_precision, 0.5);  // ranking does not depend on the threshold

  // A threshold per grasp: object 10's at 0.85, object 20's at 0.35 -> TP 0.9 and 0.4, FP
  // object 20's negative at 0.6, FN object 10's positive at 0.6, TN the other five.
  HandMade per_grasp = h;
  const std::vector<double> thresholds{0.85, 0.85, 0.85, 0.85, 0.85, 0.35, 0.35, 0.35, 0.35};
  GqcnnScored scored = per_grasp.Scored();
  scored.thresholds = thresholds;
  const GqcnnMetrics mixed = ComputeGqcnnMetrics(scored, 0.5);
  EXPECT_EQ(mixed.tp, 2);
  EXPECT_EQ(mixed.fp, 1);
  EXPECT_EQ(mixed.tn, 5);
  EXPECT_EQ(mixed.fn, 1);
  const std::vector<double> too_few{0.5};
  scored.thresholds = too_few;
  EXPECT_THROW(ComputeGqcnnMetrics(scored, 0.5), std::invalid_argument);
}

// Equal probabilities at the top of an image count as a random pick among them (in
// expectation), whatever the order of the records: a constant predictor is not credited with
// the order the dataset wrote its grasps in (the best first).
TEST(GqcnnMetricsTest, TiesAtTheTopScoreTheTiedGraspsPositiveRate) {
  std::vector<std::uint8_t> labels{1, 0, 0, 0, 1, 1, 0, 0};
  std::vector<float> constant(8, 0.3f);
  std::vector<std::uint32_t> objects{1, 1, 1, 1, 2, 2, 2, 2};
  std::vector<std::uint32_t> images{1, 1, 1, 1, 2, 2, 2, 2};
  const GqcnnMetrics m = ComputeGqcnnMetrics({labels, constant, objects, images}, 0.5);
  EXPECT_DOUBLE_EQ(m.top1_precision, 0.5 * (1.0 / 4.0 + 2.0 / 4.0));
  // A tie below the top does not matter; one at the top among two.
  std::vector<float> p{0.2f, 0.9f, 0.9f, 0.2f, 0.1f, 0.1f, 0.7f, 0.1f};
  const GqcnnMetrics r = ComputeGqcnnMetrics({labels, p, objects, images}, 0.5);
  EXPECT_DOUBLE_EQ(r.top1_precision, 0.5 * (0.0 + 0.0));
  p[0] = 0.9f;  // image 1: three tied at 0.9, one of them positive
  const GqcnnMetrics t = ComputeGqcnnMetrics({labels, p, objects, images}, 0.5);
  EXPECT_DOUBLE_EQ(t.top1_precision, 0.5 * (1.0 / 3.0 + 0.0));
}

// The hand-made set's balanced accuracy by threshold: 0.5 up to 0.1, 2/3 on (0.2, 0.3], 3/4 on
// (0.3, 0.4] (every positive, the three lowest negatives), less above. Of the grid values
// 0.31 ... 0.40 that reach 3/4, the nearest 0.5 is 0.40 (0.4f >= 0.40 still holds).
TEST(GqcnnMetricsTest, CalibratedThresholdMaximisesBalancedAccuracy) {
  const HandMade h;
  const ThresholdChoice c = ChooseBalancedAccuracyThreshold(h.labels, h.p);
  EXPECT_DOUBLE_EQ(c.threshold, 0.40);
  EXPECT_DOUBLE_EQ(c.balanced_accuracy, 0.75);
  EXPECT_DOUBLE_EQ(ComputeGqcnnMetrics(h.Scored(), c.threshold).balanced_accuracy, 0.75);
  // Ties: perfectly separated at any threshold in (0.2, 0.8] -> the nearest 0.5 is 0.5 itself;
  // separated on (0.6, 0.7] only -> 0.61 (the lowest of those nearest 0.5).
  const std::vector<std::uint8_t> y{1, 0};
  EXPECT_DOUBLE_EQ(ChooseBalancedAccuracyThreshold(y, std::vector<float>{0.8f, 0.2f}).threshold,
                   0.5);
  EXPECT_DOUBLE_EQ(ChooseBalancedAccuracyThreshold(y, std::vector<float>{0.7f, 0.6f}).threshold,
                   0.61);
  // Probabilities off the grid: 0 and NaN never succeed, 1 and infinity always do.
  const ThresholdChoice ends = ChooseBalancedAccuracyThreshold(
      std::vector<std::uint8_t>{1, 1, 0, 0},
      std::vector<float>{1.0f, std::numeric_limits<float>::infinity(), 0.0f, std::nanf("")});
  EXPECT_DOUBLE_EQ(ends.balanced_accuracy, 1.0);
  EXPECT_DOUBLE_EQ(ends.threshold, 0.5);
  // One class only, or spans of different sizes: refused.
  EXPECT_THROW(ChooseBalancedAccuracyThreshold(std::vector<std::uint8_t>{1, 1},
                                               std::vector<float>{0.2f, 0.9f}),
               std::invalid_argument);
  EXPECT_THROW(
      ChooseBalancedAccuracyThreshold(std::vector<std::uint8_t>{1}, std::vector<float>{0.2f, 0.9f}),
      std::invalid_argument);
}

TEST(GqcnnMetricsTest, UndefinedFiguresAreNaNAndSizesMustAgree) {
  std::vector<std::uint8_t> labels{0, 0};
  std::vector<float> p{0.1f, 0.2f};
  std::vector<std::uint32_t> keys{1, 1};
  const GqcnnMetrics m = ComputeGqcnnMetrics({labels, p, keys, keys}, 0.5);
  EXPECT_DOUBLE_EQ(m.accuracy, 1.0);
  EXPECT_TRUE(std::isnan(m.recall));
  EXPECT_TRUE(std::isnan(m.precision));
  EXPECT_TRUE(std::isnan(m.balanced_accuracy));
  EXPECT_DOUBLE_EQ(m.top1_precision, 0.0);
  std::vector<float> short_p{0.1f};
  EXPECT_THROW(ComputeGqcnnMetrics({labels, short_p, keys, keys}, 0.5), std::invalid_argument);
  const auto j = GqcnnMetricsJson(m, {});
  EXPECT_TRUE(j.at("recall").is_null());
  EXPECT_TRUE(j.at("accuracy_ci95").at(0).is_null());
}

TEST(GqcnnMetricsTest, BootstrapResamplesObjects) {
  // 40 objects, each either all right (10 grasps) or all wrong: accuracy's spread is the
  // spread of a mean of 40 Bernoulli(0.75) draws, sd 0.068: the 95 % interval about +-0.13.
  std::vector<std::uint8_t> labels;
  std::vector<float> p;
  std::vector<std::uint32_t> objects, images;
  for (std::uint32_t o = 0; o < 40; ++o) {
    const bool right = o % 4 != 0;
    for (int g = 0; g < 10; ++g) {
      const bool y = g % 2 == 0;
      labels.push_back(y);
      p.push_back((y == right) ? 0.9f : 0.1f);
      objects.push_back(o);
      images.push_back(o * 2 + static_cast<std::uint32_t>(g % 2));
    }
  }
  std::vector<GqcnnObjectCounts> per_object;
  const GqcnnMetrics m = ComputeGqcnnMetrics({labels, p, objects, images}, 0.5, &per_object);
  EXPECT_DOUBLE_EQ(m.accuracy, 0.75);
  const GqcnnIntervals ci = BootstrapGqcnnMetrics(per_object, 2000, 5);
  EXPECT_LT(ci.accuracy.low, 0.75);
  EXPECT_GT(ci.accuracy.high, 0.75);
  EXPECT_NEAR(ci.accuracy.high - ci.accuracy.low, 0.26, 0.06);
  const GqcnnIntervals again = BootstrapGqcnnMetrics(per_object, 2000, 5);
  EXPECT_EQ(again.balanced_accuracy.low, ci.balanced_accuracy.low);
}

}  // namespace
}  // namespace softgrasp::tools
