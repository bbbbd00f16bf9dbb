// CheckMesh on meshes whose answers are known by construction; self-intersections also against
// an independent brute-force count (brute_force_intersections.h).
#include "service/mesh/mesh_check.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "tests/mesh/brute_force_intersections.h"
#include "tests/mesh/mesh_test_util.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::mesh {
namespace {

using softgrasp::testing::BoxMesh;
using testing::BruteForceSelfIntersections;
using testing::MakeOctahedron;
using testing::MakeTetrahedron;
using testing::MakeTorus;
using testing::Merge;

TEST(MeshCheckTest, CubePasses) {
  const MeshReport r = CheckMesh(BoxMesh({0, 0, 0}, {2, 2, 2}));
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
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
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
  const MeshReport r =
      CheckMesh(Merge(BoxMesh({0, 0, 0}, {1, 1, 1}), BoxMesh({3, 0, 0}, {4, 1, 1})));
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
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
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
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
  for (auto& f : m.faces) std::swap(f[1], f[2]);
  const MeshReport r = CheckMesh(m);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_FALSE(r.outward);
  EXPECT_DOUBLE_EQ(r.volume, -1.0);
  EXPECT_FALSE(r.ok());
}

TEST(MeshCheckTest, CubesSharingAVertexAreNotVertexManifold) {
  // Second cube's corner 0 is the first cube's corner 7: one piece, pinched at a vertex.
  TriangleMesh m = Merge(BoxMesh({0, 0, 0}, {1, 1, 1}), BoxMesh({1, 1, 1}, {2, 2, 2}));
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
  TriangleMesh m = Merge(BoxMesh({0, 0, 0}, {1, 1, 1}), BoxMesh({1, 1, 0}, {2, 2, 1}));
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
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
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
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.faces.push_back({1, 1, 2});
  MeshReport r = CheckMesh(m);
  EXPECT_EQ(r.num_degenerate_faces, 1);
  EXPECT_FALSE(r.ok());

  m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.vertices[0][0] = std::numeric_limits<double>::quiet_NaN();
  r = CheckMesh(m);
  EXPECT_EQ(r.num_nonfinite_vertices, 1);
  EXPECT_FALSE(r.ok());

  r = CheckMesh(TriangleMesh{});
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.closed);
}

TEST(MeshCheckTest, ProblemsAreHumanReadable) {
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.faces.pop_back();
  const MeshReport r = CheckMesh(m);
  ASSERT_FALSE(r.problems.empty());
  EXPECT_NE(r.problems.front().find("not closed"), std::string::npos) << r.problems.front();
}

using Pairs = std::vector<std::array<int, 2>>;

/// Everything but the self-intersection test passes: a closed, one-piece, consistently oriented
/// 2-manifold.
void ExpectCombinatoriallyValid(const MeshReport& r) {
  EXPECT_TRUE(r.indices_valid);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_TRUE(r.vertex_manifold);
  EXPECT_TRUE(r.connected);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.num_degenerate_faces, 0);
}

/// CheckMesh's pairs (CGAL) equal the brute-force pairs and `expected`.
void ExpectPairs(const TriangleMesh& m, const Pairs& expected, int collinear = 0) {
  const MeshReport r = CheckMesh(m);
  ASSERT_TRUE(r.self_intersections_checked);
  EXPECT_EQ(r.self_intersecting_pairs, expected);
  EXPECT_EQ(r.num_self_intersecting_pairs, static_cast<int>(expected.size()));
  EXPECT_EQ(r.num_collinear_faces, collinear);
  EXPECT_EQ(r.self_intersection_free, expected.empty() && collinear == 0);
  const auto brute = BruteForceSelfIntersections(m);
  EXPECT_EQ(brute.pairs, expected);
  EXPECT_EQ(static_cast<int>(brute.collinear_faces.size()), collinear);
}

TEST(MeshCheckTest, ValidSolidsDoNotSelfIntersect) {
  for (const TriangleMesh& m : {BoxMesh({0, 0, 0}, {2, 2, 2}), MakeTetrahedron(), MakeOctahedron(),
                                MakeTorus(), MakeTorus(2.0, 1.9, 24, 12)}) {
    const MeshReport r = CheckMesh(m);
    EXPECT_TRUE(r.ok()) << (r.problems.empty() ? "" : r.problems.front());
    EXPECT_TRUE(r.self_intersections_checked);
    EXPECT_TRUE(r.self_intersection_free);
    ExpectPairs(m, {});
  }
  EXPECT_NEAR(CheckMesh(MakeOctahedron()).volume, 4.0 / 3.0, 1e-15);
}

