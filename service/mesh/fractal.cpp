// The fractal pipeline: draws until one passes every check, then scales the mesh to the gripper.
#include "service/mesh/fractal.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "service/mesh/alpha_shape.h"
#include "service/mesh/mesh_check.h"

namespace softgrasp::mesh {
namespace {

constexpr double kDivergenceBound = 1e6;
/// Prefix sizes checked at sigma / 2 before the cloud is complete: 512, 1024, 2048, ...
constexpr int kFirstCheckpoint = 512;
constexpr double kPrefixSigmaFactor = 0.5;
/// Largest merge grid cell on the normalised cloud (longest side 2).
constexpr double kMaxMergeCell = 0.05;

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

core::Error Invalid(const std::string& field, const std::string& message) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, field + ": " + message, field);
}

/// Running bounding box and moments of a growing cloud, for the cheap prefix checks.
class PrefixStats {
 public:
  void Add(const std::vector<Point3>& points, std::size_t from) {
    for (std::size_t i = from; i < points.size(); ++i) {
      const Point3& p = points[i];
      for (std::size_t k = 0; k < 3; ++k) {
        lo_[k] = std::min(lo_[k], p[k]);
        hi_[k] = std::max(hi_[k], p[k]);
        sum_[k] += p[k];
        sum_sq_[k] += p[k] * p[k];
      }
    }
    n_ = static_cast<double>(points.size());
  }
  /// Min axis variance after the bounding-box normalisation (longest side -> 2).
  double MinNormalizedVariance() const {
    double longest = 0.0;
    for (std::size_t k = 0; k < 3; ++k) longest = std::max(longest, hi_[k] - lo_[k]);
    if (!(longest > 0.0) || n_ == 0.0) return 0.0;
    const double s = 2.0 / longest;
    double min_var = kInf;
    for (std::size_t k = 0; k < 3; ++k) {
      const double mean = sum_[k] / n_;
      min_var = std::min(min_var, std::max(0.0, sum_sq_[k] / n_ - mean * mean) * s * s);
    }
    return min_var;
  }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  Point3 lo_{kInf, kInf, kInf};
  Point3 hi_{-kInf, -kInf, -kInf};
  Point3 sum_{};
  Point3 sum_sq_{};
  double n_ = 0.0;
};

enum class CloudOutcome { kOk, kDiverged, kLowVariance };

/// Burn-in, then the cloud in doubling chunks with a prefix variance check after each.
CloudOutcome GrowCloud(const Ifs& ifs, std::mt19937_64& rng, const FractalParams& p,
                       std::vector<Point3>& points) {
  points.clear();
  ChaosGame game;
  RunChaosGame(ifs, rng, p.burn_in, 0, kDivergenceBound, game, points);
  if (game.diverged) return CloudOutcome::kDiverged;
  PrefixStats stats;
  const auto total = static_cast<std::size_t>(p.num_points);
  std::size_t target = std::min<std::size_t>(kFirstCheckpoint, total);
  while (true) {
    const std::size_t from = points.size();
    RunChaosGame(ifs, rng, 0, static_cast<int>(target - from), kDivergenceBound, game, points);
    if (game.diverged) return CloudOutcome::kDiverged;
    if (target == total) return CloudOutcome::kOk;
    stats.Add(points, from);
    if (stats.MinNormalizedVariance() <= kPrefixSigmaFactor * p.sigma) {
      return CloudOutcome::kLowVariance;
    }
    target = std::min(2 * target, total);
  }
}

}  // namespace

double ScaleToGripper(TriangleMesh& mesh, double target_m) {
  if (mesh.vertices.empty()) return 0.0;
  Point3 lo = mesh.vertices.front(), hi = mesh.vertices.front();
  for (const Point3& v : mesh.vertices) {
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], v[k]);
      hi[k] = std::max(hi[k], v[k]);
    }
  }
  const double smallest = std::min({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  if (!(smallest > 0.0)) return 0.0;
  // 1 ppm under the target, so float rounding can never push the side above it.
  const double scale = target_m / smallest * (1.0 - 1e-6);
  for (Point3& v : mesh.vertices) {
    for (std::size_t k = 0; k < 3; ++k) {
      v[k] = static_cast<double>(static_cast<float>((v[k] - 0.5 * (lo[k] + hi[k])) * scale));
    }
  }
  std::vector<Point3> sorted = mesh.vertices;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) return 0.0;
  return scale;
}

