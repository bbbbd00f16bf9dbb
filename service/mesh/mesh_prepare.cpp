// Mesh preparation for uploads: sorted welding, face dedup by sorted vertex triple, sorted
// half-edges for the edge checks, union-find for vertex fans, a breadth-first walk for the
// orientation and the pieces, CGAL's Side_of_triangle_mesh for pieces inside the main one,
// solid second moments (Eigen) for the principal axes, edge flips for zero-area faces.
#include "service/mesh/mesh_prepare.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/box_intersection_d.h>

#include <Eigen/Dense>
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <deque>
#include <exception>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "service/mesh/hole_filling_internal.h"
#include "service/mesh/mesh_topology_internal.h"

namespace softgrasp::mesh {
namespace {

using core::ErrorCode;
using core::MakeError;
using Vec3 = std::array<double, 3>;
using Face = std::array<int, 3>;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;

/// Coordinates beyond this (metres, after the unit conversion) are refused: no graspable object
/// is a thousand kilometres from its origin, and products of such numbers stay far from overflow.
constexpr double kMaxCoordinateM = 1e6;
/// A solid whose volume is below this fraction of its largest extent cubed encloses no volume.
constexpr double kFlatVolumeFraction = 1e-12;
/// Principal moments closer than this, relative to the largest, count as equal.
constexpr double kEqualMomentsTolerance = 1e-9;

core::Error Refuse(std::string message) {
  return MakeError(ErrorCode::kUnprocessable, std::move(message), "mesh");
}

std::string Num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

std::string Point(const Vec3& p) {
  return "(" + Num(p[0]) + ", " + Num(p[1]) + ", " + Num(p[2]) + ")";
}

/// "1 face", "3 faces".
std::string Count(long long n, const std::string& one, const std::string& many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

/// "a", "a and b", "a, b and c".
std::string JoinAnd(const std::vector<std::string>& parts) {
  std::string out;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (i > 0) out += i + 1 == parts.size() ? " and " : ", ";
    out += parts[i];
  }
  return out;
}

using internal::EdgeKey;
using internal::FillHoles;
using internal::HalfEdge;
using internal::HoleFillResult;
using internal::Percent;
using internal::UnionFind;

std::uint64_t DirectedKey(int from, int to) {
  return static_cast<std::uint64_t>(from) << 32 | static_cast<std::uint64_t>(to);
}

std::size_t Z(int i) { return static_cast<std::size_t>(i); }

/// Six times the signed volume of the tetrahedron (o, p, q, s).
double SixVolume(const Vec3& o, const Vec3& p, const Vec3& q, const Vec3& s) {
  const double a[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
  const double b[3] = {q[0] - o[0], q[1] - o[1], q[2] - o[2]};
  const double c[3] = {s[0] - o[0], s[1] - o[1], s[2] - o[2]};
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/// The corner (0..2) of collinear face `t` that lies between the other two, by the coordinate
/// along which the three spread most (distinct points on a line are strictly ordered along it);
/// 3 when none does.
std::size_t MiddleCorner(const TriangleMesh& m, const Face& t) {
  std::size_t axis = 0;
  double spread = -1.0;
  for (std::size_t k = 0; k < 3; ++k) {
    const double lo =
        std::min({m.vertices[Z(t[0])][k], m.vertices[Z(t[1])][k], m.vertices[Z(t[2])][k]});
    const double hi =
        std::max({m.vertices[Z(t[0])][k], m.vertices[Z(t[1])][k], m.vertices[Z(t[2])][k]});
    if (hi - lo > spread) {
      spread = hi - lo;
      axis = k;
    }
  }
  std::size_t mid = 3;
  for (std::size_t k = 0; k < 3; ++k) {
    const double x = m.vertices[Z(t[k])][axis];
    const double y = m.vertices[Z(t[(k + 1) % 3])][axis];
    const double z = m.vertices[Z(t[(k + 2) % 3])][axis];
    if ((y < x && x < z) || (z < x && x < y)) mid = k;
  }
  return mid;
}

/// Removes faces with three distinct collinear vertices (zero area; exact predicate) from a
/// closed, consistently oriented 2-manifold mesh. Such a face (a, m, c), m between a and c, is
/// flipped with its neighbour (a, c, d) across the long edge into (a, m, d) and (m, c, d): the
/// two new triangles tile the neighbour exactly, so the surface is unchanged. Not possible when
/// the edge m-d already exists. Sets `removed` to how many went and returns how many are left.
int FlipCollinearFaces(TriangleMesh& m, int* removed, int* first_left) {
  auto point = [&](int v) {
    const Vec3& p = m.vertices[Z(v)];
    return Kernel::Point_3(p[0], p[1], p[2]);
  };
  auto collinear = [&](const Face& t) {
    return CGAL::collinear(point(t[0]), point(t[1]), point(t[2]));
  };
  std::deque<int> queue;
  for (std::size_t f = 0; f < m.faces.size(); ++f) {
    if (collinear(m.faces[f])) queue.push_back(static_cast<int>(f));
  }
  if (queue.empty()) return 0;
  const auto initial = static_cast<int>(queue.size());
  std::unordered_map<std::uint64_t, int> edge_face;
  edge_face.reserve(3 * m.faces.size());
  for (std::size_t f = 0; f < m.faces.size(); ++f) {
    const Face& t = m.faces[f];
    for (std::size_t k = 0; k < 3; ++k) {
      edge_face[DirectedKey(t[k], t[(k + 1) % 3])] = static_cast<int>(f);
    }
  }
  auto has_edge = [&](int a, int b) {
    return edge_face.count(DirectedKey(a, b)) > 0 || edge_face.count(DirectedKey(b, a)) > 0;
  };
  auto set_face = [&](int f, const Face& t) {
    const Face old = m.faces[Z(f)];
    for (std::size_t k = 0; k < 3; ++k) edge_face.erase(DirectedKey(old[k], old[(k + 1) % 3]));
    m.faces[Z(f)] = t;
  };
  auto add_edges = [&](int f) {
    const Face& t = m.faces[Z(f)];
    for (std::size_t k = 0; k < 3; ++k) edge_face[DirectedKey(t[k], t[(k + 1) % 3])] = f;
  };
  std::size_t budget = 8 * queue.size() + 64;  // a flip onto a neighbour that is itself
                                               // collinear leaves two collinear faces
  while (!queue.empty() && budget-- > 0) {
    const int f = queue.front();
    queue.pop_front();
    const Face t = m.faces[Z(f)];
    if (!collinear(t)) continue;
    const std::size_t mid = MiddleCorner(m, t);
    if (mid == 3) continue;
    const int a = t[(mid + 2) % 3], mv = t[mid], c = t[(mid + 1) % 3];
    const auto it = edge_face.find(DirectedKey(a, c));
    if (it == edge_face.end()) continue;
    const int g = it->second;
    const Face u = m.faces[Z(g)];
    const std::size_t ka = u[0] == a ? 0 : (u[1] == a ? 1 : 2);
    if (u[ka] != a || u[(ka + 1) % 3] != c) continue;
    const int d = u[(ka + 2) % 3];
    if (d == mv || has_edge(mv, d)) continue;
    set_face(f, {a, mv, d});
    set_face(g, {mv, c, d});
    add_edges(f);
    add_edges(g);
    queue.push_back(f);
    queue.push_back(g);
  }
  int left = 0;
  for (std::size_t f = 0; f < m.faces.size(); ++f) {
    if (collinear(m.faces[f]) && left++ == 0) *first_left = static_cast<int>(f);
  }
  *removed = initial - left;  // a flip never adds a collinear face
  return left;
}

core::Error CollinearRefusal(int left, const Vec3& first_file_point) {
  return Refuse(Count(left, "face has", "faces have") +
                " three vertices on a line (zero area) and cannot be removed without opening the "
                "mesh, first at " +
                Point(first_file_point));
}

/// The input coordinates times `scale`.
std::vector<Vec3> ScaledPositions(const TriangleMesh& in, double scale) {
  std::vector<Vec3> pos(in.vertices.size());
  for (std::size_t i = 0; i < in.vertices.size(); ++i) {
    for (std::size_t k = 0; k < 3; ++k) pos[i][k] = in.vertices[i][k] * scale;
  }
  return pos;
}

/// The used input vertices, each welded onto the first of those at its position.
struct Welding {
  std::vector<int> rep;       ///< vertex each input vertex is welded onto; -1 when unused
  std::size_t positions = 0;  ///< distinct positions among the used vertices
};

/// Welds used vertices with equal coordinates (0 and -0 are equal) onto the lowest index.
Welding WeldVertices(const TriangleMesh& in, const std::vector<Vec3>& pos, RepairCounts& counts) {
  const std::size_t nv = in.vertices.size();
  std::vector<char> used(nv, 0);
  for (const Face& t : in.faces) {
    for (const int v : t) used[Z(v)] = 1;
  }
  std::vector<int> order;
  order.reserve(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    if (used[i]) {
      order.push_back(static_cast<int>(i));
    } else {
      ++counts.unused_vertices;
    }
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return pos[Z(a)] < pos[Z(b)]; });
  Welding w;
  w.rep.assign(nv, -1);
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j < order.size() && pos[Z(order[j])] == pos[Z(order[i])]) {
      w.rep[Z(order[j++])] = order[i];
    }
    ++w.positions;
    i = j;
  }
  counts.welded_vertices = static_cast<int>(order.size() - w.positions);
  return w;
}

/// A face on the welded vertices, keyed by its sorted vertex triple.
struct KeyedFace {
  Face sorted;
  int face;
  bool even;  ///< same cyclic order as `sorted`
};

/// The input faces on the welded vertices (`welded`, one per input face) and, sorted by their
/// vertex triple and then by face, those that name three distinct vertices.
std::vector<KeyedFace> KeyWeldedFaces(const TriangleMesh& in, const std::vector<int>& rep,
                                      std::vector<Face>& welded, RepairCounts& counts) {
  const std::size_t nf = in.faces.size();
  welded.assign(nf, Face{});
  std::vector<KeyedFace> keyed;
  keyed.reserve(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const Face& t0 = in.faces[f];
    const Face t = {rep[Z(t0[0])], rep[Z(t0[1])], rep[Z(t0[2])]};
    welded[f] = t;
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
      ++counts.degenerate_faces;
      continue;
    }
    Face s = t;
    std::sort(s.begin(), s.end());
    const std::size_t first = t[0] == s[0] ? 0 : (t[1] == s[0] ? 1 : 2);
    keyed.push_back({s, static_cast<int>(f), t[(first + 1) % 3] == s[1]});
  }
  std::sort(keyed.begin(), keyed.end(), [](const KeyedFace& x, const KeyedFace& y) {
    if (x.sorted[0] != y.sorted[0]) return x.sorted[0] < y.sorted[0];
    if (x.sorted[1] != y.sorted[1]) return x.sorted[1] < y.sorted[1];
    if (x.sorted[2] != y.sorted[2]) return x.sorted[2] < y.sorted[2];
    return x.face < y.face;
  });
  return keyed;
}

