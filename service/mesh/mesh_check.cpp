// Mesh validity checks: sorted half-edges for the edge checks, union-find for fans and pieces,
// CGAL's Polygon Mesh Processing (exact predicates) for self-intersections.
#include "service/mesh/mesh_check.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <iterator>
#include <numeric>
#include <string>
#include <utility>

#include "service/mesh/mesh_topology_internal.h"

namespace softgrasp::mesh {
namespace {

using internal::EdgeKey;
using internal::HalfEdge;
using internal::UnionFind;

std::string EdgeName(const HalfEdge& h) {
  return std::to_string(std::min(h.from, h.to)) + "-" + std::to_string(std::max(h.from, h.to));
}

void AddProblem(MeshReport& r, int count, const std::string& what, const std::string& example) {
  if (count == 0) return;
  std::string line = std::to_string(count) + " " + what;
  if (!example.empty()) line += " (first: " + example + ")";
  r.problems.push_back(std::move(line));
}

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;

struct SelfIntersections {
  bool ran = false;
  std::string failure;                    ///< why it did not run, when it did not
  std::vector<std::array<int, 2>> pairs;  ///< distinct faces (f < g), sorted
  std::vector<int> collinear_faces;       ///< sorted
};

/// Exact self-intersection test of a mesh with valid indices, finite coordinates, no
/// repeated-vertex faces, consistently oriented and 2-manifold (so it forms a halfedge mesh).
/// Two faces intersect when their closed triangles share a point that is not on a vertex or edge
/// both of them use; CGAL filters candidates with bounding boxes and decides each with exact
/// predicates on the double coordinates, so touching counts and near misses do not.
SelfIntersections FindSelfIntersections(const TriangleMesh& mesh) {
  SelfIntersections out;
  SurfaceMesh sm;
  sm.reserve(static_cast<SurfaceMesh::size_type>(mesh.vertices.size()),
             static_cast<SurfaceMesh::size_type>(3 * mesh.faces.size() / 2 + 3),
             static_cast<SurfaceMesh::size_type>(mesh.faces.size()));
  std::vector<SurfaceMesh::Vertex_index> ids;
  ids.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) ids.push_back(sm.add_vertex({p[0], p[1], p[2]}));
  for (const auto& t : mesh.faces) {
    const SurfaceMesh::Face_index f =
        sm.add_face(ids[static_cast<std::size_t>(t[0])], ids[static_cast<std::size_t>(t[1])],
                    ids[static_cast<std::size_t>(t[2])]);
    if (f == SurfaceMesh::null_face()) {
      out.failure = "the faces do not form a halfedge mesh";
      return out;
    }
  }
  // Faces are numbered in the order they were added, so a face index is the input face index.
  std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> found;
  try {
    CGAL::Polygon_mesh_processing::self_intersections(sm, std::back_inserter(found));
  } catch (const std::exception& e) {
    out.failure = e.what();
    return out;
  }
  for (const auto& [a, b] : found) {
    const int f = static_cast<int>(a.idx()), g = static_cast<int>(b.idx());
    if (f == g) {
      out.collinear_faces.push_back(f);  // CGAL reports a zero-area face as (f, f)
    } else {
      out.pairs.push_back({std::min(f, g), std::max(f, g)});
    }
  }
  std::sort(out.pairs.begin(), out.pairs.end());
  out.pairs.erase(std::unique(out.pairs.begin(), out.pairs.end()), out.pairs.end());
  std::sort(out.collinear_faces.begin(), out.collinear_faces.end());
  out.collinear_faces.erase(std::unique(out.collinear_faces.begin(), out.collinear_faces.end()),
                            out.collinear_faces.end());
  out.ran = true;
  return out;
}

/// Indices first: nothing else is meaningful without them. Returns false, with the problem
/// noted, when an index is out of range or there are no faces.
bool CheckIndices(const TriangleMesh& mesh, MeshReport& r) {
  const int nv = static_cast<int>(mesh.vertices.size());
  int bad_index_faces = 0;
  std::string first_bad;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    for (const int v : mesh.faces[f]) {
      if (v < 0 || v >= nv) {
        if (bad_index_faces++ == 0) first_bad = "face " + std::to_string(f);
        break;
      }
    }
  }
  r.indices_valid = bad_index_faces == 0 && mesh.vertices.size() <= 0x7fffffffu;
  if (!r.indices_valid) {
    AddProblem(r, bad_index_faces, "faces with a vertex index out of range", first_bad);
    return false;
  }
  if (mesh.faces.empty()) {
    r.problems.push_back("the mesh has no faces");
    return false;
  }
  return true;
}

