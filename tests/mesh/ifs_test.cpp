// The IFS building blocks: random numbers, draws, the chaos game and the cloud statistics.
#include "service/mesh/ifs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <vector>

namespace softgrasp::mesh {
namespace {

TEST(IfsTest, UnitDoubleCoversZeroToOneExclusive) {
  EXPECT_EQ(UnitDouble(0), 0.0);
  EXPECT_EQ(UnitDouble(~std::uint64_t{0}), 1.0 - 0x1.0p-53);
  EXPECT_EQ(UnitDouble(std::uint64_t{1} << 63), 0.5);
}

TEST(IfsTest, UniformIntStaysInRangeAndHitsEveryValue) {
  std::mt19937_64 rng(7);
  std::map<int, int> seen;
  for (int i = 0; i < 6000; ++i) ++seen[UniformInt(rng, 2, 7)];
  ASSERT_EQ(seen.size(), 6u);
  EXPECT_EQ(seen.begin()->first, 2);
  EXPECT_EQ(seen.rbegin()->first, 7);
  for (const auto& [value, count] : seen) EXPECT_NEAR(count, 1000, 150) << value;
  EXPECT_THROW(UniformInt(rng, 3, 2), std::invalid_argument);
}

TEST(IfsTest, DrawIfsFollowsTheThesis) {
  std::mt19937_64 rng(42);
  for (int trial = 0; trial < 200; ++trial) {
    const Ifs ifs = DrawIfs(rng, 2, 7);
    ASSERT_GE(ifs.maps.size(), 2u);
    ASSERT_LE(ifs.maps.size(), 7u);
    ASSERT_EQ(ifs.probabilities.size(), ifs.maps.size());
    double total_det = 0.0, total_p = 0.0;
    for (const AffineMap& m : ifs.maps) {
      for (const double a : m.a) ASSERT_TRUE(a >= -1.0 && a < 1.0);
      for (const double b : m.b) ASSERT_TRUE(b >= -1.0 && b < 1.0);
      total_det += std::abs(Determinant(m));
    }
    for (std::size_t i = 0; i < ifs.maps.size(); ++i) {
      EXPECT_NEAR(ifs.probabilities[i], std::abs(Determinant(ifs.maps[i])) / total_det, 1e-15);
      total_p += ifs.probabilities[i];
    }
    EXPECT_NEAR(total_p, 1.0, 1e-12);
  }
}

TEST(IfsTest, DrawIfsIsDeterministicAndConsumesAFixedCount) {
  std::mt19937_64 a(5), b(5);
  const Ifs x = DrawIfs(a, 3, 3);
  const Ifs y = DrawIfs(b, 3, 3);
  ASSERT_EQ(x.maps.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(x.maps[i].a, y.maps[i].a);
    EXPECT_EQ(x.maps[i].b, y.maps[i].b);
  }
  std::mt19937_64 c(5);
  c.discard(36);  // a fixed N consumes exactly 12 N outputs
  EXPECT_EQ(a(), c());
  EXPECT_THROW(DrawIfs(a, 0, 3), std::invalid_argument);
  EXPECT_THROW(DrawIfs(a, 4, 3), std::invalid_argument);
}

TEST(IfsTest, DeterminantSpectralNormAndMeanLogDeterminant) {
  AffineMap m;
  m.a = {2, 0, 0, 0, 0.5, 0, 0, 0, 0.25};
  EXPECT_DOUBLE_EQ(Determinant(m), 0.25);
  EXPECT_NEAR(SpectralNorm(m), 2.0, 1e-12);
  AffineMap r;  // rotation by 90 degrees about z, scaled by 0.5
  r.a = {0, -0.5, 0, 0.5, 0, 0, 0, 0, 0.5};
  EXPECT_NEAR(SpectralNorm(r), 0.5, 1e-12);
  Ifs ifs{{m, r}, {0.5, 0.5}};
  EXPECT_NEAR(MeanLogDeterminant(ifs), 0.5 * std::log(0.25) + 0.5 * std::log(0.125), 1e-12);
}

/// The Sierpinski tetrahedron: x -> (x + corner) / 2 for the 4 corners of the unit simplex.
Ifs Sierpinski() {
  Ifs ifs;
  const double corners[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (const auto& c : corners) {
    AffineMap m;
    m.a = {0.5, 0, 0, 0, 0.5, 0, 0, 0, 0.5};
    m.b = {c[0] / 2, c[1] / 2, c[2] / 2};
    ifs.maps.push_back(m);
    ifs.probabilities.push_back(0.25);
  }
  return ifs;
}

TEST(IfsTest, ChaosGameStaysOnTheSierpinskiTetrahedron) {
  std::mt19937_64 rng(3);
  ChaosGame game;
  std::vector<Point3> points;
  RunChaosGame(Sierpinski(), rng, 50, 5000, 1e6, game, points);
  ASSERT_EQ(points.size(), 5000u);
  EXPECT_FALSE(game.diverged);
  for (const Point3& p : points) {
    ASSERT_GE(std::min({p[0], p[1], p[2]}), -1e-12);
    ASSERT_LE(p[0] + p[1] + p[2], 1.0 + 1e-12);
  }
  // It fills the simplex's corners: the bounding box is (almost) the unit cube's corner.
  const CloudNormalization n = ComputeNormalization(points);
  EXPECT_NEAR(n.scale, 2.0, 0.05);
  // Continuing the same state appends.
  RunChaosGame(Sierpinski(), rng, 0, 100, 1e6, game, points);
  EXPECT_EQ(points.size(), 5100u);
}

TEST(IfsTest, ChaosGameStopsWhenItDiverges) {
  Ifs ifs;
  AffineMap grow;
  grow.a = {3, 0, 0, 0, 3, 0, 0, 0, 3};
  grow.b = {1, 0, 0};
  ifs.maps = {grow};
  ifs.probabilities = {1.0};
  std::mt19937_64 rng(1);
  ChaosGame game;
  std::vector<Point3> points;
  RunChaosGame(ifs, rng, 0, 1000, 1e6, game, points);
  EXPECT_TRUE(game.diverged);
  EXPECT_LT(points.size(), 20u);  // 3^13 > 1e6: stopped long before 1000
  const std::size_t before = points.size();
  RunChaosGame(ifs, rng, 0, 10, 1e6, game, points);  // a diverged game stays stopped
  EXPECT_EQ(points.size(), before);
}

TEST(IfsTest, MergeGridNeighboursKeepsTheFirstPointPerCell) {
  // Cells of side 0.5 anchored at 0: [0, 0.5), [0.5, 1), [-0.5, 0), ...
  const std::vector<Point3> points = {{0.1, 0.1, 0.1},  {0.4, 0.2, 0.3},  {0.5, 0.1, 0.1},
                                      {-0.1, 0.1, 0.1}, {0.49, 0.0, 0.0}, {0.6, 0.3, 0.1},
                                      {0.1, 0.1, 0.1}};
  const std::vector<Point3> expected = {points[0], points[2], points[3]};
  EXPECT_EQ(MergeGridNeighbours(points, 0.5), expected);
  EXPECT_EQ(MergeGridNeighbours(points, 0.0), points);   // off
  EXPECT_EQ(MergeGridNeighbours(points, -1.0), points);  // off
  EXPECT_EQ(MergeGridNeighbours(points, 1e-9), points);  // > 2^21 cells per axis: unchanged
  EXPECT_TRUE(MergeGridNeighbours({}, 0.5).empty());
  EXPECT_THROW(MergeGridNeighbours({{0, 0, 0}, {NAN, 0, 0}}, 0.5), std::invalid_argument);
  EXPECT_THROW(MergeGridNeighbours({{0, 0, 0}, {0, INFINITY, 0}}, 0.5), std::invalid_argument);
}

TEST(IfsTest, MergeGridNeighboursMatchesAPlainCellMap) {
  std::mt19937_64 rng(11);
  ChaosGame game;
  std::vector<Point3> points;
  RunChaosGame(Sierpinski(), rng, 50, 20000, 1e6, game, points);
  Normalize(points, ComputeNormalization(points));
  for (const double cell : {0.003, 0.015, 0.035, 0.3}) {
    // Reference: a std::map from integer cell to the first point that landed there.
    std::map<std::array<long long, 3>, std::size_t> first;
    std::vector<Point3> expected;
    for (std::size_t i = 0; i < points.size(); ++i) {
      std::array<long long, 3> key{};
      for (std::size_t k = 0; k < 3; ++k) {
        key[k] = static_cast<long long>(std::floor(points[i][k] / cell));
      }
      if (first.emplace(key, i).second) expected.push_back(points[i]);
    }
    const std::vector<Point3> merged = MergeGridNeighbours(points, cell);
    EXPECT_EQ(merged, expected) << cell;
    // The Sierpinski tetrahedron has dimension 2: points per cell grow as the cell grows.
    EXPECT_LT(merged.size(), points.size()) << cell;
  }
}

TEST(IfsTest, NormalizationPutsTheLongestSideOnMinusOneToOne) {
  std::vector<Point3> points = {{1, 10, 100}, {3, 11, 100.5}, {2, 14, 100.25}};
  const CloudNormalization n = ComputeNormalization(points);
  EXPECT_DOUBLE_EQ(n.scale, 0.5);  // longest side: y, length 4
  EXPECT_EQ(n.centre, (Point3{2, 12, 100.25}));
  const auto var = AxisVariances(points, n);
  Normalize(points, n);
  EXPECT_DOUBLE_EQ(points[0][1], -1.0);
  EXPECT_DOUBLE_EQ(points[2][1], 1.0);
  // Variances of the normalised coordinates, computed by hand.
  auto variance = [&](int k) {
    double mean = 0, v = 0;
    for (const auto& p : points) mean += p[static_cast<std::size_t>(k)] / 3;
    for (const auto& p : points) {
      v += (p[static_cast<std::size_t>(k)] - mean) * (p[static_cast<std::size_t>(k)] - mean) / 3;
    }
    return v;
  };
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(var[static_cast<std::size_t>(k)], variance(k), 1e-15);
  EXPECT_EQ(ComputeNormalization({{1, 1, 1}, {1, 1, 1}}).scale, 0.0);
  EXPECT_THROW(ComputeNormalization({}), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::mesh