/// Keeps one face of each group of `keyed` on the same three vertices that runs more often one
/// way than the other, dropping the rest; returns the groups (ranges of `keyed`) that run as
/// often one way as the other, left for KeepOneSideOfTwoSidedFaces.
std::vector<std::pair<std::size_t, std::size_t>> KeepOneFacePerUnbalancedGroup(
    const std::vector<KeyedFace>& keyed, std::vector<char>& keep, RepairCounts& counts) {
  std::vector<std::pair<std::size_t, std::size_t>> balanced;
  for (std::size_t i = 0; i < keyed.size();) {
    std::size_t j = i;
    int even = 0, odd = 0;
    while (j < keyed.size() && keyed[j].sorted == keyed[i].sorted) {
      (keyed[j].even ? even : odd) += 1;
      ++j;
    }
    if (even == odd) {
      balanced.emplace_back(i, j);
    } else {
      counts.opposite_face_pairs += std::min(even, odd);
      counts.duplicate_faces += std::abs(even - odd) - 1;
      const bool keep_even = even > odd;
      for (std::size_t k = i; k < j; ++k) {
        if (keyed[k].even == keep_even) {
          keep[Z(keyed[k].face)] = 1;
          break;
        }
      }
    }
    i = j;
  }
  return balanced;
}

/// A balanced group whose three edges each have an odd number of other faces is one side of the
/// solid with a reversed copy (a face exported two-sided): dropping both would open a hole, so
/// one is kept (the orientation step turns it the right way). Other balanced groups are dropped.
void KeepOneSideOfTwoSidedFaces(const std::vector<KeyedFace>& keyed,
                                const std::vector<std::pair<std::size_t, std::size_t>>& balanced,
                                const std::vector<Face>& welded, std::vector<char>& keep,
                                RepairCounts& counts) {
  if (balanced.empty()) return;
  std::unordered_map<std::uint64_t, int> edge_faces;
  edge_faces.reserve(3 * welded.size());
  for (std::size_t f = 0; f < welded.size(); ++f) {
    if (!keep[f]) continue;
    const Face& t = welded[f];
    for (std::size_t k = 0; k < 3; ++k) ++edge_faces[EdgeKey(t[k], t[(k + 1) % 3])];
  }
  auto odd_edge = [&](int a, int b) {
    const auto it = edge_faces.find(EdgeKey(a, b));
    return it != edge_faces.end() && it->second % 2 == 1;
  };
  for (const auto& [i, j] : balanced) {
    const Face& s = keyed[i].sorted;
    const int pairs = static_cast<int>(j - i) / 2;
    if (odd_edge(s[0], s[1]) && odd_edge(s[1], s[2]) && odd_edge(s[0], s[2])) {
      keep[Z(keyed[i].face)] = 1;
      counts.duplicate_faces += 2 * pairs - 1;
      for (std::size_t k = 0; k < 3; ++k) ++edge_faces[EdgeKey(s[k], s[(k + 1) % 3])];
    } else {
      counts.opposite_face_pairs += pairs;
    }
  }
}