void CountNonFiniteVertices(const TriangleMesh& mesh, MeshReport& r) {
  std::string example;
  for (int v = 0; v < static_cast<int>(mesh.vertices.size()); ++v) {
    const auto& p = mesh.vertices[static_cast<std::size_t>(v)];
    if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) {
      if (r.num_nonfinite_vertices++ == 0) example = "vertex " + std::to_string(v);
    }
  }
  AddProblem(r, r.num_nonfinite_vertices, "vertices with a non-finite coordinate", example);
}

bool IsDegenerate(const std::array<int, 3>& t) {
  return t[0] == t[1] || t[1] == t[2] || t[2] == t[0];
}

/// Half-edges of non-degenerate faces, grouped by undirected edge (sorted by key, then face);
/// counts the degenerate faces.
std::vector<HalfEdge> SortedHalfEdges(const TriangleMesh& mesh, MeshReport& r) {
  std::vector<HalfEdge> half;
  half.reserve(3 * mesh.faces.size());
  std::string example;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    if (IsDegenerate(t)) {
      if (r.num_degenerate_faces++ == 0) example = "face " + std::to_string(f);
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const int a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
      half.push_back({EdgeKey(a, b), a, b, static_cast<int>(f)});
    }
  }
  AddProblem(r, r.num_degenerate_faces, "degenerate faces (a repeated vertex)", example);
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  return half;
}

/// Counts boundary, non-manifold and misoriented edges among the sorted half-edges, and joins
/// the corners (face, local vertex) of the same vertex across 2-face edges: each vertex must end
/// up with one group (one fan). Returns the number of edges.
int CheckEdges(const TriangleMesh& mesh, const std::vector<HalfEdge>& half, UnionFind& corners,
               MeshReport& r) {
  auto corner = [&](int face, int v) {
    const auto& t = mesh.faces[static_cast<std::size_t>(face)];
    const int k = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
    return static_cast<std::size_t>(face) * 3 + static_cast<std::size_t>(k);
  };
  std::string ex_boundary, ex_nonmanifold, ex_orient;
  int num_edges = 0;
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i;
    int forward = 0;
    while (j < half.size() && half[j].key == half[i].key) {
      if (half[j].from < half[j].to) ++forward;
      ++j;
    }
    const int count = static_cast<int>(j - i);
    ++num_edges;
    if (count % 2 == 1) {
      if (r.num_boundary_edges++ == 0) ex_boundary = EdgeName(half[i]);
    }
    if (count > 2) {
      if (r.num_nonmanifold_edges++ == 0) ex_nonmanifold = EdgeName(half[i]);
    }
    if (std::abs(2 * forward - count) > 1) {  // as balanced as the count allows
      if (r.num_misoriented_edges++ == 0) ex_orient = EdgeName(half[i]);
    }
    if (count == 2) {
      const HalfEdge& e0 = half[i];
      const HalfEdge& e1 = half[i + 1];
      corners.Union(corner(e0.face, e0.from), corner(e1.face, e0.from));
      corners.Union(corner(e0.face, e0.to), corner(e1.face, e0.to));
    }
    i = j;
  }
  AddProblem(r, r.num_boundary_edges, "boundary edges with an odd number of faces: not closed",
             ex_boundary);
  AddProblem(r, r.num_nonmanifold_edges, "edges with more than two faces: not 2-manifold",
             ex_nonmanifold);
  AddProblem(r, r.num_misoriented_edges,
             "edges not traversed once in each direction: inconsistent orientation", ex_orient);
  return num_edges;
}

/// Fans per vertex: counts the vertices whose corners fall into more than one group.
void CheckVertexFans(const TriangleMesh& mesh, UnionFind& corners, MeshReport& r) {
  const std::size_t nv = mesh.vertices.size();
  std::vector<std::size_t> fan_root(nv, SIZE_MAX);
  std::vector<char> extra_fan(nv, 0);
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    if (IsDegenerate(t)) continue;
    for (std::size_t k = 0; k < 3; ++k) {
      const auto v = static_cast<std::size_t>(t[k]);
      const std::size_t root = corners.Find(3 * f + k);
      if (fan_root[v] == SIZE_MAX) {
        fan_root[v] = root;
      } else if (fan_root[v] != root) {
        extra_fan[v] = 1;
      }
    }
  }
  std::string example;
  for (int v = 0; v < static_cast<int>(nv); ++v) {
    if (extra_fan[static_cast<std::size_t>(v)] && r.num_nonmanifold_vertices++ == 0) {
      example = "vertex " + std::to_string(v);
    }
  }
  AddProblem(r, r.num_nonmanifold_vertices,
             "vertices whose faces form several fans: not 2-manifold", example);
}

