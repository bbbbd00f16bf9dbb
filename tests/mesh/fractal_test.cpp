// The fractal pipeline: parameter checks, seeded batches per alpha (every mesh checked),
// determinism (in-process and against golden bytes) and the reported fields.
#include "service/mesh/fractal.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "service/mesh/alpha_shape.h"
#include "service/mesh/mesh_check.h"
#include "service/mesh/mesh_io.h"
#include "tests/mesh/brute_force_intersections.h"

namespace softgrasp::mesh {
namespace {

std::uint64_t Fnv1a(const std::string& bytes) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const char c : bytes) h = (h ^ static_cast<unsigned char>(c)) * 0x100000001b3ull;
  return h;
}

// Golden values of GoldenBytesAcrossRuns (seed 2024, default parameters). Regenerated when
// merge_fraction (default 0.05) came in: the same draw is accepted, but the alpha shape is now
// built from the merged cloud, so the mesh has fewer faces (was 2798, hash 0x22d3fec25c87acb6).
constexpr int kGoldenAttempts = 11;
constexpr std::size_t kGoldenFaces = 2552;
constexpr std::uint64_t kGoldenHash = 0x3db611749a7adcfa;

std::string FirstProblem(const MeshReport& r) { return r.problems.empty() ? "" : r.problems[0]; }