/// The faces on the welded vertices, without those that name a vertex twice, and with faces on
/// the same three vertices settled. Same orientation: a duplicate, one is kept. Opposite
/// orientations: a zero-thickness wall (two closed cells sharing a side, or a sheet modelled with
/// both sides); such a pair adds nothing to the volume and keeps every edge's face count even, so
/// it is dropped, pair by pair.
std::vector<Face> SettleCoincidentFaces(const TriangleMesh& in, const std::vector<int>& rep,
                                        RepairCounts& counts) {
  std::vector<Face> welded;
  const std::vector<KeyedFace> keyed = KeyWeldedFaces(in, rep, welded, counts);
  std::vector<char> keep(welded.size(), 0);
  const auto balanced = KeepOneFacePerUnbalancedGroup(keyed, keep, counts);
  KeepOneSideOfTwoSidedFaces(keyed, balanced, welded, keep, counts);
  std::vector<Face> faces;
  for (std::size_t f = 0; f < welded.size(); ++f) {
    if (keep[f]) faces.push_back(welded[f]);
  }
  return faces;
}

core::Error NoFacesLeftRefusal(const RepairCounts& counts) {
  std::vector<std::string> dropped;
  if (counts.degenerate_faces > 0) {
    dropped.push_back(Count(counts.degenerate_faces, "face that names a vertex twice",
                            "faces that name a vertex twice"));
  }
  if (counts.duplicate_faces > 0) {
    dropped.push_back(Count(counts.duplicate_faces, "duplicate face", "duplicate faces"));
  }
  if (counts.opposite_face_pairs > 0) {
    dropped.push_back(Count(counts.opposite_face_pairs, "pair of coincident faces facing",
                            "pairs of coincident faces facing") +
                      " opposite ways");
  }
  return Refuse("no faces are left after dropping " + JoinAnd(dropped) +
                ": the mesh encloses no volume (a flat sheet modelled with both sides?)");
}

/// Renumbers `faces` onto the vertices they use, in the order of their old indices (below
/// `num_vertices`); returns the old index of each new vertex.
std::vector<int> CompactVertices(std::vector<Face>& faces, std::size_t num_vertices) {
  std::vector<int> new_id(num_vertices, -1);
  for (const Face& t : faces) {
    for (const int v : t) new_id[Z(v)] = 0;
  }
  std::vector<int> old_id;
  for (std::size_t i = 0; i < num_vertices; ++i) {
    if (new_id[i] == 0) {
      new_id[i] = static_cast<int>(old_id.size());
      old_id.push_back(static_cast<int>(i));
    }
  }
  for (Face& t : faces) {
    for (int& v : t) v = new_id[Z(v)];
  }
  return old_id;
}

/// A vertex of the compacted mesh quoted at its file coordinates, for messages.
struct FilePoints {
  const TriangleMesh& in;
  const std::vector<int>& source;  ///< input vertex of each vertex
  std::string operator()(int v) const { return Point(in.vertices[Z(source[Z(v)])]); }
};

/// Small holes: closed with triangles between their boundary vertices, or left for the refusal
/// of open meshes, which then says why they were not filled. Returns that reason (empty when
/// every hole was filled, there was none, or filling is off).
std::string FillSmallHoles(const std::vector<Vec3>& pos, const std::vector<int>& source,
                           const PrepareOptions& options, std::vector<Face>& faces,
                           RepairCounts& counts) {
  if (options.fill_hole_max_edges <= 0) return "";
  std::vector<Vec3> kept_pos(source.size());
  for (std::size_t v = 0; v < source.size(); ++v) kept_pos[v] = pos[Z(source[v])];
  const HoleFillResult filled = FillHoles(
      kept_pos, faces, {options.fill_hole_max_edges, options.fill_hole_max_area_fraction});
  counts.filled_holes = filled.holes;
  counts.filled_hole_edges = filled.boundary_edges;
  counts.hole_faces_added = filled.new_faces;
  counts.filled_area_fraction = filled.area_fraction;
  return filled.not_filled;
}

/// The faces' directed edges, sorted by undirected edge and then by face.
std::vector<HalfEdge> SortedHalfEdges(const std::vector<Face>& faces) {
  std::vector<HalfEdge> half;
  half.reserve(3 * faces.size());
  for (int f = 0; f < static_cast<int>(faces.size()); ++f) {
    const Face& t = faces[Z(f)];
    for (std::size_t k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      half.push_back({EdgeKey(a, b), a, b, f});
    }
  }
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  return half;
}

core::Error OpenOrNonManifoldRefusal(int boundary, const std::string& boundary_example,
                                     const std::string& holes_not_filled, int nonmanifold,
                                     const std::string& nonmanifold_example) {
  std::vector<std::string> parts;
  if (boundary > 0) {
    parts.push_back(
        "the mesh is not closed: " + Count(boundary, "boundary edge", "boundary edges") +
        " (edges with a single face, or an odd number: holes in the surface), "
        "first " +
        boundary_example + (holes_not_filled.empty() ? "" : "; not filled: " + holes_not_filled));
  }
  if (nonmanifold > 0) {
    parts.push_back("the mesh is not 2-manifold: " + Count(nonmanifold, "edge is", "edges are") +
                    " shared by more than two faces, first " + nonmanifold_example);
  }
  std::string message = parts[0];
  for (std::size_t i = 1; i < parts.size(); ++i) message += "; " + parts[i];
  return Refuse(message);
}

/// A face's neighbour across one of its edges.
struct Neighbour {
  int face = -1;
  bool same_direction = false;  ///< both faces run along the shared edge the same way
};

/// How the faces of a closed, edge-manifold mesh join across their edges.
struct EdgeAdjacency {
  std::vector<Neighbour> adjacent;  ///< three per face: face f's at 3 f .. 3 f + 2
  UnionFind corners;                ///< corners (3 face + k) joined across the edges they share
};

