// The catalogue's internal mesh builders on analytic shapes (sim/catalogue/builder.h).
#include "sim/catalogue/builder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "service/mesh/mesh_check.h"

namespace softgrasp::sim::catalogue_internal {
namespace {

TEST(Revolve, CylinderHasThePolygonPrismVolumeAndPoleStiffness) {
  const double r = 0.02, h = 0.05;
  const int n = 12;
  const StiffMesh cyl = Revolve({{0, 0, 0.8f}, {r, 0, 0.8f}, {r, h, 0.3f}, {0, h, 0.33f}}, n);
  const mesh::MeshReport report = mesh::CheckMesh(cyl.mesh_m);
  ASSERT_TRUE(report.ok()) << report.problems.front();
  EXPECT_EQ(cyl.mesh_m.vertices.size(), 2u + 2u * n);
  EXPECT_EQ(cyl.mesh_m.faces.size(), 4u * n);
  // A regular n-gon of circumradius r has area n/2 r^2 sin(2 pi / n).
  EXPECT_NEAR(report.volume, h * n / 2.0 * r * r * std::sin(2 * std::numbers::pi / n), 1e-15);
  EXPECT_FLOAT_EQ(cyl.vertex_stiffness.front(), 0.8f);
  EXPECT_FLOAT_EQ(cyl.vertex_stiffness.back(), 0.3f);  // quantised
}

TEST(Revolve, RejectsProfilesThatWouldNotMakeASolid) {
  // Not ending on the axis.
  EXPECT_THROW(Revolve({{0, 0, 1}, {0.01, 0, 1}, {0.01, 0.01, 1}}, 8), std::logic_error);
  // Clockwise (the solid on the right): the surface would face inward.
  EXPECT_THROW(Revolve({{0, 0.01, 1}, {0.01, 0.01, 1}, {0.01, 0, 1}, {0, 0, 1}}, 8),
               std::logic_error);
  // A bow tie: the profile crosses itself.
  EXPECT_THROW(
      Revolve({{0, 0, 1}, {0.02, 0.02, 1}, {0.02, 0, 1}, {0.01, 0.03, 1}, {0, 0.03, 1}}, 8),
      std::logic_error);
  EXPECT_THROW(Revolve({{0, 0, 1}, {0.01, 0, 1}, {0, 0.01, 1}}, 2), std::logic_error);
}

TEST(CellSolid, LShapeIsOneManifoldSolidWithTheSumOfItsBoxes) {
  const CellGrid grid{Subdivide({0.0, 0.03, 0.05}, 0.01),
                      Subdivide({-0.02, -0.01, 0.01, 0.02}, 0.01),
                      Subdivide({0.0, 0.01, 0.03}, 0.01)};
  // A 30 x 20 x 10 mm bar into a 20 x 40 x 30 mm block.
  const StiffMesh l = CellSolid(
      grid,
      [](const Eigen::Vector3d& c) {
        return (c.x() < 0.03 && std::abs(c.y()) < 0.01 && c.z() < 0.01) || c.x() > 0.03;
      },
      [](const Eigen::Vector3d& p) { return p.x() < 0.03 ? 0.9f : 0.21f; });
  const mesh::MeshReport report = mesh::CheckMesh(l.mesh_m);
  ASSERT_TRUE(report.ok()) << report.problems.front();
  EXPECT_EQ(report.euler_characteristic, 2);
  EXPECT_NEAR(report.volume, 0.03 * 0.02 * 0.01 + 0.02 * 0.04 * 0.03, 1e-15);
  for (std::size_t i = 0; i < l.mesh_m.vertices.size(); ++i) {
    EXPECT_FLOAT_EQ(l.vertex_stiffness[i], l.mesh_m.vertices[i][0] < 0.03 ? 0.9f : 0.2f);
  }
}

TEST(Subdivide, KeepsBreakpointsAndBoundsTheStep) {
  const std::vector<double> z = Subdivide({0.02, 0.0, 0.005, 0.02}, 0.006);
  ASSERT_EQ(z.size(), 5u);  // 0, 0.005 | 0.005 .. 0.02 in three 5 mm steps
  EXPECT_EQ(z.front(), 0.0);
  EXPECT_EQ(z[1], 0.005);
  EXPECT_EQ(z.back(), 0.02);
  EXPECT_THROW(Subdivide({0.0, 1.0}, 0.0), std::logic_error);
}

TEST(ShapeSampler, HeldOutBandsAreDisjointAndCoverTheRange) {
  EXPECT_EQ(HeldOutBand(0.0, 1.0, 0).first, 0.0);
  EXPECT_EQ(HeldOutBand(0.0, 1.0, kHeldOutBands - 1).second, 1.0);
  for (int b = 0; b + 1 < kHeldOutBands; ++b) {
    EXPECT_EQ(HeldOutBand(0.035, 0.07, b).second, HeldOutBand(0.035, 0.07, b + 1).first);
  }
  ShapeSampler a(42, ShapeSplit::kVal), b(42, ShapeSplit::kVal);
  EXPECT_EQ(a.Uniform("x_m", 1.0, 2.0), b.Uniform("x_m", 1.0, 2.0));
  EXPECT_EQ(a.shape().at("split"), "val");
}

}  // namespace
}  // namespace softgrasp::sim::catalogue_internal