/// Everything docs/fractals.md promises about one generated model.
void ExpectValidModel(const FractalModel& m, const FractalParams& p) {
  const MeshReport r = CheckMesh(m.mesh);
  ASSERT_TRUE(r.ok()) << "seed " << p.seed << ": " << FirstProblem(r);
  EXPECT_TRUE(r.closed && r.edge_manifold && r.vertex_manifold && r.connected &&
              r.consistently_oriented && r.outward);
  EXPECT_TRUE(r.self_intersections_checked && r.self_intersection_free);
  EXPECT_EQ(r.num_components, 1);
  EXPECT_GT(m.volume_m3, 0.0);
  EXPECT_DOUBLE_EQ(m.volume_m3, r.volume);

  // Bounding box: centred, smallest side = fit_fraction * opening (from below, within 2 ppm).
  std::array<double, 3> lo = m.mesh.vertices[0], hi = m.mesh.vertices[0];
  for (const auto& v : m.mesh.vertices) {
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], v[k]);
      hi[k] = std::max(hi[k], v[k]);
      ASSERT_EQ(v[k], static_cast<double>(static_cast<float>(v[k])));  // float32-exact
    }
  }
  EXPECT_EQ(lo, m.bbox_min_m);
  EXPECT_EQ(hi, m.bbox_max_m);
  const double target = p.fit_fraction * p.gripper_opening_m;
  const double smallest = std::min({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  EXPECT_LE(smallest, target);
  EXPECT_GE(smallest, target * (1 - 2e-6));
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(lo[k] + hi[k], 0.0, 1e-7);

  EXPECT_EQ(m.alpha_requested, p.alpha);
  EXPECT_DOUBLE_EQ(m.alpha_used, p.alpha * std::pow(1.5, m.alpha_raises));
  EXPECT_EQ(m.alpha_raised, m.alpha_raises > 0);
  EXPECT_GE(m.pieces_dropped, 0);
  EXPECT_GE(m.dropped_volume_fraction, 0.0);
  EXPECT_LE(m.dropped_volume_fraction, 1.0 - p.min_piece_volume_fraction);
  const FractalRejections& j = m.rejections;
  EXPECT_EQ(m.attempts, 1 + j.expanding + j.diverged + j.low_variance + j.no_solid +
                            j.float_collision + j.self_intersecting);
  EXPECT_GT(std::min({m.variances[0], m.variances[1], m.variances[2]}), p.sigma);
  EXPECT_EQ(m.num_points, p.num_points);
  EXPECT_EQ(m.merge_cell, std::min(p.merge_fraction * p.alpha, 0.05));
  EXPECT_LE(m.points_triangulated, m.num_points);
  EXPECT_GE(static_cast<std::size_t>(m.points_triangulated), m.mesh.vertices.size());
  if (p.merge_fraction == 0.0) {
    EXPECT_EQ(m.points_triangulated, m.num_points);
  }
  EXPECT_GE(static_cast<int>(m.ifs.maps.size()), p.min_maps);
  EXPECT_LE(static_cast<int>(m.ifs.maps.size()), p.max_maps);
  EXPECT_GT(m.scale_m_per_unit, 0.0);
}

struct BatchSummary {
  double mean_unit_volume = 0.0;  ///< volume in normalised-cloud units (scale removed)
  int raised = 0;
  int with_dropped_pieces = 0;
};

BatchSummary RunBatch(double alpha, int count, int num_points) {
  BatchSummary s;
  for (int i = 0; i < count; ++i) {
    FractalParams p;
    p.seed = 1000 + static_cast<std::uint64_t>(i);
    p.alpha = alpha;
    p.num_points = num_points;
    const auto model = GenerateFractal(p);
    EXPECT_TRUE(model.ok()) << "seed " << p.seed << ": " << model.error().message;
    if (!model.ok()) continue;
    ExpectValidModel(model.value(), p);
    const FractalModel& m = model.value();
    s.mean_unit_volume += m.volume_m3 / std::pow(m.scale_m_per_unit, 3) / count;
    s.raised += m.alpha_raised ? 1 : 0;
    s.with_dropped_pieces += m.pieces_dropped > 0 ? 1 : 0;
  }
  return s;
}

// A seeded batch of 50 per thesis alpha (2,000 points each, to stay fast); the alpha values give
// different levels of detail: the solid grows with alpha.
TEST(FractalTest, BatchesOfFiftyPerAlphaAreAllValid) {
  const BatchSummary fine = RunBatch(0.06, 50, 2000);
  const BatchSummary medium = RunBatch(0.3, 50, 2000);
  const BatchSummary coarse = RunBatch(0.7, 50, 2000);
  for (const auto& [alpha, s] : {std::pair{0.06, fine}, {0.3, medium}, {0.7, coarse}}) {
    std::printf(
        "alpha %.2f: mean volume %.3f (normalised units), alpha raised in %d/50, "
        "pieces dropped in %d/50\n",
        alpha, s.mean_unit_volume, s.raised, s.with_dropped_pieces);
  }
  EXPECT_LT(fine.mean_unit_volume, medium.mean_unit_volume);
  EXPECT_LT(medium.mean_unit_volume, coarse.mean_unit_volume);
  EXPECT_GE(fine.raised, coarse.raised);
  EXPECT_LT(coarse.raised, 10);  // alpha 0.7 is nearly convex: rarely needs raising
}

TEST(FractalTest, FullSizeCloudsAreValid) {
  for (const double alpha : {0.06, 0.3, 0.7}) {
    for (std::uint64_t seed : {7u, 8u}) {
      FractalParams p;
      p.seed = seed;
      p.alpha = alpha;
      const auto model = GenerateFractal(p);
      ASSERT_TRUE(model.ok()) << model.error().message;
      ExpectValidModel(model.value(), p);
    }
  }
}

/// The normalised chaos-game cloud of an accepted model, replayed from (seed, attempts).
std::vector<Point3> ReplayCloud(const FractalParams& p, int attempts) {
  std::mt19937_64 rng(DrawSeed(p.seed, attempts));
  const Ifs ifs = DrawIfs(rng, p.min_maps, p.max_maps);
  ChaosGame game;
  std::vector<Point3> points;
  RunChaosGame(ifs, rng, p.burn_in, p.num_points, 1e6, game, points);
  Normalize(points, ComputeNormalization(points));
  return points;
}

// Merging (merge_fraction) thins the triangulated cloud to the grid cells it occupies, and the
// solid stays close to the one built from every point.
TEST(FractalTest, MergingThinsTheCloudAndKeepsTheShape) {
  int compared = 0;
  for (const std::uint64_t seed : {7u, 8u, 9u}) {
    FractalParams p;
    p.seed = seed;
    FractalParams full = p;
    full.merge_fraction = 0.0;
    const auto merged_model = GenerateFractal(p);
    const auto full_model = GenerateFractal(full);
    ASSERT_TRUE(merged_model.ok() && full_model.ok()) << seed;
    const FractalModel& m = merged_model.value();
    const FractalModel& f = full_model.value();
    ExpectValidModel(m, p);
    ExpectValidModel(f, full);
    // The count is that of the grid merge of the accepted cloud, recomputed here.
    const std::vector<Point3> cloud = ReplayCloud(p, m.attempts);
    EXPECT_EQ(static_cast<std::size_t>(m.points_triangulated),
              MergeGridNeighbours(cloud, m.merge_cell).size());
    EXPECT_LT(m.points_triangulated, m.num_points * 9 / 10) << "clouds are clustered";
    EXPECT_LT(m.mesh.faces.size(), f.mesh.faces.size());
    if (m.attempts != f.attempts || m.alpha_raises != f.alpha_raises) continue;
    // Same cloud and alpha: the solids agree within a few percent (volume in normalised units).
    const double merged_volume = m.volume_m3 / std::pow(m.scale_m_per_unit, 3);
    const double full_volume = f.volume_m3 / std::pow(f.scale_m_per_unit, 3);
    EXPECT_NEAR(merged_volume / full_volume, 1.0, 0.05) << seed;
    ++compared;
  }
  EXPECT_GE(compared, 2);
}

// The models of `softgrasp-sim fractals --count 50 --seed 11` (seeds 11..60, default parameters:
// alpha 0.3, 10,000 points) are free of self-intersections (ExpectValidModel). Seeds 11, 12 and 32
// are the ones a tolerance-based triangle test (Open3D's) flags, with 5, 10 and 2 pairs of nearly
// coplanar faces 33-474 um apart; the brute-force count agrees with CheckMesh that none cross.
TEST(FractalTest, SimBatchSeedsDoNotSelfIntersect) {
  int rejected = 0;
  for (std::uint64_t seed = 11; seed < 61; ++seed) {
    FractalParams p;
    p.seed = seed;
    const auto model = GenerateFractal(p);
    ASSERT_TRUE(model.ok()) << seed << ": " << model.error().message;
    ExpectValidModel(model.value(), p);
    rejected += model.value().rejections.self_intersecting;
    if (seed == 11 || seed == 12 || seed == 32) {
      const auto brute = testing::BruteForceSelfIntersections(model.value().mesh);
      EXPECT_TRUE(brute.pairs.empty()) << seed;
      EXPECT_TRUE(brute.collinear_faces.empty()) << seed;
    }
  }
  std::printf("seeds 11-60: %d draws rejected for self-intersection\n", rejected);
}

// Rounding to float32 can fold a thin part of the solid through another. At a normal size that
// has not been seen (1,000 models at alpha 0.3); at an absurdly small gripper (1e-42 m: the model
// spans ~570 subnormal float32 steps) it is common, so the redraw can be shown: draw 5 of seed 16
// is a valid solid before rounding and has 5 crossing face pairs after it, so it is rejected.
TEST(FractalTest, RoundingThatFoldsTheSurfaceIsRedrawn) {
  FractalParams p;
  p.seed = 16;
  p.num_points = 2000;
  p.gripper_opening_m = 1e-42;
  const double target_m = p.fit_fraction * p.gripper_opening_m;
  const auto model = GenerateFractal(p);
  ASSERT_TRUE(model.ok()) << model.error().message;
  const MeshReport r = CheckMesh(model.value().mesh);
  EXPECT_TRUE(r.ok()) << (r.problems.empty() ? "" : r.problems.front());
  EXPECT_TRUE(r.self_intersections_checked && r.self_intersection_free);
  EXPECT_EQ(model.value().rejections.self_intersecting, 1);
  EXPECT_GT(model.value().attempts, 5);

  // It is draw 5: the first 5 draws end with one self-intersecting rejection, the first 4 with
  // none.
  p.max_attempts = 4;
  const auto four = GenerateFractal(p);
  ASSERT_FALSE(four.ok());
  EXPECT_NE(four.error().message.find(" 0 self-intersecting"), std::string::npos)
      << four.error().message;
  p.max_attempts = 5;
  const auto five = GenerateFractal(p);
  ASSERT_FALSE(five.ok());
  EXPECT_NE(five.error().message.find(" 1 self-intersecting"), std::string::npos)
      << five.error().message;

  // Replayed: valid before rounding, crossing after (same count by brute force).
  p.max_attempts = FractalParams{}.max_attempts;
  const std::vector<Point3> cloud = ReplayCloud(p, 5);
  AlphaShapeOptions options;
  options.alpha = p.alpha;
  auto shape =
      ReconstructAlphaShape(MergeGridNeighbours(cloud, p.merge_fraction * p.alpha), options);
  ASSERT_TRUE(shape.ok()) << shape.error().message;
  TriangleMesh mesh = shape.value().mesh;
  const MeshReport before = CheckMesh(mesh);
  EXPECT_TRUE(before.ok()) << (before.problems.empty() ? "" : before.problems.front());
  EXPECT_TRUE(before.self_intersection_free);
  ASSERT_GT(ScaleToGripper(mesh, target_m), 0.0);  // no vertices collide
  const MeshReport after = CheckMesh(mesh);
  EXPECT_TRUE(after.closed && after.edge_manifold && after.vertex_manifold && after.connected &&
              after.consistently_oriented);
  EXPECT_TRUE(after.self_intersections_checked);
  EXPECT_FALSE(after.self_intersection_free);
  EXPECT_EQ(after.num_self_intersecting_pairs, 5);
  EXPECT_EQ(after.self_intersecting_pairs, testing::BruteForceSelfIntersections(mesh).pairs);
}

TEST(FractalTest, SameSeedSameBytes) {
  FractalParams p;
  p.seed = 99;
  p.num_points = 3000;
  const auto a = GenerateFractal(p);
  const auto b = GenerateFractal(p);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a.value().mesh, b.value().mesh);
  EXPECT_EQ(a.value().attempts, b.value().attempts);
  for (const MeshFormat f : {MeshFormat::kObj, MeshFormat::kPlyAscii, MeshFormat::kPlyBinary,
                             MeshFormat::kStlAscii, MeshFormat::kStlBinary}) {
    EXPECT_EQ(WriteMesh(a.value().mesh, f), WriteMesh(b.value().mesh, f)) << MeshFormatName(f);
  }
  p.seed = 100;
  const auto c = GenerateFractal(p);
  ASSERT_TRUE(c.ok());
  EXPECT_NE(a.value().mesh, c.value().mesh);
}