/// Edges: each must have exactly two faces; refuses boundary and non-manifold edges, quoting why
/// holes were not filled.
core::Result<EdgeAdjacency> JoinFacesAcrossEdges(const std::vector<Face>& faces,
                                                 const FilePoints& at,
                                                 const std::string& holes_not_filled) {
  const std::vector<HalfEdge> half = SortedHalfEdges(faces);
  EdgeAdjacency joined{std::vector<Neighbour>(3 * faces.size()), UnionFind(3 * faces.size())};
  std::vector<int> num_adjacent(faces.size(), 0);
  auto corner = [&](int face, int v) {
    const Face& t = faces[Z(face)];
    return Z(face) * 3 + (t[0] == v ? 0 : (t[1] == v ? 1 : 2));
  };
  int boundary = 0, nonmanifold = 0;
  std::string boundary_example, nonmanifold_example;
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i;
    while (j < half.size() && half[j].key == half[i].key) ++j;
    const std::size_t count = j - i;
    auto example = [&] { return "between " + at(half[i].from) + " and " + at(half[i].to); };
    if (count % 2 == 1 && boundary++ == 0) boundary_example = example();
    if (count > 2 && nonmanifold++ == 0) nonmanifold_example = example();
    if (count == 2) {
      const HalfEdge& e0 = half[i];
      const HalfEdge& e1 = half[i + 1];
      joined.corners.Union(corner(e0.face, e0.from), corner(e1.face, e0.from));
      joined.corners.Union(corner(e0.face, e0.to), corner(e1.face, e0.to));
      const bool same = e0.from == e1.from;
      joined.adjacent[Z(e0.face) * 3 + Z(num_adjacent[Z(e0.face)]++)] = {e1.face, same};
      joined.adjacent[Z(e1.face) * 3 + Z(num_adjacent[Z(e1.face)]++)] = {e0.face, same};
    }
    i = j;
  }
  if (boundary > 0 || nonmanifold > 0) {
    return OpenOrNonManifoldRefusal(boundary, boundary_example, holes_not_filled, nonmanifold,
                                    nonmanifold_example);
  }
  return joined;
}

/// Vertex fans: the faces around each vertex must form one fan.
std::optional<core::Error> CheckVertexFans(const std::vector<Face>& faces, std::size_t num_vertices,
                                           UnionFind& corners, const FilePoints& at) {
  std::vector<std::size_t> fan_root(num_vertices, SIZE_MAX);
  int pinched = 0;
  std::vector<char> counted(num_vertices, 0);
  std::string pinched_example;
  for (int f = 0; f < static_cast<int>(faces.size()); ++f) {
    for (std::size_t k = 0; k < 3; ++k) {
      const auto v = Z(faces[Z(f)][k]);
      const std::size_t root = corners.Find(Z(f) * 3 + k);
      if (fan_root[v] == SIZE_MAX) {
        fan_root[v] = root;
      } else if (fan_root[v] != root && !counted[v]) {
        counted[v] = 1;
        if (pinched++ == 0) pinched_example = at(static_cast<int>(v));
      }
    }
  }
  if (pinched == 0) return std::nullopt;
  return Refuse("the mesh is not 2-manifold: " + Count(pinched, "vertex joins", "vertices join") +
                " separate sheets of surface that touch only there, first at " + pinched_example);
}

/// The connected pieces of the surface, each oriented consistently.
struct Pieces {
  std::vector<int> piece;  ///< of each face
  std::vector<char> flip;  ///< whether a face is reversed to agree with its piece
  std::vector<int> seeds;  ///< the first face of each piece
};

/// Orientation and pieces: walk across edges; a neighbour that runs along the shared edge the
/// same way must be flipped relative to this face.
core::Result<Pieces> OrientPieces(const std::vector<Face>& faces,
                                  const std::vector<Neighbour>& adjacent, const FilePoints& at) {
  const int n = static_cast<int>(faces.size());
  Pieces p;
  p.piece.assign(faces.size(), -1);
  p.flip.assign(faces.size(), 0);
  std::vector<int> queue;
  queue.reserve(faces.size());
  bool one_sided = false;
  int one_sided_face = -1;
  for (int seed = 0; seed < n; ++seed) {
    if (p.piece[Z(seed)] != -1) continue;
    const int id = static_cast<int>(p.seeds.size());
    p.seeds.push_back(seed);
    p.piece[Z(seed)] = id;
    queue.assign(1, seed);
    for (std::size_t h = 0; h < queue.size(); ++h) {
      const int f = queue[h];
      for (std::size_t k = 0; k < 3; ++k) {
        const Neighbour& g = adjacent[Z(f) * 3 + k];
        const char want = static_cast<char>(p.flip[Z(f)] ^ (g.same_direction ? 1 : 0));
        if (p.piece[Z(g.face)] == -1) {
          p.piece[Z(g.face)] = id;
          p.flip[Z(g.face)] = want;
          queue.push_back(g.face);
        } else if (p.flip[Z(g.face)] != want && !one_sided) {
          one_sided = true;
          one_sided_face = f;
        }
      }
    }
  }
  if (one_sided) {
    return Refuse(
        "the surface cannot be oriented consistently: it is one-sided (like a Klein bottle), "
        "which a closed surface can only be if it cuts through itself; first near " +
        at(faces[Z(one_sided_face)][0]));
  }
  return p;
}

/// Each piece outwards (positive volume), measured from a vertex of its own: flips the pieces
/// with a negative volume, then reverses every flipped face. Returns six times each piece's
/// (positive) volume.
std::vector<double> TurnPiecesOutwards(const std::vector<Vec3>& pos, const std::vector<int>& source,
                                       std::vector<Face>& faces, Pieces& pieces) {
  const int n = static_cast<int>(faces.size());
  std::vector<double> six(pieces.seeds.size(), 0.0);
  for (int f = 0; f < n; ++f) {
    const Face& t = faces[Z(f)];
    const int piece = pieces.piece[Z(f)];
    const Vec3& o = pos[Z(source[Z(faces[Z(pieces.seeds[Z(piece)])][0])])];
    const double v =
        SixVolume(o, pos[Z(source[Z(t[0])])], pos[Z(source[Z(t[1])])], pos[Z(source[Z(t[2])])]);
    six[Z(piece)] += pieces.flip[Z(f)] ? -v : v;
  }
  for (std::size_t p = 0; p < six.size(); ++p) {
    if (six[p] < 0.0) {
      six[p] = -six[p];
      for (int f = 0; f < n; ++f) {
        if (pieces.piece[Z(f)] == static_cast<int>(p)) pieces.flip[Z(f)] ^= 1;
      }
    }
  }
  for (int f = 0; f < n; ++f) {
    if (pieces.flip[Z(f)]) std::swap(faces[Z(f)][1], faces[Z(f)][2]);
  }
  return six;
}

