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
    // The middle vertex, by the coordinate along which the three spread most (distinct points
    // on a line are strictly ordered along it).
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
  const std::size_t nv = in.vertices.size();
  const std::size_t nf = in.faces.size();
  RepairCounts counts;
  auto file_point = [&](int input_vertex) { return Point(in.vertices[Z(input_vertex)]); };

  std::vector<Vec3> pos(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    for (std::size_t k = 0; k < 3; ++k) pos[i][k] = in.vertices[i][k] * scale;
  }

  // Weld used vertices with equal coordinates (0 and -0 are equal) onto the lowest index.
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
  std::vector<int> rep(nv, -1);
  std::size_t positions = 0;
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j < order.size() && pos[Z(order[j])] == pos[Z(order[i])]) rep[Z(order[j++])] = order[i];
    ++positions;
    i = j;
  }
  counts.welded_vertices = static_cast<int>(order.size() - positions);

  // Faces on the welded vertices: drop those that name a vertex twice, then settle faces on the
  // same three vertices. Same orientation: a duplicate, one is kept. Opposite orientations: a
  // zero-thickness wall (two closed cells sharing a side, or a sheet modelled with both sides);
  // such a pair adds nothing to the volume and keeps every edge's face count even, so it is
  // dropped, pair by pair.
  struct Keyed {
    Face sorted;
    int face;
    bool even;  ///< same cyclic order as `sorted`
  };
  std::vector<Face> welded(nf);
  std::vector<Keyed> keyed;
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
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& x, const Keyed& y) {
    if (x.sorted[0] != y.sorted[0]) return x.sorted[0] < y.sorted[0];
    if (x.sorted[1] != y.sorted[1]) return x.sorted[1] < y.sorted[1];
    if (x.sorted[2] != y.sorted[2]) return x.sorted[2] < y.sorted[2];
    return x.face < y.face;
  });
  std::vector<char> keep(nf, 0);
  std::vector<std::pair<std::size_t, std::size_t>> balanced;  // groups as many one way as the other
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
  // A balanced group whose three edges each have an odd number of other faces is one side of the
  // solid with a reversed copy (a face exported two-sided): dropping both would open a hole, so
  // one is kept (the orientation step below turns it the right way).
  if (!balanced.empty()) {
    std::unordered_map<std::uint64_t, int> edge_faces;
    edge_faces.reserve(3 * nf);
    for (std::size_t f = 0; f < nf; ++f) {
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

  Cleaned out;
  std::vector<Face> faces;
  for (std::size_t f = 0; f < nf; ++f) {
    if (keep[f]) faces.push_back(welded[f]);
  }
  if (faces.empty()) {
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

  // Keep only used vertices, in input order.
  std::vector<int> new_id(nv, -1);
  for (const Face& t : faces) {
    for (const int v : t) new_id[Z(v)] = 0;
  }
  for (std::size_t i = 0; i < nv; ++i) {
    if (new_id[i] == 0) {
      new_id[i] = static_cast<int>(out.source.size());
      out.source.push_back(static_cast<int>(i));
    }
  }
  counts.unused_vertices += static_cast<int>(positions - out.source.size());
  for (Face& t : faces) {
    for (int& v : t) v = new_id[Z(v)];
  }
  const auto at = [&](int v) { return file_point(out.source[Z(v)]); };

  // Small holes: closed with triangles between their boundary vertices, or left for the refusal
  // below, which then says why they were not filled.
  std::string holes_not_filled;
  if (options.fill_hole_max_edges > 0) {
    std::vector<Vec3> kept_pos(out.source.size());
    for (std::size_t v = 0; v < out.source.size(); ++v) kept_pos[v] = pos[Z(out.source[v])];
    const HoleFillResult filled = FillHoles(
        kept_pos, faces, {options.fill_hole_max_edges, options.fill_hole_max_area_fraction});
    counts.filled_holes = filled.holes;
    counts.filled_hole_edges = filled.boundary_edges;
    counts.hole_faces_added = filled.new_faces;
    counts.filled_area_fraction = filled.area_fraction;
    holes_not_filled = filled.not_filled;
  }

  // Edges: each must have exactly two faces.
  const int n = static_cast<int>(faces.size());
  std::vector<HalfEdge> half;
  half.reserve(3 * faces.size());
  for (int f = 0; f < n; ++f) {
    const Face& t = faces[Z(f)];
    for (std::size_t k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      half.push_back({EdgeKey(a, b), a, b, f});
    }
  }
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  struct Neighbour {
    int face = -1;
    bool same_direction = false;  ///< both faces run along the shared edge the same way
  };
  std::vector<Neighbour> adjacent(3 * faces.size());
  std::vector<int> num_adjacent(faces.size(), 0);
  UnionFind corners(3 * faces.size());
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
      corners.Union(corner(e0.face, e0.from), corner(e1.face, e0.from));
      corners.Union(corner(e0.face, e0.to), corner(e1.face, e0.to));
      const bool same = e0.from == e1.from;
      adjacent[Z(e0.face) * 3 + Z(num_adjacent[Z(e0.face)]++)] = {e1.face, same};
      adjacent[Z(e1.face) * 3 + Z(num_adjacent[Z(e1.face)]++)] = {e0.face, same};
    }
    i = j;
  }
  if (boundary > 0 || nonmanifold > 0) {
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

  // Vertex fans: the faces around each vertex must form one fan.
  const std::size_t nvk = out.source.size();
  std::vector<std::size_t> fan_root(nvk, SIZE_MAX);
  int pinched = 0;
  std::vector<char> counted(nvk, 0);
  std::string pinched_example;
  for (int f = 0; f < n; ++f) {
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
  if (pinched > 0) {
    return Refuse("the mesh is not 2-manifold: " + Count(pinched, "vertex joins", "vertices join") +
                  " separate sheets of surface that touch only there, first at " + pinched_example);
  }

  // Orientation and pieces: walk across edges; a neighbour that runs along the shared edge the
  // same way must be flipped relative to this face.
  std::vector<int> piece(faces.size(), -1);
  std::vector<char> flip(faces.size(), 0);
  std::vector<int> seeds;
  std::vector<int> queue;
  queue.reserve(faces.size());
  bool one_sided = false;
  int one_sided_face = -1;
  for (int seed = 0; seed < n; ++seed) {
    if (piece[Z(seed)] != -1) continue;
    const int id = static_cast<int>(seeds.size());
    seeds.push_back(seed);
    piece[Z(seed)] = id;
    queue.assign(1, seed);
    for (std::size_t h = 0; h < queue.size(); ++h) {
      const int f = queue[h];
      for (std::size_t k = 0; k < 3; ++k) {
        const Neighbour& g = adjacent[Z(f) * 3 + k];
        const char want = static_cast<char>(flip[Z(f)] ^ (g.same_direction ? 1 : 0));
        if (piece[Z(g.face)] == -1) {
          piece[Z(g.face)] = id;
          flip[Z(g.face)] = want;
          queue.push_back(g.face);
        } else if (flip[Z(g.face)] != want && !one_sided) {
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

  // Each piece outwards (positive volume), measured from a vertex of its own.
  const std::size_t num_pieces = seeds.size();
  std::vector<double> six(num_pieces, 0.0);
  for (int f = 0; f < n; ++f) {
    const Face& t = faces[Z(f)];
    const Vec3& o = pos[Z(out.source[Z(faces[Z(seeds[Z(piece[Z(f)])])][0])])];
    const double v = SixVolume(o, pos[Z(out.source[Z(t[0])])], pos[Z(out.source[Z(t[1])])],
                               pos[Z(out.source[Z(t[2])])]);
    six[Z(piece[Z(f)])] += flip[Z(f)] ? -v : v;
  }
  for (std::size_t p = 0; p < num_pieces; ++p) {
    if (six[p] < 0.0) {
      six[p] = -six[p];
      for (int f = 0; f < n; ++f) {
        if (piece[Z(f)] == static_cast<int>(p)) flip[Z(f)] ^= 1;
      }
    }
  }
  for (int f = 0; f < n; ++f) {
    if (flip[Z(f)]) std::swap(faces[Z(f)][1], faces[Z(f)][2]);
  }

  // Several pieces: keep the largest by volume. Pieces entirely inside it (every vertex strictly
  // inside) are inner shells, cavities or hidden parts: dropping them leaves the outer surface
  // as it is. Pieces outside it are separate parts: dropped as debris only when tiny.
  std::size_t main_piece = 0;
  if (num_pieces > 1) {
    for (std::size_t p = 1; p < num_pieces; ++p) {
      if (six[p] > six[main_piece]) main_piece = p;
    }
    double total = 0.0;
    for (const double v : six) total += v;
    std::vector<int> vertex_piece(nvk, -1);
    for (int f = 0; f < n; ++f) {
      for (const int v : faces[Z(f)]) vertex_piece[Z(v)] = piece[Z(f)];
    }
    std::vector<char> inside(num_pieces, 0);
    SurfaceMesh sm;
    std::vector<SurfaceMesh::Vertex_index> ids(nvk);
    bool built = true;
    for (std::size_t v = 0; v < nvk; ++v) {
      if (vertex_piece[v] != static_cast<int>(main_piece)) continue;
      const Vec3& p = pos[Z(out.source[v])];
      ids[v] = sm.add_vertex({p[0], p[1], p[2]});
    }
    for (int f = 0; f < n && built; ++f) {
      if (piece[Z(f)] != static_cast<int>(main_piece)) continue;
      const Face& t = faces[Z(f)];
      built = sm.add_face(ids[Z(t[0])], ids[Z(t[1])], ids[Z(t[2])]) != SurfaceMesh::null_face();
    }
    if (built) {
      try {
        const CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> side(sm);
        std::fill(inside.begin(), inside.end(), 1);
        inside[main_piece] = 0;
        for (std::size_t v = 0; v < nvk; ++v) {
          const auto p = Z(vertex_piece[v]);
          if (p == main_piece || !inside[p]) continue;
          const Vec3& q = pos[Z(out.source[v])];
          if (side(Kernel::Point_3(q[0], q[1], q[2])) != CGAL::ON_BOUNDED_SIDE) inside[p] = 0;
        }
      } catch (const std::exception&) {
        std::fill(inside.begin(), inside.end(), 0);  // cannot tell: count them as outside
      }
    }
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
  }

  // The main piece, compacted once more.
  std::vector<Face> kept;
  kept.reserve(faces.size());
  for (int f = 0; f < n; ++f) {
    if (piece[Z(f)] != static_cast<int>(main_piece)) continue;
    kept.push_back(faces[Z(f)]);
    if (flip[Z(f)]) ++counts.reoriented_faces;
  }
  counts.turned_inside_out =
      counts.reoriented_faces > 0 && counts.reoriented_faces == static_cast<int>(kept.size());
  std::fill(new_id.begin(), new_id.end(), -1);
  for (const Face& t : kept) {
    for (const int v : t) new_id[Z(v)] = 0;
  }
  std::vector<int> source;
  for (std::size_t v = 0; v < nvk; ++v) {
    if (new_id[v] == 0) {
      new_id[v] = static_cast<int>(source.size());
      source.push_back(out.source[v]);
      out.mesh.vertices.push_back(pos[Z(out.source[v])]);
    }
  }
  for (Face& t : kept) {
    for (int& v : t) v = new_id[Z(v)];
  }

  // Zero-area faces, judged on the file's own coordinates: a scale can turn collinear points
  // into nearly collinear ones, which are not caught but still form a sliver.
  TriangleMesh file_coordinates;
  file_coordinates.vertices.reserve(source.size());
  for (const int v : source) file_coordinates.vertices.push_back(in.vertices[Z(v)]);
  file_coordinates.faces = std::move(kept);
  int first_left = -1;
  const int left =
      FlipCollinearFaces(file_coordinates, &counts.collinear_faces_removed, &first_left);
  if (left > 0) {
    return CollinearRefusal(left,
                            in.vertices[Z(source[Z(file_coordinates.faces[Z(first_left)][0])])]);
  }
  out.mesh.faces = std::move(file_coordinates.faces);
  out.source = std::move(source);
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
    if (fixed_axes == nullptr) {
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
      if (eig.info() == Eigen::Success && eig.eigenvalues().allFinite()) {
        const Eigen::Vector3d lambda = eig.eigenvalues();  // ascending
        const double tol = kEqualMomentsTolerance * std::abs(lambda[2]);
        const bool eq01 = lambda[1] - lambda[0] <= tol;
        const bool eq12 = lambda[2] - lambda[1] <= tol;
        if (!eq01 && !eq12) {
          for (int k = 0; k < 3; ++k) axes[Z(k)] = eig.eigenvectors().col(k);
        } else if (eq01 != eq12) {
          // One distinct axis u; in the plane of the equal ones, the file axis nearest that
          // plane (projected into it) and its cross product with u.
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
      }
    }
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

}  // namespace

core::Result<PreparedMesh> PrepareMesh(TriangleMesh mesh, const PrepareOptions& options) {
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
  const TriangleMesh& in = mesh;
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

  auto pass = CleanTopology(in, options.unit_scale_m, options);
  if (!pass.ok()) return pass.error();
  Cleaned cleaned = std::move(pass).value();
  TriangleMesh& m = cleaned.mesh;
  Geometry geometry = Measure(m);
  if (auto e = CheckVolume(geometry)) return *e;
  const Vec3 extents_before = geometry.extents;
  double factor = 1.0;
  if (options.rescale_min_extent_m) {
    factor = *options.rescale_min_extent_m / geometry.extents[0];
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
  }
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

  // Once more on the returned coordinates: rounding in the scale can make points collinear.
  int first_left = -1, removed = 0;
  const int collinear_left = FlipCollinearFaces(m, &removed, &first_left);
  cleaned.counts.collinear_faces_removed += removed;
  if (collinear_left > 0) {
    return CollinearRefusal(collinear_left,
                            in.vertices[Z(cleaned.source[Z(m.faces[Z(first_left)][0])])]);
  }

  PreparedMesh out;
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