// Determinism across runs and builds: these bytes were produced by an earlier run. If the
// algorithm changes on purpose, regenerate with the values printed on failure.
TEST(FractalTest, GoldenBytesAcrossRuns) {
  FractalParams p;
  p.seed = 2024;
  const auto model = GenerateFractal(p);
  ASSERT_TRUE(model.ok());
  const std::string ply = WritePly(model.value().mesh, Encoding::kBinary);
  EXPECT_EQ(model.value().attempts, kGoldenAttempts);
  EXPECT_EQ(model.value().mesh.faces.size(), kGoldenFaces);
  EXPECT_EQ(Fnv1a(ply), kGoldenHash) << std::hex << "0x" << Fnv1a(ply);
}

TEST(FractalTest, DrawsAreSeededIndependently) {
  EXPECT_NE(DrawSeed(1, 1), DrawSeed(1, 2));
  EXPECT_NE(DrawSeed(1, 1), DrawSeed(2, 1));
  EXPECT_EQ(DrawSeed(5, 3), DrawSeed(5, 3));
  // The accepted draw replays on its own from DrawSeed(seed, attempts).
  FractalParams p;
  p.seed = 31;
  p.num_points = 1000;
  const auto model = GenerateFractal(p);
  ASSERT_TRUE(model.ok());
  std::mt19937_64 rng(DrawSeed(p.seed, model.value().attempts));
  const Ifs ifs = DrawIfs(rng, p.min_maps, p.max_maps);
  ASSERT_EQ(ifs.maps.size(), model.value().ifs.maps.size());
  EXPECT_EQ(ifs.maps[0].a, model.value().ifs.maps[0].a);
}