/// Which pieces lie entirely inside `main_piece` (every vertex strictly inside it, by CGAL's
/// Side_of_triangle_mesh); none when that cannot be told.
std::vector<char> PiecesInsideMain(const std::vector<Vec3>& pos, const std::vector<int>& source,
                                   const std::vector<Face>& faces, const Pieces& pieces,
                                   std::size_t main_piece) {
  const std::size_t nvk = source.size();
  const std::size_t num_pieces = pieces.seeds.size();
  std::vector<int> vertex_piece(nvk, -1);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    for (const int v : faces[f]) vertex_piece[Z(v)] = pieces.piece[f];
  }
  std::vector<char> inside(num_pieces, 0);
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> ids(nvk);
  bool built = true;
  for (std::size_t v = 0; v < nvk; ++v) {
    if (vertex_piece[v] != static_cast<int>(main_piece)) continue;
    const Vec3& p = pos[Z(source[v])];
    ids[v] = sm.add_vertex({p[0], p[1], p[2]});
  }
  for (std::size_t f = 0; f < faces.size() && built; ++f) {
    if (pieces.piece[f] != static_cast<int>(main_piece)) continue;
    const Face& t = faces[f];
    built = sm.add_face(ids[Z(t[0])], ids[Z(t[1])], ids[Z(t[2])]) != SurfaceMesh::null_face();
  }
  if (!built) return inside;
  try {
    const CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> side(sm);
    std::fill(inside.begin(), inside.end(), 1);
    inside[main_piece] = 0;
    for (std::size_t v = 0; v < nvk; ++v) {
      const auto p = Z(vertex_piece[v]);
      if (p == main_piece || !inside[p]) continue;
      const Vec3& q = pos[Z(source[v])];
      if (side(Kernel::Point_3(q[0], q[1], q[2])) != CGAL::ON_BOUNDED_SIDE) inside[p] = 0;
    }
  } catch (const std::exception&) {
    std::fill(inside.begin(), inside.end(), 0);  // cannot tell: count them as outside
  }
  return inside;
}

/// Several pieces: keeps the largest by volume. Pieces entirely inside it are inner shells,
/// cavities or hidden parts: dropping them leaves the outer surface as it is. Pieces outside it
/// are separate parts: dropped as debris only when tiny, else the mesh is refused. Returns the
/// main piece.
core::Result<std::size_t> ChooseMainPiece(const std::vector<Vec3>& pos,
                                          const std::vector<int>& source,
                                          const std::vector<Face>& faces, const Pieces& pieces,
                                          const std::vector<double>& six,
                                          const PrepareOptions& options, RepairCounts& counts) {
  const std::size_t num_pieces = six.size();
  std::size_t main_piece = 0;
  if (num_pieces <= 1) return main_piece;
  for (std::size_t p = 1; p < num_pieces; ++p) {
    if (six[p] > six[main_piece]) main_piece = p;
  }
  double total = 0.0;
  for (const double v : six) total += v;
  const std::vector<char> inside = PiecesInsideMain(pos, source, faces, pieces, main_piece);
  double inner_volume = 0.0, outer_volume = 0.0;
  int outer = 0;
  for (std::size_t p = 0; p < num_pieces; ++p) {
    if (p == main_piece) continue;
    if (inside[p]) {
      ++counts.inner_pieces;
      inner_volume += six[p];
    } else {
      ++outer;
      outer_volume += six[p];
    }
  }
  if (outer > 0 && !(outer_volume <= options.max_debris_volume_fraction * total)) {
    return Refuse("the mesh has " + std::to_string(num_pieces) + " separate closed pieces and " +
                  Count(outer, "of them lies", "of them lie") + " outside the largest, holding " +
                  Percent(outer_volume / total) +
                  " of the volume: upload one object, or join the parts into one closed "
                  "surface");
  }
  counts.debris_pieces = outer;
  counts.dropped_volume_fraction = total > 0.0 ? (inner_volume + outer_volume) / total : 0.0;
  return main_piece;
}

/// The faces of `main_piece`; counts those that were reversed.
std::vector<Face> MainPieceFaces(const std::vector<Face>& faces, const Pieces& pieces,
                                 std::size_t main_piece, RepairCounts& counts) {
  std::vector<Face> kept;
  kept.reserve(faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    if (pieces.piece[f] != static_cast<int>(main_piece)) continue;
    kept.push_back(faces[f]);
    if (pieces.flip[f]) ++counts.reoriented_faces;
  }
  counts.turned_inside_out =
      counts.reoriented_faces > 0 && counts.reoriented_faces == static_cast<int>(kept.size());
  return kept;
}

/// Zero-area faces, judged on the file's own coordinates: a scale can turn collinear points
/// into nearly collinear ones, which are not caught but still form a sliver.
std::optional<core::Error> RemoveCollinearFaces(const TriangleMesh& in,
                                                const std::vector<int>& source,
                                                std::vector<Face>& faces, RepairCounts& counts) {
  TriangleMesh file_coordinates;
  file_coordinates.vertices.reserve(source.size());
  for (const int v : source) file_coordinates.vertices.push_back(in.vertices[Z(v)]);
  file_coordinates.faces = std::move(faces);
  int first_left = -1;
  const int left =
      FlipCollinearFaces(file_coordinates, &counts.collinear_faces_removed, &first_left);
  if (left > 0) {
    return CollinearRefusal(left,
                            in.vertices[Z(source[Z(file_coordinates.faces[Z(first_left)][0])])]);
  }
  faces = std::move(file_coordinates.faces);
  return std::nullopt;
}

/// The input after the combinatorial repairs: one closed, 2-manifold, outward piece.
struct Cleaned {
  TriangleMesh mesh;        ///< coordinates at the pass's scale
  std::vector<int> source;  ///< input vertex of each vertex (messages quote file coordinates)
  RepairCounts counts;
};

/// Welds, drops degenerate and duplicate faces and unused vertices, refuses holes and
/// non-manifold edges or vertices, orients each piece consistently and outwards, and keeps the
/// main piece. `scale` multiplies the input coordinates first. Indices and finiteness are
/// checked by the caller.
core::Result<Cleaned> CleanTopology(const TriangleMesh& in, double scale,
                                    const PrepareOptions& options) {
  RepairCounts counts;
  const std::vector<Vec3> pos = ScaledPositions(in, scale);
  const Welding welding = WeldVertices(in, pos, counts);
  std::vector<Face> faces = SettleCoincidentFaces(in, welding.rep, counts);
  if (faces.empty()) return NoFacesLeftRefusal(counts);

  // Keep only used vertices, in input order.
  const std::vector<int> source = CompactVertices(faces, in.vertices.size());
  counts.unused_vertices += static_cast<int>(welding.positions - source.size());
  const FilePoints at{in, source};

  const std::string holes_not_filled = FillSmallHoles(pos, source, options, faces, counts);
  auto joined = JoinFacesAcrossEdges(faces, at, holes_not_filled);
  if (!joined.ok()) return joined.error();
  if (auto e = CheckVertexFans(faces, source.size(), joined.value().corners, at)) return *e;
  auto oriented = OrientPieces(faces, joined.value().adjacent, at);
  if (!oriented.ok()) return oriented.error();
  Pieces pieces = std::move(oriented).value();
  const std::vector<double> six = TurnPiecesOutwards(pos, source, faces, pieces);
  const auto main_piece = ChooseMainPiece(pos, source, faces, pieces, six, options, counts);
  if (!main_piece.ok()) return main_piece.error();

  // The main piece, compacted once more.
  std::vector<Face> kept = MainPieceFaces(faces, pieces, main_piece.value(), counts);
  Cleaned out;
  for (const int v : CompactVertices(kept, source.size())) {
    out.source.push_back(source[Z(v)]);
    out.mesh.vertices.push_back(pos[Z(source[Z(v)])]);
  }
  if (auto e = RemoveCollinearFaces(in, out.source, kept, counts)) return *e;
  out.mesh.faces = std::move(kept);
  out.counts = counts;
  return out;
}

