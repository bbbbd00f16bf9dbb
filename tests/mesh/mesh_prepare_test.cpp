// PrepareMesh: every repair on a mesh built to need exactly it, every refused class with its code
// and message, units and Dex-Net's rescale against closed forms, the real Dex-Net bar clamp, the
// seeds it adds to the mesh_decode fuzz corpus (SOFTGRASP_WRITE_FUZZ_CORPUS=1 rewrites them from
// PrepareCorpusFiles() below), and random small meshes that must never break it.
#include "service/mesh/mesh_prepare.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "service/mesh/mesh_io.h"
#include "tests/mesh/mesh_test_util.h"
#include "tests/support/box_mesh.h"
#include "tests/support/test_data.h"

namespace softgrasp::mesh {
namespace {

using core::ErrorCode;
using softgrasp::testing::BoxMesh;
using ::testing::HasSubstr;
using testing::MakeTorus;
using testing::Merge;
using ::testing::Not;

// ---------------------------------------------------------------------------------------------
// Helpers

/// Every face with its own three vertices (what STL and many OBJ exporters write).
TriangleMesh Soup(const TriangleMesh& m) {
  TriangleMesh out;
  for (const auto& f : m.faces) {
    const int base = static_cast<int>(out.vertices.size());
    for (const int v : f) out.vertices.push_back(m.vertices[static_cast<std::size_t>(v)]);
    out.faces.push_back({base, base + 1, base + 2});
  }
  return out;
}

TriangleMesh Reversed(TriangleMesh m) {
  for (auto& f : m.faces) std::swap(f[1], f[2]);
  return m;
}

TriangleMesh Transformed(TriangleMesh m, const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  for (auto& v : m.vertices) {
    const Eigen::Vector3d p = r * Eigen::Vector3d(v[0], v[1], v[2]) + t;
    v = {p.x(), p.y(), p.z()};
  }
  return m;
}

Eigen::Matrix3d SomeRotation() {
  return (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

/// A cube of side `side` metres at the origin corner.
TriangleMesh Cube(double side, const Eigen::Vector3d& at = Eigen::Vector3d::Zero()) {
  return BoxMesh(at, at + Eigen::Vector3d::Constant(side));
}

PreparedMesh MustPrepare(const TriangleMesh& m, const PrepareOptions& options = {}) {
  auto r = PrepareMesh(m, options);
  EXPECT_TRUE(r.ok()) << r.error().message;
  return r.ok() ? std::move(r).value() : PreparedMesh{};
}

/// The error; fails the test when the mesh was accepted.
core::Error MustRefuse(const TriangleMesh& m, const PrepareOptions& options = {}) {
  const auto r = PrepareMesh(m, options);
  EXPECT_FALSE(r.ok()) << "accepted unexpectedly";
  return r.ok() ? core::Error{} : r.error();
}

/// What every prepared mesh must be.
void ExpectSolid(const PreparedMesh& p) {
  const MeshReport r = CheckMesh(p.mesh);
  EXPECT_TRUE(r.indices_valid && r.closed && r.edge_manifold && r.vertex_manifold && r.connected &&
              r.consistently_oriented && r.outward);
  EXPECT_EQ(r.num_degenerate_faces, 0);
  EXPECT_EQ(r.num_unreferenced_vertices, 0);
  EXPECT_EQ(r.num_collinear_faces, 0);
  EXPECT_GT(p.volume_m3, 0.0);
  EXPECT_NEAR(r.volume, p.volume_m3, 1e-12 * std::abs(p.volume_m3) + 1e-300);
}

std::string Repairs(const PreparedMesh& p) {
  std::string all;
  for (const auto& line : p.repairs) all += line + "\n";
  return all;
}

// ---------------------------------------------------------------------------------------------
// Units and rescaling

TEST(MeshPrepareTest, CubeInMillimetresBecomesMetres) {
  PrepareOptions options;
  options.unit_scale_m = 0.001;
  const PreparedMesh p = MustPrepare(Cube(50.0), options);
  ExpectSolid(p);
  EXPECT_TRUE(p.repairs.empty()) << Repairs(p);
  EXPECT_TRUE(p.warnings.empty());
  EXPECT_EQ(p.mesh.faces, Cube(50.0).faces);
  EXPECT_DOUBLE_EQ(p.scale_applied, 0.001);
  EXPECT_DOUBLE_EQ(p.rescale_factor, 1.0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(p.extents_m[static_cast<std::size_t>(k)], 0.05, 1e-15);
    EXPECT_NEAR(p.centroid_m[static_cast<std::size_t>(k)], 0.025, 1e-15);
  }
  EXPECT_NEAR(p.volume_m3, 1.25e-4, 1e-18);
  for (const auto& v : p.mesh.vertices) {
    for (const double x : v) EXPECT_TRUE(x == 0.0 || x == 0.05) << x;
  }
  EXPECT_TRUE(p.report.self_intersections_checked);
  EXPECT_TRUE(p.report.ok());
}

TEST(MeshPrepareTest, RotatedBoxGetsItsSmallestPrincipalExtentSetAsDexNetDoes) {
  // A 2 x 4 x 8 box, turned and moved: its principal axes are its sides whatever the file frame.
  const Eigen::Matrix3d r = SomeRotation();
  const TriangleMesh box = Transformed(softgrasp::testing::CentredBoxMesh({1, 2, 4}), r,
                                       Eigen::Vector3d(0.3, -0.2, 0.1));
  PrepareOptions options;
  options.rescale_min_extent_m = 0.04;
  const PreparedMesh p = MustPrepare(box, options);
  ExpectSolid(p);
  EXPECT_TRUE(p.repairs.empty()) << Repairs(p);
  EXPECT_NEAR(p.extents_m[0], 0.04, 1e-9);
  EXPECT_NEAR(p.extents_m[1], 0.08, 1e-9);
  EXPECT_NEAR(p.extents_m[2], 0.16, 1e-9);
  EXPECT_NEAR(p.extents_before_rescale_m[0], 2.0, 1e-9);
  EXPECT_NEAR(p.extents_before_rescale_m[1], 4.0, 1e-9);
  EXPECT_NEAR(p.extents_before_rescale_m[2], 8.0, 1e-9);
  EXPECT_NEAR(p.rescale_factor, 0.02, 1e-12);
  EXPECT_DOUBLE_EQ(p.scale_applied, p.rescale_factor);
  EXPECT_NEAR(p.volume_m3, 0.04 * 0.08 * 0.16, 1e-15);
  for (std::size_t k = 0; k < 3; ++k) {
    const Eigen::Vector3d axis(p.principal_axes[k][0], p.principal_axes[k][1],
                               p.principal_axes[k][2]);
    EXPECT_NEAR(std::abs(axis.dot(r.col(static_cast<Eigen::Index>(k)))), 1.0, 1e-12) << k;
  }
  // Scaled about the origin: prepared = file * scale_applied.
  EXPECT_NEAR(p.mesh.vertices[0][0], box.vertices[0][0] * 0.02, 1e-15);
  EXPECT_NEAR(p.centroid_m[0], 0.3 * 0.02, 1e-12);

  // The same box in millimetres: the unit changes the factor, not the result.
  options.unit_scale_m = 0.001;
  const TriangleMesh mm =
      Transformed(softgrasp::testing::CentredBoxMesh({10, 20, 40}), r, Eigen::Vector3d(3, -2, 1));
  const PreparedMesh q = MustPrepare(mm, options);
  EXPECT_NEAR(q.extents_m[0], 0.04, 1e-9);
  EXPECT_NEAR(q.extents_before_rescale_m[0], 0.02, 1e-12);
  EXPECT_NEAR(q.rescale_factor, 2.0, 1e-9);
  EXPECT_NEAR(q.scale_applied, 0.002, 1e-12);
}

TEST(MeshPrepareTest, EqualPrincipalMomentsFallBackToTheFileAxes) {
  // A cube's moments are all equal and a square prism's two are: any axes in those planes are
  // principal. The file axes are used there, so an axis-aligned cube keeps its side as extent.
  PrepareOptions options;
  options.rescale_min_extent_m = 0.04;
  const PreparedMesh cube = MustPrepare(Cube(0.1, {1, 2, 3}), options);
  for (const double e : cube.extents_m) EXPECT_NEAR(e, 0.04, 1e-12);
  const PreparedMesh prism = MustPrepare(BoxMesh({0, 0, 0}, {0.1, 0.1, 0.3}), options);
  EXPECT_NEAR(prism.extents_m[0], 0.04, 1e-12);
  EXPECT_NEAR(prism.extents_m[1], 0.04, 1e-12);
  EXPECT_NEAR(prism.extents_m[2], 0.12, 1e-12);
  EXPECT_NEAR(std::abs(prism.principal_axes[2][2]), 1.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Repairs

TEST(MeshPrepareTest, TriangleSoupIsWelded) {
  const PreparedMesh p = MustPrepare(Soup(Cube(0.05)));
  ExpectSolid(p);
  EXPECT_EQ(p.mesh.vertices.size(), 8u);
  EXPECT_EQ(p.mesh.faces.size(), 12u);
  EXPECT_EQ(p.counts.welded_vertices, 28);
  ASSERT_EQ(p.repairs.size(), 1u);
  EXPECT_EQ(p.repairs[0], "welded 28 duplicate vertices (equal coordinates)");
}

TEST(MeshPrepareTest, InsideOutCubeIsTurnedRightSideOut) {
  const PreparedMesh p = MustPrepare(Reversed(Cube(0.05)));
  ExpectSolid(p);
  EXPECT_TRUE(p.counts.turned_inside_out);
  EXPECT_EQ(p.counts.reoriented_faces, 12);
  EXPECT_EQ(p.mesh.faces, Cube(0.05).faces);
  ASSERT_EQ(p.repairs.size(), 1u);
  EXPECT_EQ(p.repairs[0],
            "turned the mesh right side out: all 12 faces faced inwards (negative volume) and "
            "were flipped");
}

TEST(MeshPrepareTest, OneFlippedFaceIsReoriented) {
  TriangleMesh m = Cube(0.05);
  std::swap(m.faces[3][1], m.faces[3][2]);
  const PreparedMesh p = MustPrepare(m);
  ExpectSolid(p);
  EXPECT_FALSE(p.counts.turned_inside_out);
  EXPECT_EQ(p.counts.reoriented_faces, 1);
  EXPECT_EQ(p.mesh.faces, Cube(0.05).faces);
  ASSERT_EQ(p.repairs.size(), 1u);
  EXPECT_EQ(p.repairs[0], "reoriented 1 face to agree with their neighbours and face outwards");

  // Most faces flipped: the orientation with positive volume wins, whichever face it started at.
  TriangleMesh most = Reversed(Cube(0.05));
  std::swap(most.faces[0][1], most.faces[0][2]);
  const PreparedMesh q = MustPrepare(most);
  EXPECT_EQ(q.counts.reoriented_faces, 11);
  EXPECT_FALSE(q.counts.turned_inside_out);
  EXPECT_EQ(q.mesh.faces, Cube(0.05).faces);
}

TEST(MeshPrepareTest, UnusedVerticesAndDegenerateFacesAreDropped) {
  TriangleMesh m = Cube(0.05);
  m.vertices.push_back({9, 9, 9});    // used by nothing
  m.vertices.push_back({0, 0, 0.5});  // used only by a face naming vertex 0 twice
  m.faces.push_back({0, 0, 9});
  const PreparedMesh p = MustPrepare(m);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.unused_vertices, 2);
  EXPECT_EQ(p.counts.degenerate_faces, 1);
  EXPECT_EQ(p.mesh.vertices.size(), 8u);
  EXPECT_EQ(p.repairs, (std::vector<std::string>{"dropped 1 degenerate face (a vertex named twice)",
                                                 "dropped 2 unused vertices"}));
}

TEST(MeshPrepareTest, DuplicateFacesAreDropped) {
  TriangleMesh m = Cube(0.05);
  m.faces.push_back(m.faces[4]);
  m.faces.push_back({m.faces[7][1], m.faces[7][2], m.faces[7][0]});  // same face, rotated
  const PreparedMesh p = MustPrepare(m);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.duplicate_faces, 2);
  EXPECT_EQ(p.mesh.faces, Cube(0.05).faces);
  EXPECT_EQ(p.repairs, std::vector<std::string>{"dropped 2 duplicate faces"});
}

TEST(MeshPrepareTest, AFaceExportedTwoSidedKeepsOneSide) {
  // A side with a reversed copy: dropping both would open a hole, so one is kept.
  TriangleMesh m = Cube(0.05);
  m.faces.push_back({m.faces[5][0], m.faces[5][2], m.faces[5][1]});
  const PreparedMesh p = MustPrepare(m);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.duplicate_faces, 1);
  EXPECT_EQ(p.counts.opposite_face_pairs, 0);
  EXPECT_EQ(p.mesh.faces.size(), 12u);
  EXPECT_NEAR(p.volume_m3, 1.25e-4, 1e-18);
}

TEST(MeshPrepareTest, TwoCubesGluedFaceToFaceBecomeOneBox) {
  // Each cube closed on its own; the shared square appears once each way: an internal wall.
  const TriangleMesh m = Merge(Cube(1.0), Cube(1.0, {1, 0, 0}));
  PrepareOptions options;
  options.unit_scale_m = 0.01;
  const PreparedMesh p = MustPrepare(m, options);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.opposite_face_pairs, 2);
  EXPECT_EQ(p.counts.welded_vertices, 4);
  EXPECT_EQ(p.mesh.faces.size(), 20u);
  EXPECT_NEAR(p.volume_m3, 2e-6, 1e-18);
  EXPECT_NEAR(p.extents_m[2], 0.02, 1e-15);
  EXPECT_EQ(p.repairs,
            (std::vector<std::string>{
                "welded 4 duplicate vertices (equal coordinates)",
                "dropped 2 pairs of coincident faces facing opposite ways (internal walls or "
                "zero-thickness sheets)"}));
}

TEST(MeshPrepareTest, PiecesInsideTheMainOneAreDropped) {
  // An inner cube (a hidden part), and a cavity written the usual way (inner shell inward).
  const TriangleMesh inner = Merge(Cube(0.1), Cube(0.02, {0.04, 0.04, 0.04}));
  const PreparedMesh p = MustPrepare(inner);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.inner_pieces, 1);
  EXPECT_EQ(p.counts.debris_pieces, 0);
  EXPECT_EQ(p.counts.reoriented_faces, 0);
  EXPECT_EQ(p.mesh.faces.size(), 12u);
  EXPECT_NEAR(p.counts.dropped_volume_fraction, 8e-6 / (1e-3 + 8e-6), 1e-12);
  EXPECT_EQ(p.repairs,
            std::vector<std::string>{"dropped 1 piece inside the main one (inner shells, cavities "
                                     "or hidden parts), holding 0.794% of the volume"});