std::uint64_t DrawSeed(std::uint64_t seed, int attempt) {
  return SplitMix64(seed + static_cast<std::uint64_t>(attempt) * 0x9E3779B97F4A7C15ull);
}

std::optional<core::Error> ValidateFractalParams(const FractalParams& p) {
  auto int_range = [](const std::string& field, int v, int lo,
                      int hi) -> std::optional<core::Error> {
    if (v < lo || v > hi) {
      return Invalid(field, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                                "], got " + std::to_string(v));
    }
    return std::nullopt;
  };
  if (auto e = int_range("min_maps", p.min_maps, 1, 32)) return e;
  if (auto e = int_range("max_maps", p.max_maps, 1, 32)) return e;
  if (p.min_maps > p.max_maps) {
    return Invalid("min_maps", "must not exceed max_maps (" + std::to_string(p.min_maps) + " > " +
                                   std::to_string(p.max_maps) + ")");
  }
  if (auto e = int_range("num_points", p.num_points, 100, 1000000)) return e;
  if (auto e = int_range("burn_in", p.burn_in, 0, 1000000)) return e;
  if (!(p.sigma >= 0.0 && p.sigma <= 0.2)) {
    return Invalid("sigma", "must be in [0, 0.2], got " + std::to_string(p.sigma));
  }
  if (!(p.alpha > 0.0 && p.alpha <= 1000.0)) {
    return Invalid("alpha", "must be in (0, 1000], got " + std::to_string(p.alpha));
  }
  if (!(p.gripper_opening_m > 0.0 && p.gripper_opening_m <= 2.0)) {
    return Invalid("gripper_opening_m",
                   "must be in (0, 2] metres, got " + std::to_string(p.gripper_opening_m));
  }
  if (!(p.fit_fraction > 0.0 && p.fit_fraction <= 1.0)) {
    return Invalid("fit_fraction", "must be in (0, 1], got " + std::to_string(p.fit_fraction));
  }
  if (auto e = int_range("max_attempts", p.max_attempts, 1, 10000000)) return e;
  if (!(p.min_piece_volume_fraction >= 0.0 && p.min_piece_volume_fraction <= 1.0)) {
    return Invalid("min_piece_volume_fraction",
                   "must be in [0, 1], got " + std::to_string(p.min_piece_volume_fraction));
  }
  if (auto e = int_range("max_alpha_raises", p.max_alpha_raises, 0, 64)) return e;
  if (!(p.merge_fraction >= 0.0 && p.merge_fraction <= 0.25)) {
    return Invalid("merge_fraction",
                   "must be in [0, 0.25], got " + std::to_string(p.merge_fraction));
  }
  return std::nullopt;
}