/// Volume, centroid, principal axes and extents of a closed, outward mesh.
struct Geometry {
  double volume = 0.0;
  Vec3 centroid{};
  std::array<Vec3, 3> axes{};  ///< by extent ascending
  Vec3 extents{};              ///< along `axes`; the bounding box's sides when volume <= 0
};

/// The eigenvectors of the covariance `cov`, by moment ascending; the file axes when Eigen fails
/// or all three moments are equal.
std::array<Eigen::Vector3d, 3> PrincipalAxes(const Eigen::Matrix3d& cov) {
  std::array<Eigen::Vector3d, 3> axes = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                         Eigen::Vector3d::UnitZ()};
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  if (eig.info() != Eigen::Success || !eig.eigenvalues().allFinite()) return axes;
  const Eigen::Vector3d lambda = eig.eigenvalues();  // ascending
  const double tol = kEqualMomentsTolerance * std::abs(lambda[2]);
  const bool eq01 = lambda[1] - lambda[0] <= tol;
  const bool eq12 = lambda[2] - lambda[1] <= tol;
  if (!eq01 && !eq12) {
    for (int k = 0; k < 3; ++k) axes[Z(k)] = eig.eigenvectors().col(k);
  } else if (eq01 != eq12) {
    // One distinct axis u; in the plane of the equal ones, the file axis nearest that plane
    // (projected into it) and its cross product with u.
    const Eigen::Vector3d u = eig.eigenvectors().col(eq01 ? 2 : 0);
    Eigen::Vector3d best = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
      const Eigen::Vector3d p = e - e.dot(u) * u;
      if (p.norm() > best.norm() + 1e-12) best = p;
    }
    const Eigen::Vector3d a1 = best.normalized();
    axes = {u, a1, u.cross(a1)};
  }  // all equal: the file axes
  return axes;
}

/// With `fixed_axes`, the extents are measured along those instead of the principal axes.
Geometry Measure(const TriangleMesh& m, const std::array<Vec3, 3>* fixed_axes = nullptr) {
  Geometry g;
  const Vec3& o0 = m.vertices[Z(m.faces[0][0])];
  const Eigen::Vector3d o(o0[0], o0[1], o0[2]);
  double six = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  auto rel = [&](int v) -> Eigen::Vector3d {  // a value, not an expression on a temporary
    const Vec3& p = m.vertices[Z(v)];
    return Eigen::Vector3d(p[0] - o[0], p[1] - o[1], p[2] - o[2]);
  };
  for (const Face& t : m.faces) {
    const Eigen::Vector3d a = rel(t[0]), b = rel(t[1]), c = rel(t[2]);
    const double d = a.dot(b.cross(c));
    const Eigen::Vector3d s = a + b + c;
    six += d;
    first += d * s;
    second += d * (s * s.transpose() + a * a.transpose() + b * b.transpose() + c * c.transpose());
  }
  g.volume = six / 6.0;
  std::array<Eigen::Vector3d, 3> axes = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                         Eigen::Vector3d::UnitZ()};
  if (fixed_axes != nullptr) {
    for (std::size_t k = 0; k < 3; ++k) {
      axes[k] = Eigen::Vector3d((*fixed_axes)[k][0], (*fixed_axes)[k][1], (*fixed_axes)[k][2]);
    }
  }
  if (g.volume > 0.0 && std::isfinite(g.volume)) {
    // Tetrahedra (o, a, b, c): integral of x is d (a + b + c) / 24, of x x^T is
    // d (s s^T + a a^T + b b^T + c c^T) / 120, with d = 6 x signed volume.
    const Eigen::Vector3d mean = first / 24.0 / g.volume;
    const Eigen::Matrix3d cov = second / 120.0 / g.volume - mean * mean.transpose();
    for (std::size_t k = 0; k < 3; ++k) {
      g.centroid[k] = mean[static_cast<Eigen::Index>(k)] + o[static_cast<Eigen::Index>(k)];
    }
    if (fixed_axes == nullptr) axes = PrincipalAxes(cov);
  }
  for (std::size_t k = 0; k < 3; ++k) {
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t v = 0; v < m.vertices.size(); ++v) {
      const double x = rel(static_cast<int>(v)).dot(axes[k]);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    g.extents[k] = hi - lo;
  }
  std::array<std::size_t, 3> idx = {0, 1, 2};
  std::stable_sort(idx.begin(), idx.end(),
                   [&](std::size_t x, std::size_t y) { return g.extents[x] < g.extents[y]; });
  const Vec3 extents = g.extents;
  for (std::size_t k = 0; k < 3; ++k) {
    g.extents[k] = extents[idx[k]];
    for (std::size_t c = 0; c < 3; ++c) {
      g.axes[k][c] = axes[idx[k]][static_cast<Eigen::Index>(c)];
    }
  }
  return g;
}

/// Refuses a mesh that encloses no volume.
std::optional<core::Error> CheckVolume(const Geometry& g) {
  const double largest = g.extents[2];
  if (g.volume > kFlatVolumeFraction * largest * largest * largest && std::isfinite(g.volume) &&
      g.extents[0] > 0.0) {
    return std::nullopt;
  }
  return Refuse("the mesh encloses no volume (" + Num(g.volume) + " m^3 for a largest extent of " +
                Num(largest) + " m): it is flat, or its pieces cancel out");
}