  const TriangleMesh cavity = Merge(Cube(0.1), Reversed(Cube(0.08, {0.01, 0.01, 0.01})));
  const PreparedMesh q = MustPrepare(cavity);
  ExpectSolid(q);
  EXPECT_EQ(q.counts.inner_pieces, 1);
  EXPECT_EQ(q.counts.reoriented_faces, 0);  // the dropped shell's flip is not reported
  EXPECT_NEAR(q.volume_m3, 1e-3, 1e-15);    // the cavity is filled
}

TEST(MeshPrepareTest, TinySeparatePiecesAreDroppedAsDebris) {
  const TriangleMesh m = Merge(Cube(0.1), Cube(0.001, {0.2, 0, 0}));
  const PreparedMesh p = MustPrepare(m);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.debris_pieces, 1);
  EXPECT_EQ(p.mesh.faces.size(), 12u);
  EXPECT_EQ(p.repairs, std::vector<std::string>{
                           "dropped 1 small separate piece, holding 0.0001% of the volume"});
}

TEST(MeshPrepareTest, ZeroAreaFaceIsFlippedAway) {
  // The bottom diagonal of a cube (corners 1 and 2) with a vertex M on its middle on one side
  // (a T-junction) closed by the zero-area face (1, M, 2): flipping it with its neighbour
  // across the diagonal leaves the same surface with no zero-area face.
  TriangleMesh m = Cube(2.0);
  m.vertices.push_back({1, 1, 0});
  const int mid = 8;
  ASSERT_EQ(m.faces[0], (std::array<int, 3>{0, 2, 1}));
  m.faces[0] = {2, mid, 0};
  m.faces.push_back({mid, 1, 0});
  m.faces.push_back({1, mid, 2});
  ASSERT_EQ(CheckMesh(m).num_collinear_faces, 1);
  PrepareOptions options;
  options.unit_scale_m = 0.01;
  const PreparedMesh p = MustPrepare(m, options);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.collinear_faces_removed, 1);
  EXPECT_EQ(p.mesh.faces.size(), 14u);
  EXPECT_NEAR(p.volume_m3, 8e-6, 1e-18);
  EXPECT_TRUE(p.report.ok()) << p.report.problems.front();
  EXPECT_EQ(p.repairs, std::vector<std::string>{
                           "removed 1 zero-area face (three vertices on a line) by flipping an "
                           "edge; the surface is unchanged"});

  // Zero-area faces on both sides of the diagonal (two T-junctions at different points).
  TriangleMesh two = Cube(2.0);
  two.vertices.push_back({1, 1, 0});      // 8, on the side of face 0 (0 2 1)
  two.vertices.push_back({1.5, 0.5, 0});  // 9, on the side of face 1 (1 2 3)
  two.faces[0] = {2, 8, 0};
  two.faces.push_back({8, 1, 0});
  two.faces.push_back({1, 8, 2});
  two.faces[1] = {1, 9, 3};
  two.faces.push_back({9, 2, 3});
  two.faces.push_back({2, 9, 1});
  ASSERT_EQ(CheckMesh(two).num_collinear_faces, 2);
  const PreparedMesh q = MustPrepare(two, options);
  ExpectSolid(q);
  EXPECT_EQ(q.counts.collinear_faces_removed, 2);
  EXPECT_TRUE(q.report.ok()) << q.report.problems.front();
}

