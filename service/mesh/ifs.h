#pragma once
/// 3D iterated function systems (thesis §4.2.1): random affine maps, selection probabilities
/// proportional to |det A_i|, and the chaos game that turns a system into a point cloud.
/// Every random number comes from a caller-owned std::mt19937_64, converted to doubles here,
/// so results are identical on every platform with the same seed.

#include <array>
#include <cstdint>
#include <random>
#include <vector>

namespace softgrasp::mesh {

using Point3 = std::array<double, 3>;

/// w(x) = A x + b, with A row-major.
struct AffineMap {
  std::array<double, 9> a{};
  std::array<double, 3> b{};
};

/// An IFS: maps and their selection probabilities (same length, probabilities sum to 1).
struct Ifs {
  std::vector<AffineMap> maps;
  std::vector<double> probabilities;
};

/// A double in [0, 1) from the top 53 bits of one engine output.
inline double UnitDouble(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

/// Uniform integer in [lo, hi] from the engine, unbiased (rejection), deterministic.
/// @pre lo <= hi.  @throws std::invalid_argument otherwise.
int UniformInt(std::mt19937_64& rng, int lo, int hi);

/// Determinant of a map's linear part.
double Determinant(const AffineMap& map);

/// Largest singular value of a map's linear part (its Lipschitz constant).
double SpectralNorm(const AffineMap& map);

/// Draws N uniform in [min_maps, max_maps], then 12 parameters per map uniform in [-1, 1)
/// (a row-major, then b), and sets p_i = |det A_i| / sum_j |det A_j| (uniform if all are 0).
/// Consumes exactly 1 + 12 N engine outputs when min_maps < max_maps (12 N otherwise) plus
/// any rejected draws of N.
/// @pre 1 <= min_maps <= max_maps.  @throws std::invalid_argument otherwise.
Ifs DrawIfs(std::mt19937_64& rng, int min_maps, int max_maps);

/// Sum_i p_i log|det A_i|: the sum of the system's Lyapunov exponents. When it is >= 0 the largest
/// exponent is >= 0 too, so the chaos game cannot contract onto an attractor: such a system is
/// rejected without running it. (-inf if a selected map is singular.)
double MeanLogDeterminant(const Ifs& ifs);

/// Chaos game state: continue a run with RunChaosGame on the same state and engine.
struct ChaosGame {
  Point3 x{0.0, 0.0, 0.0};  ///< current point; starts at the origin
  bool diverged = false;    ///< some coordinate left [-divergence_bound, divergence_bound] or NaN
};

/// Iterates x <- w_i(x), i drawn with p_i (one engine output per step), `skip` times without
/// recording, then appends up to `count` points to `out`. Stops early, with state.diverged set,
/// as soon as a coordinate's magnitude reaches `divergence_bound` (or is NaN).
/// @pre ifs has maps; skip, count >= 0.  @throws std::invalid_argument otherwise.
void RunChaosGame(const Ifs& ifs, std::mt19937_64& rng, int skip, int count,
                  double divergence_bound, ChaosGame& state, std::vector<Point3>& out);

/// Where and how much a cloud was moved and scaled: normalised = (p - centre) * scale.
struct CloudNormalization {
  Point3 centre{};     ///< centre of the axis-aligned bounding box
  double scale = 1.0;  ///< 2 / (longest bounding-box side): the longest side spans [-1, 1]
};

/// Bounding-box normalisation used throughout the fractal pipeline (see docs/fractals.md):
/// centre at the box centre, longest side scaled to length 2. A cloud with no extent gets
/// scale 0 (callers reject it).
/// @pre points is not empty.  @throws std::invalid_argument otherwise.
CloudNormalization ComputeNormalization(const std::vector<Point3>& points);

/// Applies `n` in place.
void Normalize(std::vector<Point3>& points, const CloudNormalization& n);

/// Merges points that fall into the same cell of an axis-aligned grid with cell side `cell`
/// (cells [k * cell, (k + 1) * cell) per axis): keeps the first point of each cell, in input order,
/// so the result is a subsequence of `points` (exact copies) and every dropped point lies within
/// cell * sqrt(3) of a kept one. The chaos game puts most of its points in a few dense clusters,
/// and at the alpha-shape scale (cell << alpha) the extra points only cost triangulation time.
/// Returns the points unchanged when cell <= 0, or when the grid would need more than 2^21 cells
/// along an axis (cell too small to merge anything useful; keeps the keys in 64 bits).
/// @pre coordinates are finite.  @throws std::invalid_argument otherwise.
std::vector<Point3> MergeGridNeighbours(const std::vector<Point3>& points, double cell);

/// Per-axis population variance of `points` after normalisation `n` (thesis eq. 4.5 uses the
/// minimum of the three).
/// @pre points is not empty.  @throws std::invalid_argument otherwise.
std::array<double, 3> AxisVariances(const std::vector<Point3>& points, const CloudNormalization& n);

}  // namespace softgrasp::mesh
