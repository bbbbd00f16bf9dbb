// tests/support/subdivided_mesh.h, which the mesh grasp benchmark sizes its meshes with: the
// Dex-Net bar clamp (a triangle soup in its OBJ file) welded and subdivided stays a closed,
// 2-manifold, outward mesh with the same volume, bounding box and the expected vertex, edge and
// face counts.
#include "tests/support/subdivided_mesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include "service/mesh/mesh_check.h"
#include "service/mesh/mesh_io.h"
#include "tests/support/test_data.h"

namespace softgrasp::testing {
namespace {

mesh::TriangleMesh BarClamp() {
  std::ifstream in(TestData("meshes/dexnet_bar_clamp.obj"), std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  auto mesh = mesh::ReadMesh(bytes.str());
  EXPECT_TRUE(mesh.ok());
  return mesh.ok() ? std::move(mesh).value() : mesh::TriangleMesh{};
}

std::size_t EdgeCount(const mesh::TriangleMesh& m) {
  std::set<std::pair<int, int>> edges;
  for (const auto& f : m.faces) {
    for (int k = 0; k < 3; ++k) {
      const int a = f[static_cast<std::size_t>(k)];
      const int b = f[static_cast<std::size_t>((k + 1) % 3)];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  }
  return edges.size();
}

std::array<double, 6> Bounds(const mesh::TriangleMesh& m) {
  std::array<double, 6> b{1e300, 1e300, 1e300, -1e300, -1e300, -1e300};
  for (const auto& v : m.vertices) {
    for (std::size_t i = 0; i < 3; ++i) {
      b[i] = std::min(b[i], v[i]);
      b[i + 3] = std::max(b[i + 3], v[i]);
    }
  }
  return b;
}

TEST(SubdividedMeshTest, TheBarClampStaysClosedWithTheSameVolume) {
  const mesh::TriangleMesh soup = BarClamp();
  ASSERT_EQ(soup.faces.size(), 476u);
  const mesh::TriangleMesh welded = WeldVertices(soup);
  mesh::MeshCheckOptions options;
  const mesh::MeshReport base = mesh::CheckMesh(welded, options);
  ASSERT_TRUE(base.ok());
  const std::size_t v = welded.vertices.size();
  const std::size_t e = EdgeCount(welded);
  const std::size_t f = welded.faces.size();
  EXPECT_EQ(SubdivideMesh(soup, 1), welded);
  for (const int n : {2, 5}) {
    const mesh::TriangleMesh fine = SubdivideMesh(soup, n);
    const auto un = static_cast<std::size_t>(n);
    EXPECT_EQ(fine.faces.size(), f * un * un);
    // Each edge gains n - 1 points, each face (n - 1)(n - 2) / 2 inside.
    EXPECT_EQ(fine.vertices.size(), v + e * (un - 1) + f * (un - 1) * (un - 2) / 2);
    EXPECT_EQ(EdgeCount(fine), e * un + f * 3 * un * (un - 1) / 2);
    const mesh::MeshReport report = mesh::CheckMesh(fine, options);
    EXPECT_TRUE(report.ok()) << n;
    EXPECT_NEAR(report.volume, base.volume, 1e-12 * base.volume) << n;
    const auto b0 = Bounds(welded);
    const auto b1 = Bounds(fine);
    for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(b1[i], b0[i], 1e-15) << n;  // rounding
  }
  EXPECT_EQ(SubdivideMesh(soup, 5).faces.size(), 11900u);
}

}  // namespace
}  // namespace softgrasp::testing