TEST(MeshPrepareTest, ZeroAreaFaceOfABipyramidIsFlippedAwayWithTheTouchingItCaused) {
  // mesh_check_test's bipyramid whose top apex T sits on the equator edge e0-e1: the zero-area
  // face (T e0 e1) goes, and with it the bottom face (bottom e1 e0) that T touched: the flip
  // splits that face at T, so the faces around T now share it as a vertex.
  TriangleMesh m;
  m.vertices = {{2, 0, 0}, {0, 2, 0}, {-2, -2, 0}, {0, 0, -2}, {1, 1, 0}};
  m.faces = {{4, 0, 1}, {4, 1, 2}, {4, 2, 0}, {3, 1, 0}, {3, 2, 1}, {3, 0, 2}};
  ASSERT_EQ(CheckMesh(m).num_self_intersecting_pairs, 2);
  PrepareOptions options;
  options.unit_scale_m = 0.01;
  const PreparedMesh p = MustPrepare(m, options);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.collinear_faces_removed, 1);
  EXPECT_TRUE(p.warnings.empty()) << p.warnings.front();
  EXPECT_TRUE(p.report.ok()) << p.report.problems.front();
}

// ---------------------------------------------------------------------------------------------
// Refusals: each class with its code

TEST(MeshPrepareTest, OpenSurfacesAreRefusedNamingTheirBoundaryEdges) {
  // One side of a box is a sheet: closing it would double its area.
  TriangleMesh sheet = Cube(0.05);
  sheet.faces.resize(2);
  const core::Error e = MustRefuse(sheet);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.field, "mesh");
  EXPECT_THAT(e.message, HasSubstr("the mesh is not closed: 4 boundary edges"));
  EXPECT_THAT(e.message, HasSubstr("first between ("));
  EXPECT_THAT(e.message, HasSubstr("; not filled: filling the 1 hole would add 100% to the surface "
                                   "area, more than the 50% filled (is the surface open on one "
                                   "side?)"));

  // Allowed to double the area, the patch would be the sheet's own two triangles turned over:
  // their diagonal would get four faces.
  PrepareOptions any_area;
  any_area.fill_hole_max_area_fraction = 2.0;
  EXPECT_THAT(MustRefuse(sheet, any_area).message,
              HasSubstr("; not filled: a patch would join two vertices that the surface already "
                        "joins by an edge"));

  // With hole filling off, a box missing one triangle is refused, and the refusal does not
  // mention filling.
  TriangleMesh m = Cube(0.05);
  m.faces.erase(m.faces.begin() + 2);
  PrepareOptions no_filling;
  no_filling.fill_hole_max_edges = 0;
  const core::Error off = MustRefuse(m, no_filling);
  EXPECT_THAT(off.message, HasSubstr("the mesh is not closed: 3 boundary edges"));
  EXPECT_THAT(off.message, Not(HasSubstr("not filled")));
}

