#pragma once
/// Checks that a triangle mesh is a valid solid boundary: closed, 2-manifold, one piece,
/// consistently and outwardly oriented, and not cutting through itself. The edge, fan and piece
/// checks are combinatorial; the signed volume and the self-intersection test are geometric (the
/// latter with exact predicates, CGAL::Polygon_mesh_processing::self_intersections).

#include <array>
#include <string>
#include <vector>

#include "service/mesh/mesh.h"

namespace softgrasp::mesh {

struct MeshReport {
  bool indices_valid = false;          ///< every face index is in [0, vertices.size())
  bool closed = false;                 ///< every edge borders an even number (>= 2) of faces
  bool edge_manifold = false;          ///< every edge borders exactly two faces
  bool vertex_manifold = false;        ///< the faces around every vertex form a single fan
  bool connected = false;              ///< exactly one piece (faces linked through shared vertices)
  bool consistently_oriented = false;  ///< each edge is traversed as often one way as the other
  bool outward = false;                ///< signed volume > 0 (normals point out)
  double volume = 0.0;                 ///< signed enclosed volume, units^3 (meaningful when closed)
  int num_components = 0;              ///< pieces, counted over referenced vertices
  int num_boundary_edges = 0;          ///< edges with an odd number of faces
  int num_nonmanifold_edges = 0;       ///< edges with more than two faces
  int num_nonmanifold_vertices = 0;    ///< vertices whose faces form more than one fan
  int num_misoriented_edges = 0;       ///< edges traversed one way >= 2 times more than the other
  int num_degenerate_faces = 0;       ///< faces that repeat a vertex index (skipped by edge checks)
  int num_unreferenced_vertices = 0;  ///< vertices no face uses
  int num_nonfinite_vertices = 0;     ///< vertices with a NaN or infinite coordinate
  int euler_characteristic = 0;       ///< V - E + F over referenced vertices (2 for a sphere)
  /// The self-intersection test ran: it was asked for and the mesh has valid indices, finite
  /// coordinates, no repeated-vertex faces, no edge with more than two faces, one fan per vertex
  /// and a consistent orientation (the test needs a halfedge structure; open meshes and several
  /// pieces are fine). Otherwise the fields below stay 0 / false / empty.
  bool self_intersections_checked = false;
  /// Checked, no two faces intersect beyond the vertex or edge they share, and no face has three
  /// collinear vertices (a zero-area face has no normal, and its crossings cannot be tested).
  bool self_intersection_free = false;
  int num_self_intersecting_pairs = 0;  ///< unordered pairs of distinct faces that intersect
  int num_collinear_faces = 0;          ///< faces with three distinct but collinear vertices
  /// The intersecting pairs as face indices {f, g}, f < g, sorted.
  std::vector<std::array<int, 2>> self_intersecting_pairs;
  std::vector<std::string> problems;  ///< one human-readable line per kind of problem found

  /// All checks pass: a closed, 2-manifold, connected, consistently outward-oriented mesh with
  /// positive volume, no degenerate faces, no unreferenced or non-finite vertices, and (when the
  /// self-intersection test was asked for) no self-intersections or zero-area faces.
  bool ok() const { return problems.empty(); }
};

struct MeshCheckOptions {
  /// Run the self-intersection test (bounding-box filter, then exact predicates; ~5 ms for the
  /// ~1,800 faces of a fractal mesh at alpha 0.3, ten times the rest of CheckMesh). Off only where
  /// the faces cannot cross by construction, e.g. facets of one Delaunay triangulation of the
  /// exact input points.
  bool self_intersections = true;
};

/// Checks `mesh`. Never throws on bad data: out-of-range indices are reported (and make every
/// other check false); the self-intersection test only runs on meshes that pass the
/// combinatorial checks (see MeshReport::self_intersections_checked).
MeshReport CheckMesh(const TriangleMesh& mesh, const MeshCheckOptions& options = {});

}  // namespace softgrasp::mesh
