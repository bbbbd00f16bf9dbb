#include "service/core/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace softgrasp::core {
namespace {

// A 0/1 checkerboard of 8x8 cells scaled into [lo, hi]: structure in every 10x10 region.
cv::Mat1f Pattern(int rows, int cols, float lo = 0.2f, float hi = 0.9f) {
  cv::Mat1f m(rows, cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) m(r, c) = ((r / 8 + c / 8) % 2) ? hi : lo;
  }
  return m;
}

TEST(StiffnessRmse255, IdenticalMapsHaveZeroError) {
  const cv::Mat1f a = Pattern(48, 64);
  EXPECT_DOUBLE_EQ(StiffnessRmse255(a, a).value(), 0.0);
}

TEST(StiffnessRmse255, ConstantOffsetIsTheOffsetOn255Scale) {
  const cv::Mat1f a = Pattern(48, 64);
  const cv::Mat1f b = a + 0.1f;
  EXPECT_NEAR(StiffnessRmse255(a, b).value(), 25.5, 1e-4);
}

TEST(StiffnessRmse255, GaussianNoiseGivesItsSigma) {
  const cv::Mat1f a(400, 400, 0.5f);
  cv::Mat1f b = a.clone();
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  for (auto it = b.begin(); it != b.end(); ++it) *it += noise(rng);
  // sigma 0.05 -> 12.75 on the 0-255 scale; 160k samples: relative error ~0.2 %.
  EXPECT_NEAR(StiffnessRmse255(a, b).value(), 12.75, 0.15);
}

TEST(StiffnessRmse255, RejectsMismatchedOrBadMaps) {
  const cv::Mat1f a(10, 10, 0.5f);
  const cv::Mat1f b(10, 11, 0.5f);
  auto r = StiffnessRmse255(a, b);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(r.error().field, "map");
  EXPECT_FALSE(StiffnessRmse255(cv::Mat1f(), cv::Mat1f()).ok());
  cv::Mat1f nan = a.clone();
  nan(3, 3) = std::nanf("");
  EXPECT_FALSE(StiffnessRmse255(a, nan).ok());
}

TEST(StiffnessMssim, IdenticalMapsScoreOne) {
  const cv::Mat1f a = Pattern(100, 130);
  EXPECT_NEAR(StiffnessMssim(a, a).value(), 1.0, 1e-12);
  const cv::Mat1f zero(50, 50, 0.0f);  // background only: C1, C2 make 0/0 regions score 1
  EXPECT_NEAR(StiffnessMssim(zero, zero).value(), 1.0, 1e-12);
}

TEST(StiffnessMssim, ConstantOffsetMatchesTheLuminanceTerm) {
  // Same structure shifted by d: contrast-structure term = 1, luminance term
  // (2 mx my + C1) / (mx^2 + my^2 + C1) per region; a constant map makes every region equal.
  const cv::Mat1f a(60, 60, 0.4f);
  const cv::Mat1f b(60, 60, 0.6f);
  const double mx = 0.4 * 255, my = 0.6 * 255, c1 = (0.01 * 255) * (0.01 * 255);
  const double expected = (2 * mx * my + c1) / (mx * mx + my * my + c1);
  EXPECT_NEAR(StiffnessMssim(a, b).value(), expected, 1e-6);  // 0.4f, 0.6f are floats
}

TEST(StiffnessMssim, NoiseLowersItAsTheFormulaSays) {
  // Constant truth t, prediction t + zero-mean noise sigma: per region mx ~ my, cov = 0, so
  // SSIM ~ C2 / (sigma^2 + C2) (with the sample variance of each region).
  const cv::Mat1f a(200, 200, 0.5f);
  cv::Mat1f b = a.clone();
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  for (auto it = b.begin(); it != b.end(); ++it) *it += noise(rng);
  const double sigma = 0.02 * 255, c2 = (0.03 * 255) * (0.03 * 255);
  const double expected = c2 / (sigma * sigma + c2);  // ~0.69
  EXPECT_NEAR(StiffnessMssim(a, b).value(), expected, 0.02);
  EXPECT_LT(StiffnessMssim(a, b).value(), 0.8);
}

TEST(StiffnessMssim, RegionsSplitSizesNotDivisibleByTen) {
  // 23 x 37: row borders at floor(i*23/10) = 0,2,4,6,9,11,13,16,18,20,23. Corrupting one region
  // alone changes exactly one of the 100 SSIMs.
  const cv::Mat1f a = Pattern(23, 37);
  cv::Mat1f b = a.clone();
  // Region (row 4, col 7): rows [9, 11), cols [25, 29).
  b(cv::Rect(25, 9, 4, 2)).setTo(0.0f);
  const double region = RegionSsim(a(cv::Rect(25, 9, 4, 2)), b(cv::Rect(25, 9, 4, 2)));
  EXPECT_LT(region, 0.5);
  EXPECT_NEAR(StiffnessMssim(a, b).value(), (99.0 + region) / 100.0, 1e-12);
  // One pixel outside that region changes a neighbouring region instead.
  cv::Mat1f c = a.clone();
  c(11, 25) = 0.0f;  // row 11 starts region row 5
  EXPECT_LT(StiffnessMssim(a, c).value(), 1.0);
  EXPECT_FALSE(StiffnessMssim(cv::Mat1f(9, 40, 0.f), cv::Mat1f(9, 40, 0.f)).ok());
}

TEST(MeanStiffnessInGraspRegion, AveragesObjectPixelsOnly) {
  // Left half of the region on an object of stiffness 0.8, right half background (0): the mean
  // counts only object pixels (eq. 3.13-3.14) -> 0.8; with a 0.4 strip -> a weighted mean.
  cv::Mat1f s(100, 100, 0.0f);
  s(cv::Rect(0, 0, 50, 100)).setTo(0.8f);
  Grasp g;
  g.center_u_px = 50;
  g.center_v_px = 50;
  g.angle_rad = 0;
  g.opening_px = 40;
  g.finger_width_px = 10;
  EXPECT_NEAR(MeanStiffnessInGraspRegion(s, g), 0.8, 1e-6);
  s(cv::Rect(30, 0, 10, 100)).setTo(0.4f);
  const cv::Mat1b mask = GraspRegionMask(s.size(), g);
  // Region: u in [30, 70] (41 columns), v in [45, 55] (11 rows).
  EXPECT_EQ(cv::countNonZero(mask), 41 * 11);
  const double expected = (10 * 0.4 + 10 * 0.8) / 20.0;  // columns 30-39 and 40-49
  EXPECT_NEAR(MeanStiffnessInGraspRegion(s, g), expected, 1e-6);
  g.center_u_px = 80;  // region u in [60, 100]: background only
  EXPECT_TRUE(std::isnan(MeanStiffnessInGraspRegion(s, g)));
}

TEST(GraspRegionMask, RotatedRegionHasTheRectangleArea) {
  Grasp g;
  g.center_u_px = 100;
  g.center_v_px = 100;
  g.angle_rad = 0.7;
  g.opening_px = 50;
  g.finger_width_px = 16;
  const int area = cv::countNonZero(GraspRegionMask(cv::Size(200, 200), g));
  EXPECT_NEAR(area, 50 * 16, 0.06 * 50 * 16);
  g.center_u_px = 0;  // clipped at the image border: about half remains
  EXPECT_NEAR(cv::countNonZero(GraspRegionMask(cv::Size(200, 200), g)), area / 2.0, 0.1 * area);
}

}  // namespace
}  // namespace softgrasp::core
