// Random 3D-IFS and the chaos game. Plain loops over fixed-size arrays: the chaos game is the
// inner loop of every draw, rejected or not.
#include "service/mesh/ifs.h"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace softgrasp::mesh {

int UniformInt(std::mt19937_64& rng, int lo, int hi) {
  if (lo > hi) throw std::invalid_argument("UniformInt: lo > hi");
  const std::uint64_t span =
      static_cast<std::uint64_t>(static_cast<std::int64_t>(hi) - static_cast<std::int64_t>(lo)) + 1;
  // Largest multiple of span that fits in 2^64: draws at or above it are redrawn (no modulo bias).
  const std::uint64_t limit =
      std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % span;
  std::uint64_t x = rng();
  while (x >= limit) x = rng();
  return static_cast<int>(static_cast<std::int64_t>(lo) + static_cast<std::int64_t>(x % span));
}

double Determinant(const AffineMap& m) {
  const auto& a = m.a;
  return a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
         a[2] * (a[3] * a[7] - a[4] * a[6]);
}

double SpectralNorm(const AffineMap& m) {
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> a(m.a.data());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(a.transpose() * a, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, solver.eigenvalues()(2)));
}

Ifs DrawIfs(std::mt19937_64& rng, int min_maps, int max_maps) {
  if (min_maps < 1 || min_maps > max_maps) {
    throw std::invalid_argument("DrawIfs: need 1 <= min_maps <= max_maps, got " +
                                std::to_string(min_maps) + ".." + std::to_string(max_maps));
  }
  const int n = min_maps == max_maps ? min_maps : UniformInt(rng, min_maps, max_maps);
  Ifs ifs;
  ifs.maps.resize(static_cast<std::size_t>(n));
  for (AffineMap& m : ifs.maps) {
    for (double& v : m.a) v = 2.0 * UnitDouble(rng()) - 1.0;
    for (double& v : m.b) v = 2.0 * UnitDouble(rng()) - 1.0;
  }
  double total = 0.0;
  ifs.probabilities.resize(ifs.maps.size());
  for (std::size_t i = 0; i < ifs.maps.size(); ++i) {
    ifs.probabilities[i] = std::abs(Determinant(ifs.maps[i]));
    total += ifs.probabilities[i];
  }
  for (double& p : ifs.probabilities) p = total > 0.0 ? p / total : 1.0 / n;
  return ifs;
}

double MeanLogDeterminant(const Ifs& ifs) {
  double sum = 0.0;
  for (std::size_t i = 0; i < ifs.maps.size(); ++i) {
    if (ifs.probabilities[i] <= 0.0) continue;
    const double det = std::abs(Determinant(ifs.maps[i]));
    if (det == 0.0) return -std::numeric_limits<double>::infinity();
    sum += ifs.probabilities[i] * std::log(det);
  }
  return sum;
}

void RunChaosGame(const Ifs& ifs, std::mt19937_64& rng, int skip, int count,
                  double divergence_bound, ChaosGame& state, std::vector<Point3>& out) {
  if (ifs.maps.empty() || ifs.maps.size() != ifs.probabilities.size()) {
    throw std::invalid_argument("RunChaosGame: the IFS has no maps or mismatched probabilities");
  }
  if (skip < 0 || count < 0) throw std::invalid_argument("RunChaosGame: negative step count");
  if (state.diverged) return;
  // Cumulative thresholds on the 53-bit integer scale, so selection is one integer compare per map.
  constexpr std::size_t kMaxMaps = 64;
  if (ifs.maps.size() > kMaxMaps) throw std::invalid_argument("RunChaosGame: more than 64 maps");
  const std::size_t n = ifs.maps.size();
  std::array<std::uint64_t, kMaxMaps> threshold{};
  double cumulative = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    cumulative += ifs.probabilities[i];
    threshold[i] = static_cast<std::uint64_t>(std::min(cumulative, 1.0) * 0x1.0p53);
  }
  threshold[n - 1] = std::uint64_t{1} << 53;  // the last map takes any rounding remainder

  double x = state.x[0], y = state.x[1], z = state.x[2];
  const int total = skip + count;
  out.reserve(out.size() + static_cast<std::size_t>(count));
  for (int step = 0; step < total; ++step) {
    const std::uint64_t u = rng() >> 11;
    std::size_t i = 0;
    while (u >= threshold[i]) ++i;
    const auto& a = ifs.maps[i].a;
    const auto& b = ifs.maps[i].b;
    const double nx = a[0] * x + a[1] * y + a[2] * z + b[0];
    const double ny = a[3] * x + a[4] * y + a[5] * z + b[1];
    const double nz = a[6] * x + a[7] * y + a[8] * z + b[2];
    x = nx;
    y = ny;
    z = nz;
    // Written so that NaN fails the test too.
    if (!(std::abs(x) < divergence_bound && std::abs(y) < divergence_bound &&
          std::abs(z) < divergence_bound)) {
      state.diverged = true;
      break;
    }
    if (step >= skip) out.push_back({x, y, z});
  }
  state.x = {x, y, z};
}