TEST(FractalTest, GripperParametersScaleTheMesh) {
  FractalParams p;
  p.seed = 12;
  p.num_points = 1500;
  p.gripper_opening_m = 0.1;
  p.fit_fraction = 0.5;
  const auto model = GenerateFractal(p);
  ASSERT_TRUE(model.ok());
  ExpectValidModel(model.value(), p);
}

TEST(FractalTest, SigmaZeroAndMapRangesWork) {
  FractalParams p;
  p.seed = 3;
  p.num_points = 1000;
  p.sigma = 0.0;
  p.min_maps = p.max_maps = 4;
  const auto model = GenerateFractal(p);
  ASSERT_TRUE(model.ok()) << model.error().message;
  EXPECT_EQ(model.value().ifs.maps.size(), 4u);
  ExpectValidModel(model.value(), p);
}

TEST(FractalTest, GivesUpAfterMaxAttempts) {
  FractalParams p;
  p.seed = 1;
  p.sigma = 0.2;  // about 1 draw in 5,000 passes
  p.max_attempts = 3;
  const auto model = GenerateFractal(p);
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.error().code, core::ErrorCode::kUnprocessable);
  EXPECT_EQ(model.error().field, "max_attempts");
}

TEST(FractalTest, InvalidParametersNameTheField) {
  auto expect_invalid = [](FractalParams p, const std::string& field) {
    const auto model = GenerateFractal(p);
    ASSERT_FALSE(model.ok()) << field;
    EXPECT_EQ(model.error().code, core::ErrorCode::kInvalidArgument) << field;
    EXPECT_EQ(model.error().field, field);
    EXPECT_NE(model.error().message.find(field), std::string::npos) << model.error().message;
  };
  FractalParams p;
  p.sigma = 0.25;
  expect_invalid(p, "sigma");
  p = {};
  p.sigma = -0.01;
  expect_invalid(p, "sigma");
  p = {};
  p.sigma = std::nan("");
  expect_invalid(p, "sigma");
  p = {};
  p.alpha = 0.0;
  expect_invalid(p, "alpha");
  p = {};
  p.alpha = -0.3;
  expect_invalid(p, "alpha");
  p = {};
  p.alpha = INFINITY;
  expect_invalid(p, "alpha");
  p = {};
  p.num_points = 99;
  expect_invalid(p, "num_points");
  p = {};
  p.num_points = 50000000;
  expect_invalid(p, "num_points");
  p = {};
  p.min_maps = 5;
  p.max_maps = 3;
  expect_invalid(p, "min_maps");
  p = {};
  p.min_maps = 0;
  expect_invalid(p, "min_maps");
  p = {};
  p.max_maps = 33;
  expect_invalid(p, "max_maps");
  p = {};
  p.burn_in = -1;
  expect_invalid(p, "burn_in");
  p = {};
  p.gripper_opening_m = 0.0;
  expect_invalid(p, "gripper_opening_m");
  p = {};
  p.fit_fraction = 1.5;
  expect_invalid(p, "fit_fraction");
  p = {};
  p.max_attempts = 0;
  expect_invalid(p, "max_attempts");
  p = {};
  p.min_piece_volume_fraction = -0.5;
  expect_invalid(p, "min_piece_volume_fraction");
  p = {};
  p.max_alpha_raises = 100;
  expect_invalid(p, "max_alpha_raises");
  for (const double bad : {-0.01, 0.3, std::nan("")}) {
    p = {};
    p.merge_fraction = bad;
    expect_invalid(p, "merge_fraction");
  }
  EXPECT_FALSE(ValidateFractalParams(FractalParams{}).has_value());
}

}  // namespace
}  // namespace softgrasp::mesh