// A box missing a triangle, or its whole lid (a scan of an object standing on the table misses its
// bottom): the patch is the missing side, so the box comes back exactly.
TEST(MeshPrepareTest, BoxMissingATriangleOrItsLidIsClosedAgain) {
  const double side = 0.05;
  TriangleMesh one = Cube(side);
  one.faces.erase(one.faces.begin() + 2);
  TriangleMesh lid = Cube(side);
  lid.faces.erase(lid.faces.begin() + 2, lid.faces.begin() + 4);
  for (const auto& [mesh, edges, faces, percent] :
       {std::tuple{one, 3, 1, "9.09%"}, std::tuple{lid, 4, 2, "20%"}}) {
    const PreparedMesh p = MustPrepare(mesh);
    ExpectSolid(p);
    EXPECT_EQ(p.counts.filled_holes, 1);
    EXPECT_EQ(p.counts.filled_hole_edges, edges);
    EXPECT_EQ(p.counts.hole_faces_added, faces);
    EXPECT_EQ(p.counts.reoriented_faces, 0);
    EXPECT_NEAR(p.volume_m3, side * side * side, 1e-15);
    EXPECT_THAT(Repairs(p),
                HasSubstr("filled 1 hole (" + std::to_string(edges) + " boundary edges) with " +
                          std::to_string(faces) + (faces == 1 ? " new face" : " new faces") +
                          ", adding " + percent + " to the surface area"));
  }
}

/// `m` without the faces that use vertex v: a hole whose boundary is v's ring of neighbours.
TriangleMesh WithoutFan(TriangleMesh m, int v) {
  std::erase_if(m.faces,
                [v](const std::array<int, 3>& f) { return f[0] == v || f[1] == v || f[2] == v; });
  return m;
}