CloudNormalization ComputeNormalization(const std::vector<Point3>& points) {
  if (points.empty()) throw std::invalid_argument("ComputeNormalization: empty cloud");
  Point3 lo = points.front(), hi = points.front();
  for (const Point3& p : points) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  CloudNormalization n;
  double longest = 0.0;
  for (int k = 0; k < 3; ++k) {
    n.centre[k] = 0.5 * (lo[k] + hi[k]);
    longest = std::max(longest, hi[k] - lo[k]);
  }
  n.scale = longest > 0.0 && std::isfinite(longest) ? 2.0 / longest : 0.0;
  return n;
}

void Normalize(std::vector<Point3>& points, const CloudNormalization& n) {
  for (Point3& p : points) {
    for (int k = 0; k < 3; ++k) p[k] = (p[k] - n.centre[k]) * n.scale;
  }
}

std::array<double, 3> AxisVariances(const std::vector<Point3>& points,
                                    const CloudNormalization& n) {
  if (points.empty()) throw std::invalid_argument("AxisVariances: empty cloud");
  const double count = static_cast<double>(points.size());
  std::array<double, 3> mean{}, var{};
  for (const Point3& p : points) {
    for (int k = 0; k < 3; ++k) mean[k] += (p[k] - n.centre[k]) * n.scale;
  }
  for (double& m : mean) m /= count;
  for (const Point3& p : points) {
    for (int k = 0; k < 3; ++k) {
      const double d = (p[k] - n.centre[k]) * n.scale - mean[k];
      var[k] += d * d;
    }
  }
  for (double& v : var) v /= count;
  return var;
}

std::vector<Point3> MergeGridNeighbours(const std::vector<Point3>& points, double cell) {
  if (!(cell > 0.0) || points.empty()) return points;
  Point3 lo = points.front(), hi = points.front();
  for (const Point3& p : points) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(p[k])) {
        throw std::invalid_argument("MergeGridNeighbours: non-finite coordinate");
      }
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  constexpr double kMaxCellsPerAxis = 0x1.0p21;
  std::array<double, 3> first_cell{};
  for (int k = 0; k < 3; ++k) {
    first_cell[k] = std::floor(lo[k] / cell);
    if (!(std::floor(hi[k] / cell) - first_cell[k] < kMaxCellsPerAxis)) return points;
  }
  // Open addressing on the packed cell key (21 bits per axis): one probe sequence per point,
  // first come first kept, so the result follows the input order.
  int bits = 4;
  while ((std::size_t{1} << bits) < 2 * points.size()) ++bits;
  const std::size_t capacity = std::size_t{1} << bits;
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::vector<std::uint64_t> table(capacity, kEmpty);
  std::vector<Point3> kept;
  kept.reserve(points.size());
  for (const Point3& p : points) {
    std::uint64_t key = 0;
    for (int k = 0; k < 3; ++k) {
      const auto index = static_cast<std::uint64_t>(std::floor(p[k] / cell) - first_cell[k]);
      key |= index << (21 * k);
    }
    auto slot = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - bits));
    while (table[slot] != kEmpty && table[slot] != key) slot = (slot + 1) & (capacity - 1);
    if (table[slot] == key) continue;
    table[slot] = key;
    kept.push_back(p);
  }
  return kept;
}

}  // namespace softgrasp::mesh
