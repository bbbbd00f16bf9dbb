// The percentile bootstrap behind evaluate's 95 % intervals: analytic cases (constant data, a
// fair coin whose interval half-width is known), determinism, missing values, bad arguments.
#include "tools/train/bootstrap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace softgrasp::tools {
namespace {

SceneStatistic MeanOf(const std::vector<double>& v) {
  return [&v](std::span<const int> sample) { return SampleMean(v, sample); };
}

TEST(SampleMean, CountsRepeatedScenesAndSkipsMissingOnes) {
  const std::vector<double> v = {1.0, 2.0, std::nan(""), 10.0};
  const std::vector<int> twice_first = {0, 0, 1};
  EXPECT_DOUBLE_EQ(SampleMean(v, twice_first), 4.0 / 3.0);
  const std::vector<int> with_missing = {2, 3, 2};
  EXPECT_DOUBLE_EQ(SampleMean(v, with_missing), 10.0);
  const std::vector<int> only_missing = {2, 2};
  EXPECT_TRUE(std::isnan(SampleMean(v, only_missing)));
}

TEST(BootstrapInterval, ConstantDataGiveAPointInterval) {
  const std::vector<double> v(50, 0.25);
  const Interval ci = BootstrapInterval(50, MeanOf(v), 500, 7);
  EXPECT_DOUBLE_EQ(ci.low, 0.25);
  EXPECT_DOUBLE_EQ(ci.high, 0.25);
}

TEST(BootstrapInterval, FairCoinMatchesTheNormalApproximation) {
  // 400 scenes, half succeeded: the mean's standard error is sqrt(0.25 / 400) = 0.025, so the
  // 95 % interval is about 0.5 -+ 1.96 * 0.025 = [0.451, 0.549].
  std::vector<double> v(400);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = i % 2 == 0 ? 1.0 : 0.0;
  const Interval ci = BootstrapInterval(400, MeanOf(v), 4000, 1);
  EXPECT_NEAR(ci.low, 0.451, 0.008);
  EXPECT_NEAR(ci.high, 0.549, 0.008);
}

TEST(BootstrapInterval, PairedRatioOfEqualPlannersIsExactlyOne) {
  // Two planners with the same per-scene figures: every resample gives a ratio of 1, however
  // spread the figures are.
  const std::vector<double> a = {0.01, 0.5, 0.02, 0.3, std::nan(""), 0.07};
  const std::vector<double> b = a;
  const Interval ci = BootstrapInterval(
      6, [&](std::span<const int> k) { return SampleMean(a, k) / SampleMean(b, k); }, 1000, 3);
  EXPECT_DOUBLE_EQ(ci.low, 1.0);
  EXPECT_DOUBLE_EQ(ci.high, 1.0);
}

TEST(BootstrapInterval, SameSeedSameIntervalOtherSeedOtherInterval) {
  std::vector<double> v;
  for (int i = 0; i < 60; ++i) v.push_back(std::fmod(i * 0.37, 1.0));
  const Interval a = BootstrapInterval(60, MeanOf(v), 500, 11);
  const Interval b = BootstrapInterval(60, MeanOf(v), 500, 11);
  const Interval c = BootstrapInterval(60, MeanOf(v), 500, 12);
  EXPECT_EQ(a.low, b.low);
  EXPECT_EQ(a.high, b.high);
  EXPECT_TRUE(a.low != c.low || a.high != c.high);
  EXPECT_LT(a.low, a.high);
}

TEST(BootstrapInterval, NoIntervalWhenMostResamplesHaveNoFigure) {
  const std::vector<double> none(20, std::nan(""));
  const Interval missing = BootstrapInterval(20, MeanOf(none), 1000, 5);
  EXPECT_TRUE(std::isnan(missing.low));
  EXPECT_TRUE(std::isnan(missing.high));
  // A statistic undefined in about 60 % of the resamples (first drawn scene < 12 of 20): no
  // interval; undefined in about 40 % (< 8): the defined ones make the interval.
  const auto undefined_below = [](int limit) {
    return [limit](std::span<const int> k) { return k[0] < limit ? std::nan("") : 1.0; };
  };
  EXPECT_TRUE(std::isnan(BootstrapInterval(20, undefined_below(12), 1000, 5).low));
  const Interval some = BootstrapInterval(20, undefined_below(8), 1000, 5);
  EXPECT_DOUBLE_EQ(some.low, 1.0);
  EXPECT_DOUBLE_EQ(some.high, 1.0);
}

TEST(BootstrapInterval, RefusesBadArguments) {
  const std::vector<double> v(5, 1.0);
  EXPECT_THROW(BootstrapInterval(0, MeanOf(v), 100, 1), std::invalid_argument);
  EXPECT_THROW(BootstrapInterval(5, MeanOf(v), 9, 1), std::invalid_argument);
  EXPECT_THROW(BootstrapInterval(5, MeanOf(v), 100, 1, 1.0), std::invalid_argument);
  EXPECT_THROW(BootstrapInterval(5, MeanOf(v), 100, 1, std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::tools