// Scans of real objects come with holes where the scanner saw nothing; small ones are closed with
// triangles between their boundary vertices, facing out like their neighbours.
TEST(MeshPrepareTest, SmallHolesAreFilledFacingOut) {
  const int n = 32, m = 16;  // torus grid: vertex (i, j) is i * m + j, 6 faces around each
  const TriangleMesh torus = MakeTorus(0.04, 0.01, n, m);
  const PreparedMesh whole = MustPrepare(torus);
  const TriangleMesh holed = WithoutFan(WithoutFan(torus, 0), 16 * m + 8);
  ASSERT_EQ(holed.faces.size(), torus.faces.size() - 12);

  const PreparedMesh p = MustPrepare(holed);
  ExpectSolid(p);
  EXPECT_EQ(p.counts.filled_holes, 2);
  EXPECT_EQ(p.counts.filled_hole_edges, 12);
  EXPECT_EQ(p.counts.hole_faces_added, 8);  // a hexagon takes 4 triangles
  EXPECT_EQ(p.counts.reoriented_faces, 0);  // the patches already face out
  EXPECT_EQ(p.mesh.faces.size(), torus.faces.size() - 4);
  // Each hexagon's patch is flatter than the six faces it replaces, so it adds a little less
  // area than they had and takes a sliver of volume off.
  auto area = [](const TriangleMesh& mesh) {
    double sum = 0;
    for (const auto& f : mesh.faces) {
      const auto at = [&](int v) {
        const auto& x = mesh.vertices[static_cast<std::size_t>(v)];
        return Eigen::Vector3d(x[0], x[1], x[2]);
      };
      sum += 0.5 * (at(f[1]) - at(f[0])).cross(at(f[2]) - at(f[0])).norm();
    }
    return sum;
  };
  const double removed_fraction = (area(torus) - area(holed)) / area(holed);
  EXPECT_GT(p.counts.filled_area_fraction, 0.9 * removed_fraction);
  EXPECT_LT(p.counts.filled_area_fraction, removed_fraction);
  EXPECT_LT(p.volume_m3, whole.volume_m3);
  EXPECT_GT(p.volume_m3, 0.999 * whole.volume_m3);
  EXPECT_THAT(Repairs(p), HasSubstr("filled 2 holes (12 boundary edges) with 8 new faces, adding "
                                    "1.18% to the surface area"));

  // The same holes as a triangle soup, one face turned the wrong way: welded, filled, reoriented.
  TriangleMesh soup = Soup(holed);
  std::swap(soup.faces[100][1], soup.faces[100][2]);
  const PreparedMesh q = MustPrepare(soup);
  ExpectSolid(q);
  EXPECT_EQ(q.counts.filled_holes, 2);
  EXPECT_NEAR(q.volume_m3, p.volume_m3, 1e-15);
}

TEST(MeshPrepareTest, HolesBeyondTheLimitsAreNotFilled) {
  const int m = 16;
  const TriangleMesh holed = WithoutFan(MakeTorus(0.04, 0.01, 32, m), 5 * m + 3);
  PrepareOptions few_edges;
  few_edges.fill_hole_max_edges = 5;
  const core::Error e = MustRefuse(holed, few_edges);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_THAT(e.message, HasSubstr("the mesh is not closed: 6 boundary edges"));
  EXPECT_THAT(e.message, HasSubstr("not filled: a hole has 6 boundary edges, more than the 5 of a "
                                   "hole that is filled (is the surface open on one side?)"));
  PrepareOptions little_area;
  little_area.fill_hole_max_area_fraction = 0.001;
  EXPECT_THAT(MustRefuse(holed, little_area).message,
              HasSubstr("not filled: filling the 1 hole would add 0.639% to the surface area, "
                        "more than the 0.1% filled"));

  // Two triangles that share one corner leave two holes touching there: not a simple loop.
  TriangleMesh touching = MakeTorus(0.04, 0.01, 32, m);
  auto id = [&](int i, int j) { return i * m + j; };
  std::erase_if(touching.faces, [&](const std::array<int, 3>& f) {
    return f == std::array<int, 3>{id(4, 4), id(5, 5), id(4, 5)} ||
           f == std::array<int, 3>{id(5, 5), id(6, 5), id(6, 6)};
  });
  ASSERT_EQ(touching.faces.size(), 32U * m * 2 - 2);
  EXPECT_THAT(MustRefuse(touching).message,
              HasSubstr("not filled: two holes meet at a vertex, or the faces around a hole "
                        "disagree on their orientation"));
}

TEST(MeshPrepareTest, CubesSharingAnEdgeAreRefusedAsNonManifold) {
  const TriangleMesh m = Merge(Cube(0.05), Cube(0.05, {0.05, 0.05, 0}));
  const core::Error e = MustRefuse(m);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.field, "mesh");
  EXPECT_THAT(e.message,
              HasSubstr("the mesh is not 2-manifold: 1 edge is shared by more than two faces, "
                        "first between (0.05, 0.05, 0.05) and (0.05, 0.05, 0)"));
}

TEST(MeshPrepareTest, CubesSharingACornerAreRefusedAsNonManifold) {
  const TriangleMesh m = Merge(Cube(0.05), Cube(0.05, {0.05, 0.05, 0.05}));
  const core::Error e = MustRefuse(m);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.message,
            "the mesh is not 2-manifold: 1 vertex joins separate sheets of surface that touch "
            "only there, first at (0.05, 0.05, 0.05)");
}

