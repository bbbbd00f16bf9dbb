// Alpha shapes: the raw solid against CGAL::Fixed_alpha_shape_3, and the repaired meshes on
// clouds with known shapes (ball, two balls, a hollow shell with a core, sparse points).
#include "service/mesh/alpha_shape.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Fixed_alpha_shape_3.h>
#include <CGAL/Fixed_alpha_shape_cell_base_3.h>
#include <CGAL/Fixed_alpha_shape_vertex_base_3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <stdexcept>

#include "service/mesh/ifs.h"
#include "service/mesh/mesh_check.h"

namespace softgrasp::mesh {
namespace {

constexpr double kPi = 3.14159265358979323846;

using Points = std::vector<std::array<double, 3>>;

/// n points uniform in the shell r_in <= |p - c| <= r_out, from a fixed seed.
Points Shell(int n, double r_in, double r_out, std::array<double, 3> c, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Points points;
  while (static_cast<int>(points.size()) < n) {
    std::array<double, 3> p{};
    for (double& x : p) x = 2.0 * UnitDouble(rng()) - 1.0;
    const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    if (r * r_out < r_in || r > 1.0) continue;
    points.push_back({c[0] + r_out * p[0], c[1] + r_out * p[1], c[2] + r_out * p[2]});
  }
  return points;
}

Points Ball(int n, double r, std::array<double, 3> c, std::uint64_t seed) {
  return Shell(n, 0.0, r, c, seed);
}

Points Join(Points a, const Points& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::string FirstProblem(const MeshReport& r) { return r.problems.empty() ? "" : r.problems[0]; }

TEST(AlphaShapeTest, RawSolidMatchesCgalFixedAlphaShape) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Tds = CGAL::Triangulation_data_structure_3<CGAL::Fixed_alpha_shape_vertex_base_3<K>,
                                                   CGAL::Fixed_alpha_shape_cell_base_3<K>>;
  using AlphaShape = CGAL::Fixed_alpha_shape_3<CGAL::Delaunay_triangulation_3<K, Tds>>;
  const Points points = Join(Ball(1500, 1.0, {0, 0, 0}, 1), Ball(300, 0.4, {1.6, 0, 0}, 2));
  for (const double alpha : {0.12, 0.3, 0.7}) {
    std::vector<K::Point_3> cgal_points;
    std::map<std::array<double, 3>, int> index;
    for (std::size_t i = 0; i < points.size(); ++i) {
      cgal_points.emplace_back(points[i][0], points[i][1], points[i][2]);
      index[points[i]] = static_cast<int>(i);
    }
    AlphaShape shape(cgal_points.begin(), cgal_points.end(), alpha * alpha);  // CGAL: squared
    std::vector<AlphaShape::Facet> regular;
    shape.get_alpha_shape_facets(std::back_inserter(regular), AlphaShape::REGULAR);
    std::set<std::array<int, 3>> expected;
    for (const auto& [cell, i] : regular) {
      std::array<int, 3> tri{};
      for (int j = 0; j < 3; ++j) {
        const auto& p = cell->vertex(shape.vertex_triple_index(i, j))->point();
        tri[static_cast<std::size_t>(j)] = index.at({p.x(), p.y(), p.z()});
      }
      std::sort(tri.begin(), tri.end());
      expected.insert(tri);
    }
    double interior_volume = 0.0;
    for (auto c = shape.finite_cells_begin(); c != shape.finite_cells_end(); ++c) {
      if (shape.classify(c) == AlphaShape::INTERIOR) {
        interior_volume +=
            CGAL::to_double(CGAL::volume(c->vertex(0)->point(), c->vertex(1)->point(),
                                         c->vertex(2)->point(), c->vertex(3)->point()));
      }
    }

    const auto raw = RawAlphaShapeFacets(points, alpha);
    ASSERT_TRUE(raw.ok());
    std::set<std::array<int, 3>> ours;
    for (auto tri : raw.value()) {
      std::sort(tri.begin(), tri.end());
      ours.insert(tri);
    }
    EXPECT_EQ(ours.size(), raw.value().size());
    EXPECT_EQ(ours, expected) << "alpha " << alpha;
    // Orientation: the boundary of a union of tetrahedra, oriented away from it, encloses
    // exactly their volume.
    const MeshReport report = CheckMesh(TriangleMesh{points, raw.value()});
    EXPECT_NEAR(report.volume, interior_volume, 1e-9 * interior_volume) << "alpha " << alpha;
    EXPECT_TRUE(report.closed);
  }
}

TEST(AlphaShapeTest, BallGivesOneClosedManifoldMesh) {
  const Points points = Ball(3000, 1.0, {0, 0, 0}, 11);
  const auto result = ReconstructAlphaShape(points, {.alpha = 1.0});
  ASSERT_TRUE(result.ok()) << result.error().message;
  const AlphaShapeResult& r = result.value();
  const MeshReport report = CheckMesh(r.mesh);
  EXPECT_TRUE(report.ok()) << FirstProblem(report);
  EXPECT_EQ(report.euler_characteristic, 2);
  EXPECT_GT(r.volume, 0.9 * 4.0 / 3.0 * kPi);
  EXPECT_LT(r.volume, 4.0 / 3.0 * kPi);
  EXPECT_DOUBLE_EQ(r.volume, report.volume);
  EXPECT_EQ(r.raises, 0);
  EXPECT_EQ(r.alpha_used, 1.0);
  // Every vertex is an exact input point.
  std::set<std::array<double, 3>> input(points.begin(), points.end());
  for (const auto& v : r.mesh.vertices) EXPECT_TRUE(input.count(v));
}

TEST(AlphaShapeTest, OutputIsCanonical) {
  const Points points = Ball(800, 1.0, {0, 0, 0}, 5);
  const auto a = ReconstructAlphaShape(points, {.alpha = 0.5});
  const auto b = ReconstructAlphaShape(points, {.alpha = 0.5});
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a.value().mesh, b.value().mesh);
  // Vertices are numbered in order of first appearance in the faces.
  int next = 0;
  for (const auto& f : a.value().mesh.faces) {
    for (const int i : f) {
      ASSERT_LE(i, next);
      if (i == next) ++next;
    }
  }
  EXPECT_EQ(next, static_cast<int>(a.value().mesh.vertices.size()));
}

TEST(AlphaShapeTest, KeepsTheLargestOfTwoBalls) {
  const Points points = Join(Ball(2000, 1.0, {0, 0, 0}, 21), Ball(400, 0.5, {4, 0, 0}, 22));
  const auto result = ReconstructAlphaShape(points, {.alpha = 0.5});
  ASSERT_TRUE(result.ok()) << result.error().message;
  const AlphaShapeResult& r = result.value();
  EXPECT_TRUE(CheckMesh(r.mesh).ok());
  EXPECT_GE(r.pieces_dropped, 1);
  EXPECT_EQ(r.raises, 0);
  EXPECT_NEAR(r.dropped_volume_fraction, 1.0 / 9.0, 0.03);      // radius 0.5 vs 1: volume 1 : 8
  for (const auto& v : r.mesh.vertices) EXPECT_LT(v[0], 1.01);  // the big ball only
}

TEST(AlphaShapeTest, RaisesAlphaWhenTheLargestPieceIsTooSmall) {
  // Two equal balls far apart: neither holds 90 % of the solid until alpha spans the gap.
  const Points points = Join(Ball(600, 1.0, {0, 0, 0}, 31), Ball(600, 1.0, {3, 0, 0}, 32));
  AlphaShapeOptions options;
  options.alpha = 0.5;
  options.min_piece_volume_fraction = 0.9;
  const auto result = ReconstructAlphaShape(points, options);
  ASSERT_TRUE(result.ok()) << result.error().message;
  const AlphaShapeResult& r = result.value();
  EXPECT_GT(r.raises, 0);
  EXPECT_DOUBLE_EQ(r.alpha_used, 0.5 * std::pow(1.5, r.raises));
  EXPECT_GT(r.alpha_used, 0.5);
  EXPECT_TRUE(CheckMesh(r.mesh).ok());
  // Both balls are in the one piece now.
  double min_x = 1e9, max_x = -1e9;
  for (const auto& v : r.mesh.vertices) {
    min_x = std::min(min_x, v[0]);
    max_x = std::max(max_x, v[0]);
  }
  EXPECT_LT(min_x, -0.9);
  EXPECT_GT(max_x, 3.9);
}

TEST(AlphaShapeTest, FillsTheCavityOfAHollowShell) {
  // A thick shell with a small core floating in its hollow: the shell is the largest piece, the
  // core is dropped, and the hollow is filled, so the mesh is one sphere-like surface.
  const Points points = Join(Shell(5000, 0.8, 1.0, {0, 0, 0}, 41), Ball(300, 0.25, {0, 0, 0}, 42));
  const auto result = ReconstructAlphaShape(points, {.alpha = 0.2});
  ASSERT_TRUE(result.ok()) << result.error().message;
  const AlphaShapeResult& r = result.value();
  const MeshReport report = CheckMesh(r.mesh);
  EXPECT_TRUE(report.ok()) << FirstProblem(report);
  EXPECT_EQ(report.num_components, 1);
  EXPECT_GE(r.pieces_dropped, 1);
  EXPECT_GT(r.cells_filled, 0);
  EXPECT_GT(r.volume, 0.85 * 4.0 / 3.0 * kPi);  // solid, not a shell (which would be ~2.1)
}

TEST(AlphaShapeTest, TouchingBallsGiveAValidMesh) {
  // Two balls touching at the origin: the alpha solid pinches there; the repair must settle.
  Points points = Join(Ball(1500, 0.5, {-0.5, 0, 0}, 51), Ball(1500, 0.5, {0.5, 0, 0}, 52));
  points.push_back({0, 0, 0});
  const auto result = ReconstructAlphaShape(points, {.alpha = 0.12});
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_TRUE(CheckMesh(result.value().mesh).ok());
}

TEST(AlphaShapeTest, RaisesAlphaForSparsePoints) {
  const Points points = Ball(60, 1.0, {0, 0, 0}, 61);
  const auto result = ReconstructAlphaShape(points, {.alpha = 0.01});
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_GT(result.value().raises, 5);  // 0.01 is far below the point spacing
  EXPECT_DOUBLE_EQ(result.value().alpha_used, 0.01 * std::pow(1.5, result.value().raises));
  EXPECT_TRUE(CheckMesh(result.value().mesh).ok());
}

TEST(AlphaShapeTest, UnusableInputIsAnError) {
  const auto few = ReconstructAlphaShape({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {});
  ASSERT_FALSE(few.ok());
  EXPECT_EQ(few.error().code, core::ErrorCode::kUnprocessable);
  EXPECT_EQ(few.error().field, "points");

  Points flat;
  for (int i = 0; i < 50; ++i) flat.push_back({i * 0.1, (i * 7 % 11) * 0.1, 0.0});
  const auto coplanar = ReconstructAlphaShape(flat, {});
  ASSERT_FALSE(coplanar.ok());
  EXPECT_EQ(coplanar.error().code, core::ErrorCode::kUnprocessable);

  Points nan = Ball(50, 1.0, {0, 0, 0}, 7);
  nan[10][1] = std::nan("");
  const auto with_nan = ReconstructAlphaShape(nan, {});
  ASSERT_FALSE(with_nan.ok());
  EXPECT_EQ(with_nan.error().code, core::ErrorCode::kUnprocessable);

  AlphaShapeOptions too_few_raises;
  too_few_raises.alpha = 1e-4;
  too_few_raises.max_raises = 2;
  const auto not_found = ReconstructAlphaShape(Ball(60, 1.0, {0, 0, 0}, 61), too_few_raises);
  ASSERT_FALSE(not_found.ok());
  EXPECT_EQ(not_found.error().code, core::ErrorCode::kUnprocessable);
}

TEST(AlphaShapeTest, BadOptionsThrow) {
  const Points points = Ball(50, 1.0, {0, 0, 0}, 7);
  EXPECT_THROW(ReconstructAlphaShape(points, {.alpha = 0.0}), std::invalid_argument);
  EXPECT_THROW(ReconstructAlphaShape(points, {.alpha = -1.0}), std::invalid_argument);
  EXPECT_THROW(ReconstructAlphaShape(points, {.alpha = 1.0, .raise_factor = 1.0}),
               std::invalid_argument);
  EXPECT_THROW(ReconstructAlphaShape(points, {.alpha = 1.0, .max_raises = -1}),
               std::invalid_argument);
  EXPECT_THROW(ReconstructAlphaShape(points, {.alpha = 1.0, .min_piece_volume_fraction = 1.5}),
               std::invalid_argument);
  EXPECT_THROW(RawAlphaShapeFacets(points, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::mesh
