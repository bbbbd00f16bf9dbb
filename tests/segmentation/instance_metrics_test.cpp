// COCO-style mask metrics on hand-made label images, every expectation computed by hand
// (docs/segmentation-metrics.md). Notation: t_k = 0.50, 0.55, ..., 0.95; r_j = j / 100 for
// j = 0..100; AP_t = (1/101) sum_j P_env(first rank with recall >= r_j), 0 where never reached.
#include "service/segmentation/instance_metrics.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace softgrasp::segmentation {
namespace {

cv::Mat1w Blank(int rows = 40, int cols = 60) { return cv::Mat1w(rows, cols, std::uint16_t{0}); }

void Fill(cv::Mat1w& labels, const cv::Rect& rect, int id) {
  labels(rect).setTo(static_cast<std::uint16_t>(id));
}

MaskScores Evaluate(const TruthImage& truth, const InstanceMasks& predicted) {
  MaskEvaluator evaluator;
  evaluator.Add(truth, predicted);
  return evaluator.Compute();
}

TEST(MaskEvaluator, PerfectPredictionScoresOne) {
  TruthImage truth{Blank(), {}, {}};
  Fill(truth.labels, {0, 0, 10, 10}, 3);  // truth ids need not be dense
  Fill(truth.labels, {20, 5, 8, 12}, 7);
  InstanceMasks predicted{Blank(), {0.9f, 0.4f}};
  Fill(predicted.labels, {20, 5, 8, 12}, 1);
  Fill(predicted.labels, {0, 0, 10, 10}, 2);
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_DOUBLE_EQ(s.ap, 1.0);
  EXPECT_DOUBLE_EQ(s.ap50, 1.0);
  EXPECT_DOUBLE_EQ(s.ap75, 1.0);
  EXPECT_DOUBLE_EQ(s.ar, 1.0);
  EXPECT_EQ(s.images, 1);
  EXPECT_EQ(s.truth_instances, 2);
  EXPECT_EQ(s.predicted_instances, 2);
}

// Truth 10 x 10 = 100 px, prediction its top 10 x 6 = 60 px: IoU = 60 / 100 = 0.6 exactly.
// IoU >= t holds for t = 0.50, 0.55 and 0.60 (the boundary counts; compared exactly), so the
// detection is a TP (precision 1 at recall 1: AP_t = 1) at 3 thresholds and a FP (AP_t = 0,
// recall 0) at the 7 others: AP = AR = 3 / 10 = 0.3, AP50 = 1, AP75 = 0.
TEST(MaskEvaluator, IouExactlySixTenthsPassesThreeThresholds) {
  TruthImage truth{Blank(), {}, {}};
  Fill(truth.labels, {0, 0, 10, 10}, 1);
  InstanceMasks predicted{Blank(), {0.8f}};
  Fill(predicted.labels, {0, 0, 10, 6}, 1);
  EXPECT_DOUBLE_EQ(MaskIou(truth.labels == 1, predicted.labels == 1), 0.6);
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_DOUBLE_EQ(s.ap50, 1.0);
  EXPECT_DOUBLE_EQ(s.ap75, 0.0);
  EXPECT_DOUBLE_EQ(s.ap, 0.3);
  EXPECT_DOUBLE_EQ(s.ar, 0.3);
}

// One truth; a FP (0.9) outranks the TP (0.8). Ranking FP, TP: precision 0, 1/2, recall 0, 1;
// envelope 1/2, 1/2; every r_j finds precision 1/2: AP = 0.5 at every threshold.
TEST(MaskEvaluator, FalsePositiveAboveTheTruePositive) {
  TruthImage truth{Blank(), {}, {}};
  Fill(truth.labels, {0, 0, 10, 10}, 1);
  InstanceMasks predicted{Blank(), {0.9f, 0.8f}};
  Fill(predicted.labels, {30, 20, 10, 10}, 1);
  Fill(predicted.labels, {0, 0, 10, 10}, 2);
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_DOUBLE_EQ(s.ap, 0.5);
  EXPECT_DOUBLE_EQ(s.ap50, 0.5);
  EXPECT_DOUBLE_EQ(s.ar, 1.0);
}

// Two truths A, B; ranking TP(A) 0.9, FP 0.8, TP(B) 0.7. recall 1/2, 1/2, 1; precision 1, 1/2,
// 2/3; envelope 1, 2/3, 2/3. r_0..r_50 (51 points) find rank 1 (precision 1), r_51..r_100
// (50 points) rank 3 (2/3): AP = (51 + 50 * 2/3) / 101 = 253 / 303.
TEST(MaskEvaluator, PrecisionEnvelopeOverAnInterleavedRanking) {
  TruthImage truth{Blank(), {}, {}};
  Fill(truth.labels, {0, 0, 10, 10}, 1);
  Fill(truth.labels, {15, 0, 10, 10}, 2);
  InstanceMasks predicted{Blank(), {0.9f, 0.8f, 0.7f}};
  Fill(predicted.labels, {0, 0, 10, 10}, 1);
  Fill(predicted.labels, {40, 20, 10, 10}, 2);
  Fill(predicted.labels, {15, 0, 10, 10}, 3);
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_NEAR(s.ap50, 253.0 / 303.0, 1e-12);
  EXPECT_NEAR(s.ap, 253.0 / 303.0, 1e-12);
  EXPECT_DOUBLE_EQ(s.ar, 1.0);
}

// The confident threshold: ranking TP 0.9, TP 0.8, FP 0.7, then nine TPs at 0.6 (ties: one cut
// after all of them). Precision at the cuts: 1 (0.9), 1 (0.8), 2/3 (0.7), 11/12 >= 0.9 (0.6):
// the lowest qualifying score is 0.6, with all 11 truths found (recall50 = 1). Without the nine,
// the cut at 0.7 (2/3) fails and 0.8 is the threshold, recall 2/2.
TEST(MaskEvaluator, ConfidentScoreIsTheLowestCutWithNinetyPercentPrecision) {
  TruthImage truth{Blank(), {}, {}};
  InstanceMasks predicted{Blank(), {0.9f, 0.8f, 0.7f}};
  Fill(truth.labels, {0, 0, 4, 4}, 1);
  Fill(truth.labels, {5, 0, 4, 4}, 2);
  Fill(predicted.labels, {0, 0, 4, 4}, 1);
  Fill(predicted.labels, {5, 0, 4, 4}, 2);
  Fill(predicted.labels, {50, 30, 4, 4}, 3);
  const MaskScores few = Evaluate(truth, predicted);
  EXPECT_FLOAT_EQ(static_cast<float>(few.confident_score), 0.8f);
  EXPECT_DOUBLE_EQ(few.confident_recall50, 1.0);
  for (int i = 0; i < 9; ++i) {
    Fill(truth.labels, {5 * i, 10, 4, 4}, 3 + i);
    Fill(predicted.labels, {5 * i, 10, 4, 4}, 4 + i);
    predicted.scores.push_back(0.6f);
  }
  const MaskScores many = Evaluate(truth, predicted);
  EXPECT_FLOAT_EQ(static_cast<float>(many.confident_score), 0.6f);
  EXPECT_DOUBLE_EQ(many.confident_recall50, 1.0);
  EXPECT_DOUBLE_EQ(Evaluate(truth, InstanceMasks{Blank(), {}}).confident_score, -1.0);
  InstanceMasks only_fp{Blank(), {0.5f}};
  Fill(only_fp.labels, {50, 30, 4, 4}, 1);
  EXPECT_DOUBLE_EQ(Evaluate(truth, only_fp).confident_score, -1.0);
}

// A (id 1) counts, B (id 2, 200 px) is ignored. Detections on B's left half (0.9) and right half
// (0.8) lie inside B (intersection / detection area = 1): neither TP nor FP. The TP on A (0.5)
// alone is ranked: AP = AR = 1, one truth instance. (Counted, B would make both FPs.)
TEST(MaskEvaluator, DetectionsOnAnIgnoredTruthAreNotFalsePositives) {
  TruthImage truth{Blank(), {2}, {}};
  Fill(truth.labels, {0, 0, 10, 10}, 1);
  Fill(truth.labels, {20, 0, 20, 10}, 2);
  InstanceMasks predicted{Blank(), {0.9f, 0.8f, 0.5f}};
  Fill(predicted.labels, {20, 0, 10, 10}, 1);
  Fill(predicted.labels, {30, 0, 10, 10}, 2);
  Fill(predicted.labels, {0, 0, 10, 10}, 3);
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_DOUBLE_EQ(s.ap, 1.0);
  EXPECT_DOUBLE_EQ(s.ar, 1.0);
  EXPECT_EQ(s.truth_instances, 1);
  EXPECT_EQ(s.predicted_instances, 3);
}

// The crowd rule: a detection (0.9) covering ignored B (100 px) plus 100 px of background has
// intersection / detection area = 100 / 200 = 0.5: ignored at t = 0.50, a FP above the TP on A
// (0.5) at the 9 other thresholds (AP_t = 0.5, as in FalsePositiveAboveTheTruePositive).
// AP = (1 + 9 * 0.5) / 10 = 0.55, AP50 = 1, AP75 = 0.5.
TEST(MaskEvaluator, IgnoredTruthAbsorbsDetectionsItCoversEnough) {
  TruthImage truth{Blank(), {2}, {}};
  Fill(truth.labels, {0, 0, 10, 10}, 1);
  Fill(truth.labels, {20, 0, 10, 10}, 2);
  InstanceMasks predicted{Blank(), {0.9f, 0.5f}};
  Fill(predicted.labels, {20, 0, 20, 10}, 1);
  Fill(predicted.labels, {0, 0, 10, 10}, 2);
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_DOUBLE_EQ(s.ap50, 1.0);
  EXPECT_DOUBLE_EQ(s.ap75, 0.5);
  EXPECT_DOUBLE_EQ(s.ap, 0.55);
  EXPECT_DOUBLE_EQ(s.ar, 1.0);
}

// Image 1: a TP (0.6). Image 2: its truth missed, a FP (0.9). Pooled ranking FP, TP over 2
// truths: precision 0, 1/2, recall 0, 1/2; envelope 1/2. r_0..r_50 find precision 1/2,
// r_51..r_100 are never reached: AP = 51 * 0.5 / 101 = 25.5 / 101; AR = 1/2. (The mean of the
// per-image APs would be (1 + 0) / 2 = 0.5: pooling is not averaging.)
TEST(MaskEvaluator, PoolsDetectionsAcrossImages) {
  MaskEvaluator evaluator;
  TruthImage truth1{Blank(), {}, {}};
  Fill(truth1.labels, {0, 0, 10, 10}, 1);
  InstanceMasks predicted1{Blank(), {0.6f}};
  Fill(predicted1.labels, {0, 0, 10, 10}, 1);
  evaluator.Add(truth1, predicted1);
  TruthImage truth2{Blank(), {}, {}};
  Fill(truth2.labels, {0, 0, 10, 10}, 1);
  InstanceMasks predicted2{Blank(), {0.9f}};
  Fill(predicted2.labels, {40, 20, 10, 10}, 1);
  evaluator.Add(truth2, predicted2);
  const MaskScores s = evaluator.Compute();
  EXPECT_EQ(s.images, 2);
  EXPECT_EQ(s.truth_instances, 2);
  EXPECT_NEAR(s.ap, 25.5 / 101.0, 1e-12);
  EXPECT_NEAR(s.ap50, 25.5 / 101.0, 1e-12);
  EXPECT_DOUBLE_EQ(s.ar, 0.5);
}

// Label images cannot overlap, so a duplicate is a split: A (10 x 20 = 200 px) predicted as its
// left half (0.9) and its right half (0.8), IoU 100 / 200 = 0.5 each; B (0.7) perfect.
// t = 0.50: the higher-scored half takes A, the lower-scored one finds A matched: TP, FP, TP,
// AP50 = 253 / 303 (as in PrecisionEnvelopeOverAnInterleavedRanking; had the lower-scored half
// matched, the ranking FP, TP, TP would give 2/3), recall 1.
// t >= 0.55: FP, FP, TP(B): precision 1/3 up to recall 1/2: AP_t = 51 / 3 / 101 = 17 / 101.
// AP = (253 / 303 + 9 * 17 / 101) / 10 = 712 / 3030; AR = (1 + 9 * 0.5) / 10 = 0.55.
TEST(MaskEvaluator, LowerScoredDuplicateIsAFalsePositive) {
  TruthImage truth{Blank(), {}, {}};
  Fill(truth.labels, {0, 0, 20, 10}, 1);
  Fill(truth.labels, {30, 0, 10, 10}, 2);
  InstanceMasks predicted{Blank(), {0.9f, 0.8f, 0.7f}};
  Fill(predicted.labels, {0, 0, 10, 10}, 1);
  Fill(predicted.labels, {10, 0, 10, 10}, 2);
  Fill(predicted.labels, {30, 0, 10, 10}, 3);
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_NEAR(s.ap50, 253.0 / 303.0, 1e-12);
  EXPECT_NEAR(s.ap75, 17.0 / 101.0, 1e-12);
  EXPECT_NEAR(s.ap, 712.0 / 3030.0, 1e-12);
  EXPECT_NEAR(s.ar, 0.55, 1e-12);
}

// cup 1: perfect. box 2: IoU 0.6 (TP at 3 of 10 thresholds). box 3: missed. box 4: ignored
// (not an instance). cup: recall50 = AR = best IoU = 1. box: 2 instances, recall50 = 1/2,
// AR = (3 * 1/2 + 7 * 0) / 10 = 0.15, mean best IoU = (0.6 + 0) / 2 = 0.3.
TEST(MaskEvaluator, PerCategoryRecall) {
  TruthImage truth{Blank(), {4}, {{1, "cup"}, {2, "box"}, {3, "box"}, {4, "box"}}};
  Fill(truth.labels, {0, 0, 10, 10}, 1);
  Fill(truth.labels, {15, 0, 10, 10}, 2);
  Fill(truth.labels, {30, 0, 10, 10}, 3);
  Fill(truth.labels, {45, 0, 10, 10}, 4);
  InstanceMasks predicted{Blank(), {0.9f, 0.8f}};
  Fill(predicted.labels, {0, 0, 10, 10}, 1);
  Fill(predicted.labels, {15, 0, 10, 6}, 2);
  const MaskScores s = Evaluate(truth, predicted);
  ASSERT_EQ(s.per_category.size(), 2u);
  const CategoryScores& cup = s.per_category.at("cup");
  EXPECT_EQ(cup.instances, 1);
  EXPECT_DOUBLE_EQ(cup.recall50, 1.0);
  EXPECT_DOUBLE_EQ(cup.ar, 1.0);
  EXPECT_DOUBLE_EQ(cup.mean_best_iou, 1.0);
  const CategoryScores& box = s.per_category.at("box");
  EXPECT_EQ(box.instances, 2);
  EXPECT_DOUBLE_EQ(box.recall50, 0.5);
  EXPECT_NEAR(box.ar, 0.15, 1e-12);
  EXPECT_NEAR(box.mean_best_iou, 0.3, 1e-12);
  EXPECT_EQ(s.truth_instances, 3);
}

// Only the 100 highest-scored detections of an image count: 100 single-pixel FPs (0.5) push the
// perfect detection (0.1) out, so nothing is found.
TEST(MaskEvaluator, AtMostOneHundredDetectionsPerImage) {
  TruthImage truth{Blank(20, 20), {}, {}};
  Fill(truth.labels, {0, 0, 2, 2}, 1);
  InstanceMasks predicted{Blank(20, 20), std::vector<float>(101, 0.5f)};
  for (int i = 0; i < 100; ++i)
    predicted.labels(5 + i / 20, i % 20) = static_cast<std::uint16_t>(i + 1);
  Fill(predicted.labels, {0, 0, 2, 2}, 101);
  predicted.scores[100] = 0.1f;
  const MaskScores s = Evaluate(truth, predicted);
  EXPECT_EQ(s.predicted_instances, 100);
  EXPECT_DOUBLE_EQ(s.ap, 0.0);
  EXPECT_DOUBLE_EQ(s.ar, 0.0);
  // With 0.9 it is ranked first among the 100 kept: AP = AR = 1.
  predicted.scores[100] = 0.9f;
  EXPECT_DOUBLE_EQ(Evaluate(truth, predicted).ar, 1.0);
  EXPECT_DOUBLE_EQ(Evaluate(truth, predicted).ap, 1.0);
}

TEST(MaskEvaluator, UndefinedWithoutTruthZeroWithoutDetections) {
  EXPECT_DOUBLE_EQ(MaskEvaluator().Compute().ap, -1.0);
  // Detections but no truth (or only ignored truth): AP and AR undefined, -1.
  TruthImage only_ignored{Blank(), {1}, {}};
  Fill(only_ignored.labels, {0, 0, 5, 5}, 1);
  InstanceMasks predicted{Blank(), {0.7f}};
  Fill(predicted.labels, {20, 20, 5, 5}, 1);
  const MaskScores undefined = Evaluate(only_ignored, predicted);
  EXPECT_DOUBLE_EQ(undefined.ap, -1.0);
  EXPECT_DOUBLE_EQ(undefined.ap50, -1.0);
  EXPECT_DOUBLE_EQ(undefined.ar, -1.0);
  EXPECT_EQ(undefined.predicted_instances, 1);
  // Truth but no detection (an empty label image is allowed then): 0.
  TruthImage truth{Blank(), {}, {}};
  Fill(truth.labels, {0, 0, 5, 5}, 1);
  const MaskScores none = Evaluate(truth, InstanceMasks{});
  EXPECT_DOUBLE_EQ(none.ap, 0.0);
  EXPECT_DOUBLE_EQ(none.ar, 0.0);
  EXPECT_EQ(none.truth_instances, 1);
}

TEST(MaskEvaluator, RejectsInconsistentInput) {
  MaskEvaluator evaluator;
  TruthImage truth{Blank(), {}, {}};
  EXPECT_THROW(evaluator.Add(truth, InstanceMasks{Blank(41, 60), {}}), std::invalid_argument);
  InstanceMasks too_few_scores{Blank(), {0.5f}};
  too_few_scores.labels(0, 0) = 2;
  EXPECT_THROW(evaluator.Add(truth, too_few_scores), std::invalid_argument);
  EXPECT_THROW(evaluator.Add(truth, InstanceMasks{cv::Mat1w(), {0.5f}}), std::invalid_argument);
  EXPECT_EQ(evaluator.Compute().images, 0);
}

TEST(MaskIou, CountsPixels) {
  cv::Mat1b a(4, 4, std::uint8_t{0}), b(4, 4, std::uint8_t{0});
  EXPECT_DOUBLE_EQ(MaskIou(a, b), 0.0);
  a(cv::Rect(0, 0, 2, 2)) = 1;    // 4 px
  b(cv::Rect(1, 0, 2, 2)) = 255;  // 4 px, 2 shared: IoU 2 / 6
  EXPECT_DOUBLE_EQ(MaskIou(a, b), 2.0 / 6.0);
  EXPECT_THROW(MaskIou(a, cv::Mat1b(3, 4)), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::segmentation