/// The tetrahedron A (0,0,0), B (3,0,0), C (0,3,0), D (0,0,3) (units arbitrary) with its base ABC
/// replaced by a fan of three faces around E. Faces: 0 ABD (y = 0), 1 ADC (x = 0),
/// 2 BCD (x + y + z = 3), 3 EAC, 4 ECB, 5 EBA. With E inside the tetrahedron it is a valid solid
/// with a dent in its base; pushed out through a side face, the fan cuts that face.
TriangleMesh TetrahedronWithBaseFan(const std::array<double, 3>& e) {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {3, 0, 0}, {0, 3, 0}, {0, 0, 3}, e};
  m.faces = {{0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {4, 0, 2}, {4, 2, 1}, {4, 1, 0}};
  return m;
}

TEST(MeshCheckTest, BaseCentrePushedOutThroughASideFaceCutsIt) {
  // Inside (E 0.5 above the base): valid, volume 4.5 - 0.75 (the tetrahedron EABC is cut away).
  const MeshReport inside = CheckMesh(TetrahedronWithBaseFan({1, 1, 0.5}));
  EXPECT_TRUE(inside.ok()) << (inside.problems.empty() ? "" : inside.problems.front());
  EXPECT_NEAR(inside.volume, 3.75, 1e-12);
  ExpectPairs(TetrahedronWithBaseFan({1, 1, 0.5}), {});

  // E out through face ABD (y = 0) near its centre (1, 0, 1): the fan faces EAC and ECB each run
  // from their vertex on ABD (A, resp. B) into it, through to E, so they cross ABD; EBA shares the
  // edge AB with it and lies outside; nothing else meets.
  const TriangleMesh pushed = TetrahedronWithBaseFan({1, -0.5, 1});
  const MeshReport r = CheckMesh(pushed);
  ExpectCombinatoriallyValid(r);
  EXPECT_TRUE(r.outward);
  EXPECT_NEAR(r.volume, 3.0, 1e-12);  // the signed volume does not see the crossing
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.self_intersection_free);
  ExpectPairs(pushed, {{0, 3}, {0, 4}});
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_EQ(
      r.problems[0],
      "2 pairs of faces that cut through each other: self-intersecting (first: faces 0 and 3)");
}

TEST(MeshCheckTest, TouchingFacesIntersect) {
  // E exactly at the centre (1, 0, 1) of face ABD: EAC and ECB touch ABD at E, and EBA lies in
  // ABD's plane on the same side of their shared edge AB, overlapping it.
  ExpectPairs(TetrahedronWithBaseFan({1, 0, 1}), {{0, 3}, {0, 4}, {0, 5}});
}

TEST(MeshCheckTest, NearMissesAreDecidedExactly) {
  // E 2^-40 (relative) inside or outside the slanted face BCD, near its centre (1, 1, 1): inside
  // is valid; outside, EAC and EBA cross BCD (ECB shares the edge BC with it).
  const double t = std::ldexp(1.0, -40);
  ExpectPairs(TetrahedronWithBaseFan({1 - t, 1 - t, 1 - t}), {});
  EXPECT_TRUE(CheckMesh(TetrahedronWithBaseFan({1 - t, 1 - t, 1 - t})).ok());
  ExpectPairs(TetrahedronWithBaseFan({1 + t, 1 + t, 1 + t}), {{2, 3}, {2, 5}});
}

TEST(MeshCheckTest, CubeCornerPushedBelowTheBottomFoldsThroughIt) {
  // Corner 7 (1, 1, 1) moved to (1, 1, -0.5), below the bottom face z = 0. Counted by hand:
  //  - its faces in the walls y = 1 (6: 2-6-7, 7: 2-7-3) and x = 1 (10: 1-3-7, 11: 1-7-5) now
  //    fold over each other within their walls (coplanar, same side of the shared edge): {6, 7},
  //    {10, 11};
  //  - face 3 (5-7-6) dives through the bottom half 1 (1-2-3), meeting z = 0 along the segment
  //    (1, 2/3, 0)-(2/3, 1, 0), and through faces 7 and 10 (its edge 7-5 runs into 10 beyond the
  //    shared corner, 7-6 into 7): {1, 3}, {3, 7}, {3, 10};
  //  - faces 6 and 11 contain the bottom edges 2-3 and 1-3 beyond corners 2 and 1: {1, 6},
  //    {1, 11}.
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.vertices[7] = {1, 1, -0.5};
  const MeshReport r = CheckMesh(m);
  ExpectCombinatoriallyValid(r);
  EXPECT_FALSE(r.ok());
  ExpectPairs(m, {{1, 3}, {1, 6}, {1, 11}, {3, 7}, {3, 10}, {6, 7}, {10, 11}});
}