TEST(MeshPrepareTest, OneSidedSurfaceIsRefused) {
  // A Klein bottle: the torus grid with one seam glued reversed (it crosses itself in space).
  const int n = 8, m = 6;
  TriangleMesh k = MakeTorus(2.0, 0.5, n, m);
  auto id = [&](int i, int j) {
    j = ((j % m) + m) % m;
    if (i == n) {
      i = 0;
      j = (m - j) % m;
    }
    return i * m + j;
  };
  k.faces.clear();
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      k.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      k.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  }
  const MeshReport r = CheckMesh(k, {.self_intersections = false});
  ASSERT_TRUE(r.closed && r.edge_manifold && r.vertex_manifold) << r.problems.front();
  PrepareOptions options;
  options.unit_scale_m = 0.01;
  const core::Error e = MustRefuse(k, options);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_THAT(e.message, HasSubstr("the surface cannot be oriented consistently"));
}

TEST(MeshPrepareTest, SeparateObjectsAreRefused) {
  const core::Error e = MustRefuse(Merge(Cube(0.05), Cube(0.04, {0.1, 0, 0})));
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.message,
            "the mesh has 2 separate closed pieces and 1 of them lies outside the largest, "
            "holding 33.9% of the volume: upload one object, or join the parts into one closed "
            "surface");
  // Overlapping pieces (a handle modelled as its own shell) are separate pieces too.
  EXPECT_THAT(MustRefuse(Merge(Cube(0.05), Cube(0.02, {0.04, 0.01, 0.01}))).message,
              HasSubstr("2 separate closed pieces"));
}

TEST(MeshPrepareTest, NonFiniteVertexIsAnInvalidArgument) {
  for (const double bad : {NAN, INFINITY, -INFINITY}) {
    TriangleMesh m = Cube(0.05);
    m.vertices[5][1] = bad;
    const core::Error e = MustRefuse(m);
    EXPECT_EQ(e.code, ErrorCode::kInvalidArgument);
    EXPECT_EQ(e.field, "mesh");
    EXPECT_EQ(e.message, "vertex 5 has a non-finite coordinate");
  }
}

TEST(MeshPrepareTest, IndexOutOfRangeIsAnInvalidArgument) {
  TriangleMesh m = Cube(0.05);
  m.faces[3][2] = 8;
  EXPECT_EQ(MustRefuse(m).code, ErrorCode::kInvalidArgument);
  m.faces[3][2] = -1;
  EXPECT_EQ(MustRefuse(m).code, ErrorCode::kInvalidArgument);
}

TEST(MeshPrepareTest, TooManyTrianglesIsPayloadTooLarge) {
  PrepareOptions options;
  options.max_triangles = 11;
  const core::Error e = MustRefuse(Cube(0.05), options);
  EXPECT_EQ(e.code, ErrorCode::kTooLarge);
  EXPECT_EQ(e.field, "mesh");
  EXPECT_EQ(e.message, "the mesh has 12 triangles; at most 11 are accepted");
  options.max_triangles = 12;
  MustPrepare(Cube(0.05), options);
}

TEST(MeshPrepareTest, NoTrianglesOrOnlyATwoSidedSheetIsUnprocessable) {
  TriangleMesh none = Cube(0.05);
  none.faces.clear();
  EXPECT_EQ(MustRefuse(none).code, ErrorCode::kUnprocessable);

  TriangleMesh sheet;
  sheet.vertices = {{0, 0, 0}, {0.05, 0, 0}, {0, 0.05, 0}};
  sheet.faces = {{0, 1, 2}, {0, 2, 1}};
  const core::Error e = MustRefuse(sheet);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.message,
            "no faces are left after dropping 1 pair of coincident faces facing opposite ways: "
            "the mesh encloses no volume (a flat sheet modelled with both sides?)");

  TriangleMesh degenerate;
  degenerate.vertices = {{0, 0, 0}, {0, 0, 0}, {1, 0, 0}};
  degenerate.faces = {{0, 1, 2}};
  EXPECT_THAT(MustRefuse(degenerate).message,
              HasSubstr("after dropping 1 face that names a vertex twice"));
}

TEST(MeshPrepareTest, FlatClosedMeshHasNoVolume) {
  // A tetrahedron's four faces on four points of one plane: closed, no volume.
  TriangleMesh m = testing::MakeTetrahedron();
  m.vertices[3] = {1, 1, 0};
  const core::Error e = MustRefuse(m);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_THAT(e.message, HasSubstr("the mesh encloses no volume"));
}

TEST(MeshPrepareTest, TooSmallOrTooLargeSaysToCheckTheUnit) {
  const core::Error small = MustRefuse(Cube(0.0005));
  EXPECT_EQ(small.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(small.message,
            "the mesh is too small: its smallest principal extent is 0.0005 m, below the 0.001 m "
            "accepted (is the unit right?)");
  // A 100 mm part read as metres.
  const core::Error large = MustRefuse(Cube(100.0));
  EXPECT_EQ(large.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(large.message,
            "the mesh is too large: its largest principal extent is 100 m, above the 2 m "
            "accepted (is the unit right?)");
  // Rescaled, a long bar becomes too long: no unit to blame.
  PrepareOptions options;
  options.rescale_min_extent_m = 0.04;
  EXPECT_THAT(MustRefuse(BoxMesh({0, 0, 0}, {1, 1, 100}), options).message,
              HasSubstr("its largest principal extent is 4 m, above the 2 m accepted"));
  // Coordinates no object has.
  const core::Error far = MustRefuse(Cube(0.05, {1e7, 0, 0}));
  EXPECT_EQ(far.code, ErrorCode::kUnprocessable);
  EXPECT_THAT(far.message, HasSubstr("coordinates reach 1e+07 m after the unit conversion"));
}

TEST(MeshPrepareTest, ZeroAreaFaceThatCannotBeFlippedIsRefused) {
  // Bottom: the zero-area face (M A C) and (A D C); top: the flat face (A M D) over part of the
  // bottom and a tent over (M C D). Flipping the zero-area face with (A D C) would add the edge
  // M-D, which the top already has.
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {2, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1.3, 0.3, 1}};  // A C M D T
  m.faces = {{2, 0, 1}, {0, 3, 1}, {0, 2, 3}, {2, 1, 4}, {1, 3, 4}, {3, 2, 4}};
  ASSERT_TRUE(CheckMesh(m, {.self_intersections = false}).closed);
  PrepareOptions options;
  options.unit_scale_m = 0.1;
  const core::Error e = MustRefuse(m, options);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.message,
            "1 face has three vertices on a line (zero area) and cannot be removed without "
            "opening the mesh, first at (1, 0, 0)");
}