/// Pieces: vertices joined by faces. Counts the unreferenced vertices and the pieces; returns
/// the number of referenced vertices.
int CountPieces(const TriangleMesh& mesh, MeshReport& r) {
  const int nv = static_cast<int>(mesh.vertices.size());
  std::vector<char> used(static_cast<std::size_t>(nv), 0);
  for (const auto& t : mesh.faces) {
    for (const int v : t) used[static_cast<std::size_t>(v)] = 1;
  }
  UnionFind pieces(static_cast<std::size_t>(nv));
  for (const auto& t : mesh.faces) {
    pieces.Union(static_cast<std::size_t>(t[0]), static_cast<std::size_t>(t[1]));
    pieces.Union(static_cast<std::size_t>(t[1]), static_cast<std::size_t>(t[2]));
  }
  int referenced = 0;
  std::string example;
  for (int v = 0; v < nv; ++v) {
    const auto sv = static_cast<std::size_t>(v);
    if (!used[sv]) {
      if (r.num_unreferenced_vertices++ == 0) example = "vertex " + std::to_string(v);
      continue;
    }
    ++referenced;
    if (pieces.Find(sv) == sv) ++r.num_components;
  }
  AddProblem(r, r.num_unreferenced_vertices, "unreferenced vertices", example);
  if (r.num_components > 1) {
    r.problems.push_back(std::to_string(r.num_components) + " separate pieces: not connected");
  }
  return referenced;
}

/// Signed volume, relative to the first vertex for precision.
double SignedVolume(const TriangleMesh& mesh) {
  const auto& o = mesh.vertices[static_cast<std::size_t>(mesh.faces[0][0])];
  double six_volume = 0.0;
  for (const auto& t : mesh.faces) {
    const auto& p = mesh.vertices[static_cast<std::size_t>(t[0])];
    const auto& q = mesh.vertices[static_cast<std::size_t>(t[1])];
    const auto& s = mesh.vertices[static_cast<std::size_t>(t[2])];
    const double a[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
    const double b[3] = {q[0] - o[0], q[1] - o[1], q[2] - o[2]};
    const double c[3] = {s[0] - o[0], s[1] - o[1], s[2] - o[2]};
    six_volume += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                  a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  return six_volume / 6.0;
}

/// Runs FindSelfIntersections and notes what it found, or why it could not run.
void CheckSelfIntersections(const TriangleMesh& mesh, MeshReport& r) {
  const SelfIntersections si = FindSelfIntersections(mesh);
  if (!si.ran) {
    r.problems.push_back("the self-intersection test could not run: " + si.failure);
    return;
  }
  r.self_intersections_checked = true;
  r.num_self_intersecting_pairs = static_cast<int>(si.pairs.size());
  r.num_collinear_faces = static_cast<int>(si.collinear_faces.size());
  r.self_intersecting_pairs = si.pairs;
  r.self_intersection_free = si.pairs.empty() && si.collinear_faces.empty();
  AddProblem(r, r.num_self_intersecting_pairs,
             "pairs of faces that cut through each other: self-intersecting",
             si.pairs.empty() ? std::string()
                              : "faces " + std::to_string(si.pairs[0][0]) + " and " +
                                    std::to_string(si.pairs[0][1]));
  AddProblem(
      r, r.num_collinear_faces, "faces with three collinear vertices: zero area",
      si.collinear_faces.empty() ? std::string() : "face " + std::to_string(si.collinear_faces[0]));
}

}  // namespace

MeshReport CheckMesh(const TriangleMesh& mesh, const MeshCheckOptions& options) {
  MeshReport r;
  if (!CheckIndices(mesh, r)) return r;
  CountNonFiniteVertices(mesh, r);
  const std::vector<HalfEdge> half = SortedHalfEdges(mesh, r);
  UnionFind corners(3 * mesh.faces.size());
  const int num_edges = CheckEdges(mesh, half, corners, r);
  CheckVertexFans(mesh, corners, r);
  const int referenced = CountPieces(mesh, r);
  r.volume = SignedVolume(mesh);

  r.closed = r.num_boundary_edges == 0;
  r.edge_manifold = r.num_boundary_edges == 0 && r.num_nonmanifold_edges == 0;
  r.vertex_manifold = r.num_nonmanifold_vertices == 0;
  r.connected = r.num_components == 1;
  r.consistently_oriented = r.num_misoriented_edges == 0;
  r.outward = r.volume > 0.0 && std::isfinite(r.volume);
  if (!r.outward) {
    r.problems.push_back("signed volume " + std::to_string(r.volume) +
                         " is not positive: faces point inward or the mesh is flat");
  }
  r.euler_characteristic = referenced - num_edges + static_cast<int>(mesh.faces.size());

  // Self-intersections need a halfedge mesh: only when the combinatorial checks allow one.
  // Open meshes (boundary edges) and several pieces are fine for the test itself.
  if (options.self_intersections && r.num_nonfinite_vertices == 0 && r.num_degenerate_faces == 0 &&
      r.num_nonmanifold_edges == 0 && r.num_nonmanifold_vertices == 0 &&
      r.num_misoriented_edges == 0) {
    CheckSelfIntersections(mesh, r);
  }
  return r;
}

}  // namespace softgrasp::mesh
