#pragma once
/// Checks that a triangle mesh is a valid solid boundary: closed, 2-manifold, one piece,
/// consistently and outwardly oriented. Purely combinatorial except for the signed volume.

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
  std::vector<std::string> problems;  ///< one human-readable line per kind of problem found

  /// All checks pass: a closed, 2-manifold, connected, consistently outward-oriented mesh with
  /// positive volume, no degenerate faces, no unreferenced or non-finite vertices.
  bool ok() const { return problems.empty(); }
};

/// Checks `mesh`. Never throws on bad data: out-of-range indices are reported (and make every
/// other check false).
MeshReport CheckMesh(const TriangleMesh& mesh);

}  // namespace softgrasp::mesh