TEST(MeshPrepareTest, SelfIntersectionsWarnOrRefuse) {
  // mesh_check_test's tetrahedron whose base fan is pushed out through a side: 2 crossing pairs.
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {3, 0, 0}, {0, 3, 0}, {0, 0, 3}, {1, -0.5, 1}};
  m.faces = {{0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {4, 0, 2}, {4, 2, 1}, {4, 1, 0}};
  PrepareOptions options;
  options.unit_scale_m = 0.01;
  const PreparedMesh p = MustPrepare(m, options);
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_EQ(p.warnings[0],
            "the mesh intersects itself: 2 pairs of faces cut through each other; volume and "
            "centre of mass count the overlap twice");
  EXPECT_EQ(p.report.num_self_intersecting_pairs, 2);

  options.self_intersections = SelfIntersectionPolicy::kRefuse;
  const core::Error e = MustRefuse(m, options);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.message, "the mesh intersects itself: 2 pairs of faces cut through each other");

  options.self_intersections = SelfIntersectionPolicy::kSkip;
  EXPECT_TRUE(MustPrepare(m, options).warnings.empty());

  options.self_intersections = SelfIntersectionPolicy::kWarn;
  options.self_intersection_min_box_pairs = 5;  // the 6 faces' boxes all overlap: 15 pairs
  options.self_intersection_box_pairs_per_face = 0.5;
  const PreparedMesh skipped = MustPrepare(m, options);
  ASSERT_EQ(skipped.warnings.size(), 1u);
  EXPECT_EQ(skipped.warnings[0],
            "self-intersections not tested: more than 5 pairs of faces have overlapping bounding "
            "boxes (a large triangle fan?), which would make the test slow");
  EXPECT_FALSE(skipped.report.self_intersections_checked);
}

TEST(MeshPrepareTest, BadUnitOrRescaleIsAnInvalidArgumentAndBadLimitsThrow) {
  for (const double unit : {0.0, -1.0, double{NAN}, double{INFINITY}}) {
    PrepareOptions options;
    options.unit_scale_m = unit;
    const core::Error e = MustRefuse(Cube(0.05), options);
    EXPECT_EQ(e.code, ErrorCode::kInvalidArgument);
    EXPECT_EQ(e.field, "unit");
  }
  for (const double target : {0.0, -0.04, double{NAN}}) {
    PrepareOptions options;
    options.rescale_min_extent_m = target;
    const core::Error e = MustRefuse(Cube(0.05), options);
    EXPECT_EQ(e.code, ErrorCode::kInvalidArgument);
    EXPECT_EQ(e.field, "rescale");
  }
  PrepareOptions bad;
  bad.max_triangles = 0;
  EXPECT_THROW(PrepareMesh(Cube(0.05), bad), std::invalid_argument);
  bad = {};
  bad.min_extent_m = NAN;
  EXPECT_THROW(PrepareMesh(Cube(0.05), bad), std::invalid_argument);
  bad = {};
  bad.fill_hole_max_edges = -1;  // 0 means "never fill"; below that is a mistake
  EXPECT_THROW(PrepareMesh(Cube(0.05), bad), std::invalid_argument);
  for (const double fraction : {-0.1, double{NAN}, double{INFINITY}}) {
    bad = {};
    bad.fill_hole_max_area_fraction = fraction;
    EXPECT_THROW(PrepareMesh(Cube(0.05), bad), std::invalid_argument) << fraction;
  }
}

// ---------------------------------------------------------------------------------------------
// A real mesh