std::vector<std::string> RepairLines(const RepairCounts& c) {
  std::vector<std::string> lines;
  if (c.welded_vertices > 0) {
    lines.push_back("welded " + Count(c.welded_vertices, "duplicate vertex", "duplicate vertices") +
                    " (equal coordinates)");
  }
  if (c.degenerate_faces > 0) {
    lines.push_back("dropped " + Count(c.degenerate_faces, "degenerate face", "degenerate faces") +
                    " (a vertex named twice)");
  }
  if (c.duplicate_faces > 0) {
    lines.push_back("dropped " + Count(c.duplicate_faces, "duplicate face", "duplicate faces"));
  }
  if (c.opposite_face_pairs > 0) {
    lines.push_back("dropped " +
                    Count(c.opposite_face_pairs, "pair of coincident faces facing",
                          "pairs of coincident faces facing") +
                    " opposite ways (internal walls or zero-thickness sheets)");
  }
  if (c.unused_vertices > 0) {
    lines.push_back("dropped " + Count(c.unused_vertices, "unused vertex", "unused vertices"));
  }
  if (c.turned_inside_out) {
    lines.push_back("turned the mesh right side out: all " +
                    Count(c.reoriented_faces, "face", "faces") +
                    " faced inwards (negative volume) and were flipped");
  } else if (c.reoriented_faces > 0) {
    lines.push_back("reoriented " + Count(c.reoriented_faces, "face", "faces") +
                    " to agree with their neighbours and face outwards");
  }
  if (c.inner_pieces > 0 || c.debris_pieces > 0) {
    std::vector<std::string> what;
    if (c.inner_pieces > 0) {
      what.push_back(Count(c.inner_pieces, "piece", "pieces") +
                     " inside the main one (inner shells, cavities or hidden parts)");
    }
    if (c.debris_pieces > 0) {
      what.push_back(Count(c.debris_pieces, "small separate piece", "small separate pieces"));
    }
    lines.push_back("dropped " + JoinAnd(what) + ", holding " + Percent(c.dropped_volume_fraction) +
                    " of the volume");
  }
  if (c.filled_holes > 0) {
    lines.push_back("filled " + Count(c.filled_holes, "hole", "holes") + " (" +
                    Count(c.filled_hole_edges, "boundary edge", "boundary edges") + ") with " +
                    Count(c.hole_faces_added, "new face", "new faces") + ", adding " +
                    Percent(c.filled_area_fraction) + " to the surface area");
  }
  if (c.collinear_faces_removed > 0) {
    lines.push_back("removed " +
                    Count(c.collinear_faces_removed, "zero-area face", "zero-area faces") +
                    " (three vertices on a line) by flipping an edge; the surface is unchanged");
  }
  return lines;
}

bool Positive(double x) { return std::isfinite(x) && x > 0.0; }

/// Whether at most `budget` pairs of faces have overlapping (closed) bounding boxes: the
/// candidates the self-intersection test would decide one by one. Stops counting past the budget.
bool FewOverlappingBoxes(const TriangleMesh& m, std::int64_t budget) {
  using Box =
      CGAL::Box_intersection_d::Box_d<double, 3, CGAL::Box_intersection_d::ID_FROM_BOX_ADDRESS>;
  std::vector<Box> boxes;
  boxes.reserve(m.faces.size());
  for (const Face& t : m.faces) {
    const Vec3& p = m.vertices[Z(t[0])];
    const Vec3& q = m.vertices[Z(t[1])];
    const Vec3& r = m.vertices[Z(t[2])];
    boxes.emplace_back(CGAL::Bbox_3(std::min({p[0], q[0], r[0]}), std::min({p[1], q[1], r[1]}),
                                    std::min({p[2], q[2], r[2]}), std::max({p[0], q[0], r[0]}),
                                    std::max({p[1], q[1], r[1]}), std::max({p[2], q[2], r[2]})));
  }
  std::vector<const Box*> handles;
  handles.reserve(boxes.size());
  for (const Box& b : boxes) handles.push_back(&b);
  struct OverBudget {};
  std::int64_t pairs = 0;
  try {
    CGAL::box_self_intersection_d(handles.begin(), handles.end(), [&](const Box*, const Box*) {
      if (++pairs > budget) throw OverBudget{};
    });
  } catch (const OverBudget&) {
    return false;
  }
  return true;
}

/// Throws for limits that are not positive and finite (the caller's bug), and refuses a unit or
/// a rescale target that is not a positive length (the request's fault).
std::optional<core::Error> CheckOptions(const PrepareOptions& options) {
  if (options.max_triangles < 1 || !Positive(options.min_extent_m) ||
      !Positive(options.max_extent_m) || !(options.max_debris_volume_fraction >= 0.0) ||
      !(options.max_debris_volume_fraction <= 1.0) ||
      !(options.self_intersection_box_pairs_per_face >= 0.0) ||
      !std::isfinite(options.self_intersection_box_pairs_per_face) ||
      options.self_intersection_min_box_pairs < 0 || options.fill_hole_max_edges < 0 ||
      !(options.fill_hole_max_area_fraction >= 0.0) ||
      !std::isfinite(options.fill_hole_max_area_fraction)) {
    throw std::invalid_argument("PrepareOptions: a limit is not positive and finite");
  }
  if (!Positive(options.unit_scale_m)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "the unit must be a positive number of metres per file unit", "unit");
  }
  if (options.rescale_min_extent_m && !Positive(*options.rescale_min_extent_m)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "the rescale target must be a positive length in metres", "rescale");
  }
  return std::nullopt;
}

/// Refuses a mesh with too many triangles or vertices, none, a face index out of range, a
/// non-finite coordinate, or coordinates beyond kMaxCoordinateM after the unit conversion.
/// Returns the largest absolute coordinate (file units).
core::Result<double> CheckInputMesh(const TriangleMesh& in, const PrepareOptions& options) {
  if (static_cast<std::int64_t>(in.faces.size()) > options.max_triangles) {
    return MakeError(ErrorCode::kTooLarge,
                     "the mesh has " + std::to_string(in.faces.size()) + " triangles; at most " +
                         std::to_string(options.max_triangles) + " are accepted",
                     "mesh");
  }
  if (in.vertices.size() > static_cast<std::size_t>(INT_MAX)) {
    return MakeError(ErrorCode::kTooLarge, "the mesh has too many vertices", "mesh");
  }
  if (in.faces.empty()) return Refuse("the mesh has no triangles");
  const auto nv = static_cast<int>(in.vertices.size());
  for (std::size_t f = 0; f < in.faces.size(); ++f) {
    for (const int v : in.faces[f]) {
      if (v < 0 || v >= nv) {
        return MakeError(ErrorCode::kInvalidArgument,
                         "face " + std::to_string(f) + " names vertex " + std::to_string(v) +
                             ", out of range (" + std::to_string(nv) + " vertices)",
                         "mesh");
      }
    }
  }
  double largest = 0.0;
  for (std::size_t v = 0; v < in.vertices.size(); ++v) {
    for (const double x : in.vertices[v]) {
      if (!std::isfinite(x)) {
        return MakeError(ErrorCode::kInvalidArgument,
                         "vertex " + std::to_string(v) + " has a non-finite coordinate", "mesh");
      }
      largest = std::max(largest, std::abs(x));
    }
  }
  if (largest * options.unit_scale_m > kMaxCoordinateM) {
    return Refuse("coordinates reach " + Num(largest * options.unit_scale_m) +
                  " m after the unit conversion, far beyond any object to grasp (is the unit "
                  "right?)");
  }
  return largest;
}