core::Result<FractalModel> GenerateFractal(const FractalParams& params) {
  if (auto error = ValidateFractalParams(params)) return *error;

  AlphaShapeOptions shape_options;
  shape_options.alpha = params.alpha;
  shape_options.max_raises = params.max_alpha_raises;
  shape_options.min_piece_volume_fraction = params.min_piece_volume_fraction;
  const double target_m = params.fit_fraction * params.gripper_opening_m;
  // Capped so that a large alpha (a near-convex hull) still keeps the outline to ~1/40 of the box.
  const double merge_cell = std::min(params.merge_fraction * params.alpha, kMaxMergeCell);

  FractalRejections rejections;
  std::vector<Point3> points;
  points.reserve(static_cast<std::size_t>(params.num_points));
  for (int attempt = 1; attempt <= params.max_attempts; ++attempt) {
    std::mt19937_64 rng(DrawSeed(params.seed, attempt));
    Ifs ifs = DrawIfs(rng, params.min_maps, params.max_maps);
    if (!(MeanLogDeterminant(ifs) < 0.0)) {
      ++rejections.expanding;
      continue;
    }
    const CloudOutcome outcome = GrowCloud(ifs, rng, params, points);
    if (outcome == CloudOutcome::kDiverged) {
      ++rejections.diverged;
      continue;
    }
    if (outcome == CloudOutcome::kLowVariance) {
      ++rejections.low_variance;
      continue;
    }
    // Thesis eq. 4.5 on the normalised cloud, exact (two-pass) variances.
    const CloudNormalization normalization = ComputeNormalization(points);
    const std::array<double, 3> variances = normalization.scale > 0.0
                                                ? AxisVariances(points, normalization)
                                                : std::array<double, 3>{0.0, 0.0, 0.0};
    if (!(std::min({variances[0], variances[1], variances[2]}) > params.sigma)) {
      ++rejections.low_variance;
      continue;
    }
    Normalize(points, normalization);
    const std::vector<Point3> merged = MergeGridNeighbours(points, merge_cell);
    auto shape = ReconstructAlphaShape(merged, shape_options);
    if (!shape.ok()) {
      ++rejections.no_solid;
      continue;
    }
    AlphaShapeResult& s = shape.value();
    const double scale = ScaleToGripper(s.mesh, target_m);
    if (scale == 0.0) {
      ++rejections.float_collision;
      continue;
    }
    // The alpha shape's facets come from one Delaunay triangulation of the exact points, so they
    // cannot cross; the scaled, float32-rounded mesh (the one returned) can, where the solid is a
    // sliver a few rounding steps thick. The topology is unchanged, so anything else failing here
    // would be a collision the sort above missed; kept as a guard.
    const MeshReport report = CheckMesh(s.mesh);
    if (!report.ok()) {
      if (report.self_intersections_checked && !report.self_intersection_free) {
        ++rejections.self_intersecting;
      } else {
        ++rejections.float_collision;
      }
      continue;
    }

    FractalModel model;
    model.ifs = std::move(ifs);
    model.attempts = attempt;
    model.rejections = rejections;
    model.num_points = params.num_points;
    model.points_triangulated = static_cast<int>(merged.size());
    model.merge_cell = merge_cell;
    model.variances = variances;
    model.alpha_requested = s.alpha_requested;
    model.alpha_used = s.alpha_used;
    model.alpha_raises = s.raises;
    model.alpha_raised = s.raises > 0;
    model.pieces_dropped = s.pieces_dropped;
    model.dropped_volume_fraction = s.dropped_volume_fraction;
    model.cells_removed = s.cells_removed;
    model.cells_filled = s.cells_filled;
    model.scale_m_per_unit = scale;
    model.volume_m3 = report.volume;
    model.bbox_min_m = model.bbox_max_m = s.mesh.vertices.front();
    for (const Point3& v : s.mesh.vertices) {
      for (std::size_t k = 0; k < 3; ++k) {
        model.bbox_min_m[k] = std::min(model.bbox_min_m[k], v[k]);
        model.bbox_max_m[k] = std::max(model.bbox_max_m[k], v[k]);
      }
    }
    model.mesh = std::move(s.mesh);
    return model;
  }
  return core::MakeError(core::ErrorCode::kUnprocessable,
                         "no fractal passed the checks in " + std::to_string(params.max_attempts) +
                             " draws (" + std::to_string(rejections.expanding) + " expanding, " +
                             std::to_string(rejections.diverged) + " diverged, " +
                             std::to_string(rejections.low_variance) + " low variance, " +
                             std::to_string(rejections.no_solid) + " without a valid solid, " +
                             std::to_string(rejections.float_collision) + " float collisions, " +
                             std::to_string(rejections.self_intersecting) +
                             " self-intersecting); " + "raise max_attempts or lower sigma",
                         "max_attempts");
}

}  // namespace softgrasp::mesh