TEST(MeshPrepareTest, DexNetBarClampNeedsOnlyWelding) {
  std::ifstream in(softgrasp::testing::TestData("meshes/dexnet_bar_clamp.obj"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto decoded = ReadMesh(bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  ASSERT_EQ(decoded.value().vertices.size(), 1428u);
  ASSERT_EQ(decoded.value().faces.size(), 476u);

  const PreparedMesh p = MustPrepare(decoded.value());
  ExpectSolid(p);
  EXPECT_EQ(p.mesh.faces.size(), 476u);
  EXPECT_EQ(p.counts.welded_vertices, 1428 - static_cast<int>(p.mesh.vertices.size()));
  EXPECT_EQ(p.counts.reoriented_faces, 0);
  EXPECT_EQ(p.counts.collinear_faces_removed, 0);
  ASSERT_EQ(p.repairs.size(), 1u) << Repairs(p);
  EXPECT_EQ(p.repairs[0], "welded " + std::to_string(p.counts.welded_vertices) +
                              " duplicate vertices (equal coordinates)");
  EXPECT_TRUE(p.warnings.empty()) << p.warnings.front();
  EXPECT_TRUE(p.report.ok()) << p.report.problems.front();
  // Metres already; its principal extents lie within its bounding box (about 0.156 x 0.109 x
  // 0.080 m, tests/data/README.md).
  EXPECT_GT(p.extents_m[0], 0.03);
  EXPECT_LT(p.extents_m[2], 0.2);

  PrepareOptions options;
  options.rescale_min_extent_m = 0.04;
  const PreparedMesh r = MustPrepare(decoded.value(), options);
  ExpectSolid(r);
  EXPECT_NEAR(r.extents_m[0], 0.04, 1e-12);
  EXPECT_NEAR(r.rescale_factor, 0.04 / p.extents_m[0], 1e-12);
  EXPECT_EQ(r.repairs, p.repairs);
}

// ---------------------------------------------------------------------------------------------
// Seeds for the mesh_decode fuzz corpus: decoded, then prepared as named.

struct Seed {
  std::string bytes;
  bool prepares;  ///< else refused with kUnprocessable
};

std::map<std::string, Seed> PrepareCorpusFiles() {
  std::map<std::string, Seed> files;
  const TriangleMesh cube = Cube(0.05);
  files["ok_prep_inside_out_cube.obj"] = {WriteObj(Reversed(cube)), true};
  files["ok_prep_soup_cube.obj"] = {WriteObj(Soup(cube)), true};
  TriangleMesh flipped = cube;  // STL welds on reading; one facet reversed, one repeated
  std::swap(flipped.faces[6][1], flipped.faces[6][2]);
  flipped.faces.push_back(flipped.faces[9]);
  files["ok_prep_soup_flipped_facet.stl"] = {WriteStl(flipped, Encoding::kAscii), true};
  TriangleMesh open = cube;
  open.faces.erase(open.faces.begin() + 2);
  files["ok_prep_open_box.obj"] = {WriteObj(open), true};  // the hole is filled
  TriangleMesh sheet = cube;
  sheet.faces.resize(2);
  files["ok_prep_sheet.obj"] = {WriteObj(sheet), false};
  files["ok_prep_cubes_sharing_edge.obj"] = {WriteObj(Merge(cube, Cube(0.05, {0.05, 0.05, 0}))),
                                             false};
  files["ok_prep_cube_with_inner_cube.ply"] = {
      WritePly(Merge(Cube(0.1), Cube(0.02, {0.04, 0.04, 0.04})), Encoding::kAscii), true};
  TriangleMesh sliver = Cube(0.02);
  sliver.vertices.push_back({0.01, 0.01, 0});
  sliver.faces[0] = {2, 8, 0};
  sliver.faces.push_back({8, 1, 0});
  sliver.faces.push_back({1, 8, 2});
  files["ok_prep_zero_area_face.obj"] = {WriteObj(sliver), true};
  return files;
}

TEST(MeshPrepareTest, FuzzCorpusSeedsPrepareAsNamed) {
  const std::filesystem::path dir =
      std::filesystem::path(SOFTGRASP_SOURCE_DIR) / "tests/fuzz/corpus/mesh_decode";
  const char* write = std::getenv("SOFTGRASP_WRITE_FUZZ_CORPUS");
  const auto seeds = PrepareCorpusFiles();
  if (write != nullptr && std::string(write) == "1") {
    for (const auto& [name, seed] : seeds) {
      std::ofstream(dir / name, std::ios::binary) << seed.bytes;
    }
  }
  for (const auto& [name, seed] : seeds) {
    std::ifstream in(dir / name, std::ios::binary);
    ASSERT_TRUE(in) << name << " is missing: run with SOFTGRASP_WRITE_FUZZ_CORPUS=1";
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(bytes, seed.bytes) << name;
    const auto decoded = ReadMesh(bytes);
    ASSERT_TRUE(decoded.ok()) << name << ": " << decoded.error().message;
    const auto prepared = PrepareMesh(decoded.value());
    EXPECT_EQ(prepared.ok(), seed.prepares)
        << name << ": " << (prepared.ok() ? "accepted" : prepared.error().message);
    if (prepared.ok()) {
      ExpectSolid(prepared.value());
      EXPECT_FALSE(prepared.value().repairs.empty()) << name;
    } else {
      EXPECT_EQ(prepared.error().code, ErrorCode::kUnprocessable) << name;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Random small meshes on a coarse grid (repeats, duplicates, collinear points are common): the
// result is a solid or an expected error, never a crash or an internal error.

TEST(MeshPrepareTest, RandomSmallMeshesNeverBreakIt) {
  std::mt19937 rng(17);
  int accepted = 0;
  PrepareOptions options;
  options.unit_scale_m = 0.01;
  options.max_triangles = 40;
  for (int trial = 0; trial < 3000; ++trial) {
    TriangleMesh m;
    const int nv = 4 + static_cast<int>(rng() % 8);
    for (int v = 0; v < nv; ++v) {
      m.vertices.push_back({static_cast<double>(rng() % 3), static_cast<double>(rng() % 3),
                            static_cast<double>(rng() % 3)});
    }
    // Start from a closed mesh now and then, then disturb it.
    if (trial % 3 == 0) {
      m = trial % 2 == 0 ? Cube(2.0) : testing::MakeOctahedron();
    }
    const int extra = static_cast<int>(rng() % 6);
    for (int f = 0; f < extra; ++f) {
      const int n = static_cast<int>(m.vertices.size());
      m.faces.push_back({static_cast<int>(rng() % static_cast<unsigned>(n)),
                         static_cast<int>(rng() % static_cast<unsigned>(n)),
                         static_cast<int>(rng() % static_cast<unsigned>(n))});
    }
    if (!m.faces.empty() && rng() % 2 == 0) {
      auto& f = m.faces[rng() % m.faces.size()];
      std::swap(f[1], f[2]);
    }
    const auto r = PrepareMesh(m, options);
    if (r.ok()) {
      ++accepted;
      ExpectSolid(r.value());
    } else {
      EXPECT_TRUE(r.error().code == ErrorCode::kUnprocessable ||
                  r.error().code == ErrorCode::kTooLarge)
          << r.error().message;
      EXPECT_EQ(r.error().field, "mesh");
    }
  }
  EXPECT_GT(accepted, 100);
}

}  // namespace
}  // namespace softgrasp::mesh