TEST(MeshCheckTest, CollinearFaceIsReportedAndNotPaired) {
  // Triangular bipyramid, equator e0 (2,0,0), e1 (0,2,0), e2 (-2,-2,0), bottom apex (0,0,-2), top
  // apex T moved onto the middle of edge e0-e1: face 0 (T e0 e1) has no area, faces 1 (T e1 e2)
  // and 2 (T e2 e0) fill the equator and touch the bottom face 3 (bottom e1 e0) at T.
  TriangleMesh m;
  m.vertices = {{2, 0, 0}, {0, 2, 0}, {-2, -2, 0}, {0, 0, -2}, {1, 1, 0}};
  m.faces = {{4, 0, 1}, {4, 1, 2}, {4, 2, 0}, {3, 1, 0}, {3, 2, 1}, {3, 0, 2}};
  const MeshReport r = CheckMesh(m);
  ExpectCombinatoriallyValid(r);
  EXPECT_TRUE(r.outward);
  ExpectPairs(m, {{1, 3}, {2, 3}}, 1);
  EXPECT_EQ(r.problems.back(), "1 faces with three collinear vertices: zero area (first: face 0)");
}

TEST(MeshCheckTest, SelfIntersectionTestRunsOnlyOnMeshesItCanRead) {
  // Bad indices, NaN, non-manifold edges: reported, the test is skipped, nothing throws.
  TriangleMesh bad = BoxMesh({0, 0, 0}, {1, 1, 1});
  bad.faces[3][1] = 99;
  MeshReport r = CheckMesh(bad);
  EXPECT_FALSE(r.self_intersections_checked);
  EXPECT_FALSE(r.self_intersection_free);
  bad = BoxMesh({0, 0, 0}, {1, 1, 1});
  bad.vertices[7][2] = std::numeric_limits<double>::infinity();
  r = CheckMesh(bad);
  EXPECT_FALSE(r.self_intersections_checked);
  EXPECT_FALSE(r.ok());
  // Sharing an edge, as above.
  bad = Merge(BoxMesh({0, 0, 0}, {1, 1, 1}), BoxMesh({1, 1, 0}, {2, 2, 1}));
  for (auto& f : bad.faces) {
    for (int& i : f) {
      if (i == 8) i = 3;
      if (i == 12) i = 7;
    }
  }
  r = CheckMesh(bad);
  EXPECT_FALSE(r.self_intersections_checked);
  EXPECT_FALSE(r.ok());
  // An open mesh is still tested (its other problem is reported apart).
  TriangleMesh open = BoxMesh({0, 0, 0}, {1, 1, 1});
  open.faces.pop_back();
  r = CheckMesh(open);
  EXPECT_TRUE(r.self_intersections_checked);
  EXPECT_TRUE(r.self_intersection_free);
  EXPECT_FALSE(r.closed);
  // Two disjoint pieces are tested too; two interpenetrating ones cross.
  r = CheckMesh(Merge(BoxMesh({0, 0, 0}, {1, 1, 1}), BoxMesh({3, 0, 0}, {4, 1, 1})));
  EXPECT_TRUE(r.self_intersections_checked);
  EXPECT_EQ(r.num_self_intersecting_pairs, 0);
  const TriangleMesh overlapping =
      Merge(BoxMesh({0, 0, 0}, {1, 1, 1}), BoxMesh({0.75, 0.25, 0.25}, {1.25, 0.75, 0.75}));
  r = CheckMesh(overlapping);
  EXPECT_TRUE(r.self_intersections_checked);
  EXPECT_GT(r.num_self_intersecting_pairs, 0);
  EXPECT_EQ(r.self_intersecting_pairs, BruteForceSelfIntersections(overlapping).pairs);
}

TEST(MeshCheckTest, SelfIntersectionTestCanBeTurnedOff) {
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.vertices[7] = {1, 1, -0.5};
  MeshCheckOptions options;
  options.self_intersections = false;
  const MeshReport r = CheckMesh(m, options);
  EXPECT_FALSE(r.self_intersections_checked);
  EXPECT_FALSE(r.self_intersection_free);
  EXPECT_EQ(r.num_self_intersecting_pairs, 0);
  EXPECT_EQ(r.ok(), r.outward);  // only the geometric volume test is left to fail
  EXPECT_TRUE(CheckMesh(BoxMesh({0, 0, 0}, {1, 1, 1}), options).ok());
}

}  // namespace
}  // namespace softgrasp::mesh