/// Scales `m` about the origin so that its smallest principal extent becomes
/// options.rescale_min_extent_m, and measures `geometry` anew; `largest` is the largest absolute
/// input coordinate. Returns the factor.
core::Result<double> RescaleToMinExtent(TriangleMesh& m, Geometry& geometry, double largest,
                                        const PrepareOptions& options) {
  const double factor = *options.rescale_min_extent_m / geometry.extents[0];
  if (!Positive(factor) || !Positive(options.unit_scale_m * factor)) {
    return Refuse("the mesh cannot be rescaled: its smallest extent is " +
                  Num(geometry.extents[0]) + " m");
  }
  if (largest * options.unit_scale_m * factor > kMaxCoordinateM) {
    return Refuse("coordinates reach " + Num(largest * options.unit_scale_m * factor) +
                  " m after the rescale, far beyond any object to grasp");
  }
  for (auto& v : m.vertices) {
    for (double& x : v) x *= factor;
  }
  // A uniform scale about the origin does not turn the principal axes: measure along the same.
  geometry = Measure(m, &geometry.axes);
  if (auto e = CheckVolume(geometry)) return *e;
  return factor;
}

/// Refuses a mesh whose smallest principal extent is below options.min_extent_m or whose largest
/// is above options.max_extent_m.
std::optional<core::Error> CheckExtents(const Geometry& geometry, const PrepareOptions& options) {
  const std::string unit_hint = options.rescale_min_extent_m ? "" : " (is the unit right?)";
  if (geometry.extents[0] < options.min_extent_m) {
    return Refuse("the mesh is too small: its smallest principal extent is " +
                  Num(geometry.extents[0]) + " m, below the " + Num(options.min_extent_m) +
                  " m accepted" + unit_hint);
  }
  if (geometry.extents[2] > options.max_extent_m) {
    return Refuse("the mesh is too large: its largest principal extent is " +
                  Num(geometry.extents[2]) + " m, above the " + Num(options.max_extent_m) +
                  " m accepted" + unit_hint);
  }
  return std::nullopt;
}

/// Checks the prepared mesh into out.report, testing self-intersections only when few pairs of
/// faces have overlapping bounding boxes. Anything the preparation should have repaired is an
/// internal error; self-intersections are refused or added to out.warnings as the options say.
std::optional<core::Error> CheckPrepared(const TriangleMesh& m, const PrepareOptions& options,
                                         PreparedMesh& out) {
  const auto box_pair_budget = std::max(
      options.self_intersection_min_box_pairs,
      static_cast<std::int64_t>(std::min(9e18, options.self_intersection_box_pairs_per_face *
                                                   static_cast<double>(m.faces.size()))));
  const bool test_intersections = options.self_intersections != SelfIntersectionPolicy::kSkip &&
                                  FewOverlappingBoxes(m, box_pair_budget);
  MeshCheckOptions check;
  check.self_intersections = test_intersections;
  out.report = CheckMesh(m, check);
  const MeshReport& r = out.report;
  if (!(r.indices_valid && r.closed && r.edge_manifold && r.vertex_manifold && r.connected &&
        r.consistently_oriented && r.outward && r.num_degenerate_faces == 0 &&
        r.num_unreferenced_vertices == 0 && r.num_nonfinite_vertices == 0 &&
        r.num_collinear_faces == 0 && (!test_intersections || r.self_intersections_checked))) {
    std::string problems;
    for (const auto& p : r.problems) problems += (problems.empty() ? "" : "; ") + p;
    return MakeError(ErrorCode::kInternal, "mesh preparation left problems: " + problems, "mesh");
  }
  if (r.num_self_intersecting_pairs > 0) {
    const std::string what =
        Count(r.num_self_intersecting_pairs, "pair", "pairs") + " of faces cut through each other";
    if (options.self_intersections == SelfIntersectionPolicy::kRefuse) {
      return Refuse("the mesh intersects itself: " + what);
    }
    out.warnings.push_back("the mesh intersects itself: " + what +
                           "; volume and centre of mass count the overlap twice");
  } else if (options.self_intersections != SelfIntersectionPolicy::kSkip && !test_intersections) {
    out.warnings.push_back("self-intersections not tested: more than " +
                           std::to_string(box_pair_budget) +
                           " pairs of faces have overlapping bounding boxes (a large triangle "
                           "fan?), which would make the test slow");
  }
  return std::nullopt;
}

}  // namespace

core::Result<PreparedMesh> PrepareMesh(TriangleMesh mesh, const PrepareOptions& options) {
  if (auto e = CheckOptions(options)) return *e;
  const TriangleMesh& in = mesh;
  const auto input = CheckInputMesh(in, options);
  if (!input.ok()) return input.error();
  const double largest = input.value();

  auto pass = CleanTopology(in, options.unit_scale_m, options);
  if (!pass.ok()) return pass.error();
  Cleaned cleaned = std::move(pass).value();
  TriangleMesh& m = cleaned.mesh;
  Geometry geometry = Measure(m);
  if (auto e = CheckVolume(geometry)) return *e;
  const Vec3 extents_before = geometry.extents;
  double factor = 1.0;
  if (options.rescale_min_extent_m) {
    const auto rescaled = RescaleToMinExtent(m, geometry, largest, options);
    if (!rescaled.ok()) return rescaled.error();
    factor = rescaled.value();
  }
  if (auto e = CheckExtents(geometry, options)) return *e;

  // Once more on the returned coordinates: rounding in the scale can make points collinear.
  int first_left = -1, removed = 0;
  const int collinear_left = FlipCollinearFaces(m, &removed, &first_left);
  cleaned.counts.collinear_faces_removed += removed;
  if (collinear_left > 0) {
    return CollinearRefusal(collinear_left,
                            in.vertices[Z(cleaned.source[Z(m.faces[Z(first_left)][0])])]);
  }

  PreparedMesh out;
  if (auto e = CheckPrepared(m, options, out)) return *e;
  out.counts = cleaned.counts;
  out.repairs = RepairLines(out.counts);
  out.unit_scale_m = options.unit_scale_m;
  out.rescale_factor = factor;
  out.scale_applied = options.unit_scale_m * factor;
  out.principal_axes = geometry.axes;
  out.extents_before_rescale_m = extents_before;
  out.extents_m = geometry.extents;
  out.volume_m3 = geometry.volume;
  out.centroid_m = geometry.centroid;
  out.mesh = std::move(m);
  return out;
}

}  // namespace softgrasp::mesh
