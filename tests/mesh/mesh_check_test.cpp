// CheckMesh on meshes whose answers are known by construction.
#include "service/mesh/mesh_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>

#include "tests/mesh/mesh_test_util.h"

namespace softgrasp::mesh {
namespace {

using testing::MakeCube;
using testing::MakeTetrahedron;
using testing::MakeTorus;
using testing::Merge;

TEST(MeshCheckTest, CubePasses) {
  const MeshReport r = CheckMesh(MakeCube({0, 0, 0}, 2.0));
  EXPECT_TRUE(r.ok()) << (r.problems.empty() ? "" : r.problems.front());
  EXPECT_TRUE(r.indices_valid);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_TRUE(r.vertex_manifold);
  EXPECT_TRUE(r.connected);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_TRUE(r.outward);
  EXPECT_DOUBLE_EQ(r.volume, 8.0);
  EXPECT_EQ(r.num_components, 1);
  EXPECT_EQ(r.euler_characteristic, 2);
}

TEST(MeshCheckTest, TetrahedronAndTorusPass) {
  const MeshReport tet = CheckMesh(MakeTetrahedron());
  EXPECT_TRUE(tet.ok());
  EXPECT_NEAR(tet.volume, 1.0 / 6.0, 1e-15);
  const MeshReport torus = CheckMesh(MakeTorus());
  EXPECT_TRUE(torus.ok()) << (torus.problems.empty() ? "" : torus.problems.front());
  EXPECT_EQ(torus.euler_characteristic, 0);  // genus 1 is still a closed 2-manifold
  const double kPi = std::acos(-1.0);
  const double smooth = 2 * kPi * kPi * 2.0 * 0.25;  // 2 pi^2 R r^2; the polygon is smaller
  EXPECT_GT(torus.volume, 0.85 * smooth);
  EXPECT_LT(torus.volume, smooth);
}

TEST(MeshCheckTest, CubeWithAFaceRemovedIsNotClosed) {
  TriangleMesh m = MakeCube();
  m.faces.erase(m.faces.begin(), m.faces.begin() + 2);  // the bottom square
  const MeshReport r = CheckMesh(m);
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.closed);
  EXPECT_FALSE(r.edge_manifold);
  EXPECT_EQ(r.num_boundary_edges, 4);
  EXPECT_TRUE(r.connected);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_TRUE(r.vertex_manifold);
}

TEST(MeshCheckTest, TwoDisjointCubesAreNotConnected) {
  const MeshReport r = CheckMesh(Merge(MakeCube(), MakeCube({3, 0, 0})));
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.connected);
  EXPECT_EQ(r.num_components, 2);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_TRUE(r.vertex_manifold);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_DOUBLE_EQ(r.volume, 2.0);
}

TEST(MeshCheckTest, FlippedFaceIsInconsistentlyOriented) {
  TriangleMesh m = MakeCube();
  std::swap(m.faces[5][1], m.faces[5][2]);
  const MeshReport r = CheckMesh(m);
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.consistently_oriented);
  EXPECT_EQ(r.num_misoriented_edges, 3);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_TRUE(r.connected);
}

TEST(MeshCheckTest, AllFacesFlippedIsInward) {
  TriangleMesh m = MakeCube();
  for (auto& f : m.faces) std::swap(f[1], f[2]);
  const MeshReport r = CheckMesh(m);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_FALSE(r.outward);
  EXPECT_DOUBLE_EQ(r.volume, -1.0);
  EXPECT_FALSE(r.ok());
}

TEST(MeshCheckTest, CubesSharingAVertexAreNotVertexManifold) {
  // Second cube's corner 0 is the first cube's corner 7: one piece, pinched at a vertex.
  TriangleMesh m = Merge(MakeCube(), MakeCube({1, 1, 1}));
  for (auto& f : m.faces) {
    for (int& i : f) {
      if (i == 8) i = 7;
    }
  }
  const MeshReport r = CheckMesh(m);
  EXPECT_FALSE(r.vertex_manifold);
  EXPECT_EQ(r.num_nonmanifold_vertices, 1);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_TRUE(r.connected);
  EXPECT_EQ(r.num_unreferenced_vertices, 1);  // the old vertex 8
  EXPECT_FALSE(r.ok());
}

TEST(MeshCheckTest, CubesSharingAnEdgeAreNotEdgeManifold) {
  // Second cube at (1, 1, 0): shares the edge from corner 3 (1,1,0) to corner 7 (1,1,1).
  TriangleMesh m = Merge(MakeCube(), MakeCube({1, 1, 0}));
  for (auto& f : m.faces) {
    for (int& i : f) {
      if (i == 8) i = 3;
      if (i == 12) i = 7;
    }
  }
  const MeshReport r = CheckMesh(m);
  EXPECT_FALSE(r.edge_manifold);
  EXPECT_EQ(r.num_nonmanifold_edges, 1);
  EXPECT_TRUE(r.closed);  // four faces on that edge: even
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_FALSE(r.ok());
}

TEST(MeshCheckTest, BadIndicesAreReportedNotThrown) {
  TriangleMesh m = MakeCube();
  m.faces[3][1] = 8;
  MeshReport r = CheckMesh(m);
  EXPECT_FALSE(r.indices_valid);
  EXPECT_FALSE(r.closed);
  EXPECT_FALSE(r.ok());
  m.faces[3][1] = -1;
  r = CheckMesh(m);
  EXPECT_FALSE(r.indices_valid);
}

TEST(MeshCheckTest, DegenerateFaceNanVertexAndEmptyMeshFail) {
  TriangleMesh m = MakeCube();
  m.faces.push_back({1, 1, 2});
  MeshReport r = CheckMesh(m);
  EXPECT_EQ(r.num_degenerate_faces, 1);
  EXPECT_FALSE(r.ok());

  m = MakeCube();
  m.vertices[0][0] = std::numeric_limits<double>::quiet_NaN();
  r = CheckMesh(m);
  EXPECT_EQ(r.num_nonfinite_vertices, 1);
  EXPECT_FALSE(r.ok());

  r = CheckMesh(TriangleMesh{});
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.closed);
}

TEST(MeshCheckTest, ProblemsAreHumanReadable) {
  TriangleMesh m = MakeCube();
  m.faces.pop_back();
  const MeshReport r = CheckMesh(m);
  ASSERT_FALSE(r.problems.empty());
  EXPECT_NE(r.problems.front().find("not closed"), std::string::npos) << r.problems.front();
}

}  // namespace
}  // namespace softgrasp::mesh
