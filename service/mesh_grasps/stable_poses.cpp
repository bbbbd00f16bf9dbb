// Stable poses on a table: Qhull's convex hull with coplanar facets merged, solid-angle priors
// from the centre of mass, the toppling graph and its sinks (meshpy's stable_poses).
//
// Qhull runs WITHOUT "Qt": its facets are then convex polygons in which coplanar input triangles
// are already merged (a cube gives 6 squares), so the sink test "does the projected COM fall
// inside the facet" is a plain convex-polygon test on the whole flat face, and no second pass is
// needed to glue coplanar triangles back together (with "Qt" that pass would also have to cope
// with the zero-area triangles triangulation can produce).
#include "service/mesh_grasps/stable_poses.h"

#include <libqhull_r/qhull_ra.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>

namespace softgrasp::mesh {
namespace {

/// Geometry within this fraction of the bounding-box diagonal counts as flat / on the boundary:
///  - Qhull merges neighbouring facets whose centrums lie within it of each other's planes
///    ("C-n" pre-merge), so faces that are flat up to float32 rounding of the coordinates
///    (~6e-8 relative) become one pose;
///  - a projected COM that far outside a facet edge still counts as resting on that facet (a
///    COM exactly above an edge is in neutral balance; rounding must not make it topple);
///  - the COM must lie at least that far inside every hull facet.
/// At 1e-6 a 1 m object tolerates 1 um: far below any real table or part flatness, and far above
/// double rounding (~1e-16 relative), so neither side of the choice is near a real effect.
constexpr double kFlatTolerance = 1e-6;
/// Segment distances closer than this fraction of the diagonal are ties when choosing the edge a
/// facet topples over (the projected COM is closest to a corner, i.e. to two edges at once).
constexpr double kTieTolerance = 1e-12;

/// A convex hull facet: a convex polygon, counter-clockwise seen from outside, with its plane
/// n . x = offset (n outward, unit length).
struct HullFacet {
  std::vector<int> vertices;
  /// Qhull's ridges of a merged (non-triangular) facet: the polygon's edges, unordered.
  std::vector<std::pair<int, int>> edges;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double offset = 0.0;
};

/// Frees a Qhull instance on every path (the "qh_freeqhull, then qh_memfreeshort" pattern).
class QhullInstance {
 public:
  QhullInstance() : qh_(std::make_unique<qhT>()) {}
  QhullInstance(const QhullInstance&) = delete;
  QhullInstance& operator=(const QhullInstance&) = delete;
  ~QhullInstance() {
    qh_freeqhull(qh_.get(), !qh_ALL);
    int still_long = 0, total_long = 0;
    qh_memfreeshort(qh_.get(), &still_long, &total_long);
    if (err_ != nullptr) std::fclose(err_);
  }
  qhT* get() { return qh_.get(); }
  /// Qhull's messages go here, never to stdout/stderr. Null when /dev/null cannot be opened.
  FILE* err() const { return err_; }

 private:
  std::unique_ptr<qhT> qh_;
  FILE* err_ = std::fopen("/dev/null", "w");
};

/// The elements of a null-terminated Qhull set.
template <class T>
std::vector<T*> SetElements(setT* set) {
  std::vector<T*> out;
  if (set == nullptr) return out;
  const setelemT* e = set->e;
  for (int i = 0; e[i].p != nullptr; ++i) out.push_back(static_cast<T*>(e[i].p));
  return out;
}

/// The polygon's vertices by angle around their centroid, counter-clockwise about the normal.
/// Right for a triangle and for any polygon whose vertices are clearly convex; a long, thin merged
/// facet can come out of order (a vertex near an edge's line sorts to the wrong side of it).
std::vector<int> SortedByAngle(const std::vector<Eigen::Vector3d>& points, const HullFacet& f) {
  const Eigen::Vector3d& n = f.normal;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int v : f.vertices) centroid += points[static_cast<std::size_t>(v)];
  centroid /= static_cast<double>(f.vertices.size());
  const Eigen::Vector3d u = n.unitOrthogonal();
  const Eigen::Vector3d w = n.cross(u);
  std::vector<std::pair<double, int>> by_angle;
  for (int v : f.vertices) {
    const Eigen::Vector3d d = points[static_cast<std::size_t>(v)] - centroid;
    by_angle.emplace_back(std::atan2(d.dot(w), d.dot(u)), v);
  }
  std::sort(by_angle.begin(), by_angle.end());
  std::vector<int> out;
  for (const auto& [angle, v] : by_angle) out.push_back(v);
  return out;
}

/// The polygon walked along its ridges: the order neighbouring facets agree on. Empty when the
/// ridges do not form one cycle through every vertex.
std::vector<int> WalkedAlongRidges(const HullFacet& f) {
  if (f.edges.size() != f.vertices.size()) return {};
  std::map<int, std::vector<int>> next_to;
  for (const auto& [a, b] : f.edges) {
    next_to[a].push_back(b);
    next_to[b].push_back(a);
  }
  for (const auto& [v, ends] : next_to) {
    if (ends.size() != 2) return {};
  }
  std::vector<int> cycle = {f.edges.front().first};
  int previous = -1;
  while (cycle.size() < f.vertices.size()) {
    const std::vector<int>& ends = next_to[cycle.back()];
    const int next = ends[0] != previous ? ends[0] : ends[1];
    if (next == cycle.front()) return {};  // a shorter cycle: not one polygon
    previous = cycle.back();
    cycle.push_back(next);
  }
  const std::vector<int>& closing = next_to[cycle.back()];
  if (std::find(closing.begin(), closing.end(), cycle.front()) == closing.end()) return {};
  return cycle;
}

/// Puts f.vertices in counter-clockwise order about the outward normal, starting at the smallest
/// index so the polygon does not depend on Qhull's vertex order.
void OrderCounterClockwise(const std::vector<Eigen::Vector3d>& points, HullFacet& f) {
  std::vector<int> order = f.vertices.size() > 3 ? WalkedAlongRidges(f) : std::vector<int>{};
  if (order.empty()) {
    order = SortedByAngle(points, f);
  } else {
    Eigen::Vector3d area = Eigen::Vector3d::Zero();  // twice the polygon's vector area
    for (std::size_t k = 0; k < order.size(); ++k) {
      area += points[static_cast<std::size_t>(order[k])].cross(
          points[static_cast<std::size_t>(order[(k + 1) % order.size()])]);
    }
    if (area.dot(f.normal) < 0.0) std::reverse(order.begin(), order.end());
  }
  std::rotate(order.begin(), std::min_element(order.begin(), order.end()), order.end());
  f.vertices = std::move(order);
}

/// Convex hull facets of `points` (Qhull, coplanar facets merged within `merge_distance`), each
/// polygon counter-clockwise around its outward normal (OrderCounterClockwise). Empty on Qhull
/// failure, with the exit code in `exit_code`.
std::vector<HullFacet> ConvexHullFacets(const std::vector<Eigen::Vector3d>& points,
                                        double merge_distance, int& exit_code) {
  std::vector<HullFacet> facets;
  QhullInstance instance;
  if (instance.err() == nullptr) {
    exit_code = -1;
    return facets;
  }
  qhT* qh = instance.get();
  qh_zero(qh, instance.err());
  std::vector<coordT> coords;
  coords.reserve(points.size() * 3);
  for (const Eigen::Vector3d& p : points) coords.insert(coords.end(), {p.x(), p.y(), p.z()});
  std::array<char, 64> command{};
  std::snprintf(command.data(), command.size(), "qhull C-%.9g", merge_distance);
  exit_code = qh_new_qhull(qh, 3, static_cast<int>(points.size()), coords.data(), False,
                           command.data(), nullptr, instance.err());
  if (exit_code != 0) return facets;

  for (facetT* facet = qh->facet_list; facet != nullptr && facet->next != nullptr;
       facet = facet->next) {
    if (facet->visible) continue;
    HullFacet out;
    out.normal = Eigen::Vector3d(facet->normal[0], facet->normal[1], facet->normal[2]);
    out.offset = -facet->offset;  // Qhull's plane: normal . x + offset = 0
    for (vertexT* vertex : SetElements<vertexT>(facet->vertices)) {
      out.vertices.push_back(qh_pointid(qh, vertex->point));
    }
    // A merged facet's explicit ridges are its polygon's edges (two vertices each in 3-d).
    if (!facet->simplicial) {
      for (ridgeT* ridge : SetElements<ridgeT>(facet->ridges)) {
        const std::vector<vertexT*> ends = SetElements<vertexT>(ridge->vertices);
        if (ends.size() != 2) continue;
        out.edges.emplace_back(qh_pointid(qh, ends[0]->point), qh_pointid(qh, ends[1]->point));
      }
    }
    facets.push_back(std::move(out));
  }

  for (HullFacet& f : facets) OrderCounterClockwise(points, f);
  return facets;
}

/// Solid angle of triangle (a, b, c) seen from the origin (Van Oosterom & Strackee 1983); positive
/// when a, b, c run counter-clockwise seen from the origin's far side (outward from inside).
double TriangleSolidAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& c) {
  const double la = a.norm(), lb = b.norm(), lc = c.norm();
  const double numerator = a.dot(b.cross(c));
  const double denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
  return 2.0 * std::atan2(numerator, denominator);
}

core::Error Unprocessable(std::string message, std::string field) {
  return core::MakeError(core::ErrorCode::kUnprocessable, std::move(message), std::move(field));
}

/// The mesh's vertices as points, and the diagonal of their bounding box.
struct MeshPoints {
  std::vector<Eigen::Vector3d> points;
  double diagonal = 0.0;
};

/// Refuses fewer than 4 vertices, more than an int indexes, a non-finite coordinate, or
/// vertices that all coincide.
core::Result<MeshPoints> PointsOf(const TriangleMesh& mesh) {
  if (mesh.vertices.size() < 4) {
    return Unprocessable("a mesh needs at least 4 vertices to rest on a table, got " +
                             std::to_string(mesh.vertices.size()),
                         "mesh");
  }
  if (mesh.vertices.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    return Unprocessable("too many vertices", "mesh");
  }
  MeshPoints out;
  out.points.reserve(mesh.vertices.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& v : mesh.vertices) {
    const Eigen::Vector3d p(v[0], v[1], v[2]);
    if (!p.allFinite()) return Unprocessable("a vertex has a non-finite coordinate", "mesh");
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    out.points.push_back(p);
  }
  out.diagonal = (hi - lo).norm();
  if (!(out.diagonal > 0.0) || !std::isfinite(out.diagonal)) {
    return Unprocessable("all vertices coincide (or the mesh is too large to measure)", "mesh");
  }
  return out;
}

/// options.center_of_mass, or else the centroid of the enclosed volume.
core::Result<Eigen::Vector3d> CentreOfMass(const TriangleMesh& mesh,
                                           const StablePoseOptions& options) {
  if (options.center_of_mass) {
    const Eigen::Vector3d com = *options.center_of_mass;
    if (!com.allFinite()) {
      return Unprocessable("center_of_mass has a non-finite coordinate", "center_of_mass");
    }
    return com;
  }
  const Eigen::Vector3d com = VolumeCentroid(mesh);
  if (!com.allFinite()) {
    return Unprocessable(
        "the mesh encloses no positive volume (open, inward-facing or bad face indices), so it "
        "has no default centre of mass; pass center_of_mass",
        "center_of_mass");
  }
  return com;
}

/// ConvexHullFacets, refusing points with no 3-d hull.
core::Result<std::vector<HullFacet>> HullOf(const std::vector<Eigen::Vector3d>& points,
                                            double flat) {
  int exit_code = 0;
  std::vector<HullFacet> facets = ConvexHullFacets(points, flat, exit_code);
  if (exit_code == -1) {
    return core::MakeError(core::ErrorCode::kInternal, "cannot open /dev/null for Qhull");
  }
  if (exit_code != 0 || facets.size() < 4) {
    return Unprocessable(
        "the vertices have no 3-d convex hull (all coplanar or nearly so; Qhull exit code " +
            std::to_string(exit_code) + ")",
        "mesh");
  }
  return facets;
}

/// Heights of the COM above each facet plane (positive inside); refuses a COM that is not at
/// least `flat` inside every facet.
core::Result<std::vector<double>> ComHeights(const std::vector<HullFacet>& facets,
                                             const Eigen::Vector3d& com, double flat) {
  std::vector<double> height(facets.size());
  for (std::size_t i = 0; i < facets.size(); ++i) {
    height[i] = facets[i].offset - facets[i].normal.dot(com);
    if (!(height[i] > flat)) {
      return Unprocessable("the centre of mass is not strictly inside the convex hull",
                           "center_of_mass");
    }
  }
  return height;
}

/// Each facet's prior: the solid angle it subtends from the COM, as a fraction of the whole.
std::vector<double> SolidAnglePriors(const std::vector<Eigen::Vector3d>& points,
                                     const std::vector<HullFacet>& facets,
                                     const Eigen::Vector3d& com) {
  std::vector<double> prior(facets.size(), 0.0);
  double total_angle = 0.0;
  for (std::size_t i = 0; i < facets.size(); ++i) {
    const HullFacet& f = facets[i];
    const Eigen::Vector3d first = points[static_cast<std::size_t>(f.vertices[0])] - com;
    for (std::size_t k = 1; k + 1 < f.vertices.size(); ++k) {
      prior[i] += TriangleSolidAngle(first, points[static_cast<std::size_t>(f.vertices[k])] - com,
                                     points[static_cast<std::size_t>(f.vertices[k + 1])] - com);
    }
    total_angle += prior[i];
  }
  // total_angle is 4 pi up to rounding; dividing by it makes the priors sum to 1.
  for (double& p : prior) p /= total_angle;
  return prior;
}

/// The edge (its index in f.vertices: from vertex k to k + 1) that facet `f` topples over when
/// resting on it, the COM `height` above it: the edge nearest the projected COM, ties to the one
/// it lies further outside of. -1 for a sink: the projected COM is not more than `flat` outside
/// any edge.
int TopplingEdge(const std::vector<Eigen::Vector3d>& points, const HullFacet& f, double height,
                 const Eigen::Vector3d& com, double diagonal, double flat) {
  const Eigen::Vector3d projected = com + height * f.normal;
  const std::size_t m = f.vertices.size();
  double max_outside = -std::numeric_limits<double>::infinity();
  int best_edge = -1;
  double best_distance = std::numeric_limits<double>::infinity(), best_outside = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    const Eigen::Vector3d a = points[static_cast<std::size_t>(f.vertices[k])];
    const Eigen::Vector3d b = points[static_cast<std::size_t>(f.vertices[(k + 1) % m])];
    const Eigen::Vector3d edge = b - a;
    const double length = edge.norm();
    if (!(length > 0.0)) continue;
    // For a counter-clockwise polygon about n, edge x n points out of the polygon.
    const double outside = (projected - a).dot(edge.cross(f.normal)) / length;
    max_outside = std::max(max_outside, outside);
    const double t = std::clamp((projected - a).dot(edge) / (length * length), 0.0, 1.0);
    const double distance = (projected - (a + t * edge)).norm();
    const double tie = kTieTolerance * diagonal;
    if (distance < best_distance - tie ||
        (distance <= best_distance + tie && outside > best_outside)) {
      best_edge = static_cast<int>(k);
      best_distance = distance;
      best_outside = outside;
    }
  }
  if (max_outside <= flat) return -1;  // sink: COM above the facet
  return best_edge;
}

/// The toppling graph: next[i] = facet i topples onto, -1 for a sink.
core::Result<std::vector<int>> TopplingGraph(const std::vector<Eigen::Vector3d>& points,
                                             const std::vector<HullFacet>& facets,
                                             const std::vector<double>& height,
                                             const Eigen::Vector3d& com, double diagonal,
                                             double flat) {
  // Facets by vertex, to find the neighbour across an edge (the other facet holding both ends).
  std::map<int, std::vector<int>> facets_of_vertex;
  for (std::size_t i = 0; i < facets.size(); ++i) {
    for (int v : facets[i].vertices) facets_of_vertex[v].push_back(static_cast<int>(i));
  }
  std::vector<int> next(facets.size(), -1);
  for (std::size_t i = 0; i < facets.size(); ++i) {
    const HullFacet& f = facets[i];
    const int best_edge = TopplingEdge(points, f, height[i], com, diagonal, flat);
    if (best_edge < 0) continue;
    const std::size_t m = f.vertices.size();
    const int a = f.vertices[static_cast<std::size_t>(best_edge)];
    const int b = f.vertices[(static_cast<std::size_t>(best_edge) + 1) % m];
    int neighbour = -1;
    for (int g : facets_of_vertex[a]) {
      if (g == static_cast<int>(i)) continue;
      const auto& gv = facets[static_cast<std::size_t>(g)].vertices;
      if (std::find(gv.begin(), gv.end(), b) != gv.end()) {
        neighbour = g;
        break;
      }
    }
    if (neighbour < 0) {
      return core::MakeError(core::ErrorCode::kInternal,
                             "convex hull facet has no neighbour across an edge");
    }
    next[i] = neighbour;
  }
  return next;
}

/// Cut cycles (possible only through rounding): each is cut at its facet with the lowest COM
/// height, which becomes a sink, so the whole cycle ends there.
void CutCycles(const std::vector<double>& height, std::vector<int>& next) {
  std::vector<char> state(next.size(), 0);  // 0 unseen, 1 on the current path, 2 finished
  for (std::size_t start = 0; start < next.size(); ++start) {
    std::vector<int> path;
    int current = static_cast<int>(start);
    while (state[static_cast<std::size_t>(current)] == 0 &&
           next[static_cast<std::size_t>(current)] >= 0) {
      state[static_cast<std::size_t>(current)] = 1;
      path.push_back(current);
      current = next[static_cast<std::size_t>(current)];
    }
    if (state[static_cast<std::size_t>(current)] == 1) {
      int lowest = current;
      for (auto it = std::find(path.begin(), path.end(), current); it != path.end(); ++it) {
        const double h = height[static_cast<std::size_t>(*it)];
        const double l = height[static_cast<std::size_t>(lowest)];
        if (h < l || (h == l && *it < lowest)) lowest = *it;
      }
      next[static_cast<std::size_t>(lowest)] = -1;
    }
    state[static_cast<std::size_t>(current)] = 2;
    for (int p : path) state[static_cast<std::size_t>(p)] = 2;
  }
}

/// Follow the (acyclic) graph to the sinks, remembering every answer on the way: sink[i] is
/// where facet i comes to rest.
std::vector<int> Sinks(const std::vector<int>& next) {
  std::vector<int> sink(next.size(), -1);
  for (std::size_t start = 0; start < next.size(); ++start) {
    std::vector<int> path;
    int current = static_cast<int>(start);
    while (sink[static_cast<std::size_t>(current)] < 0 &&
           next[static_cast<std::size_t>(current)] >= 0) {
      path.push_back(current);
      current = next[static_cast<std::size_t>(current)];
    }
    const int reached = sink[static_cast<std::size_t>(current)] >= 0
                            ? sink[static_cast<std::size_t>(current)]
                            : current;
    sink[static_cast<std::size_t>(current)] = reached;
    for (int p : path) sink[static_cast<std::size_t>(p)] = reached;
  }
  return sink;
}

/// The object resting on facet `f` with its COM `height` above the table.
StablePose PoseOn(const HullFacet& f, double probability, double height,
                  const Eigen::Vector3d& com) {
  StablePose pose;
  pose.probability = probability;
  pose.face_normal_object = f.normal;
  pose.com_height_m = height;
  pose.face_vertex_indices = f.vertices;
  // Table axes in object coordinates: z = -n; x = the object axis least aligned with n,
  // projected into the facet plane; y = z x x.
  const Eigen::Vector3d z = -f.normal;
  Eigen::Index axis = 0;
  f.normal.cwiseAbs().minCoeff(&axis);
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
  const Eigen::Vector3d x = (e - e.dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  pose.table_from_object_rotation.row(0) = x.transpose();
  pose.table_from_object_rotation.row(1) = y.transpose();
  pose.table_from_object_rotation.row(2) = z.transpose();
  pose.table_from_object_translation =
      Eigen::Vector3d(0.0, 0.0, height) - pose.table_from_object_rotation * com;
  return pose;
}

}  // namespace

Eigen::Vector3d VolumeCentroid(const TriangleMesh& mesh) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d invalid(nan, nan, nan);
  if (mesh.vertices.empty() || mesh.faces.empty()) return invalid;
  const int n = static_cast<int>(mesh.vertices.size());
  auto at = [&](int i) {
    const auto& v = mesh.vertices[static_cast<std::size_t>(i)];
    return Eigen::Vector3d(v[0], v[1], v[2]);
  };
  // Tetrahedra from a vertex of the mesh rather than the origin keep far-away meshes accurate.
  const Eigen::Vector3d reference = at(0);
  double six_volume = 0.0;
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  for (const auto& f : mesh.faces) {
    for (int i : f) {
      if (i < 0 || i >= n) return invalid;
    }
    const Eigen::Vector3d a = at(f[0]) - reference, b = at(f[1]) - reference,
                          c = at(f[2]) - reference;
    const double v6 = a.dot(b.cross(c));
    six_volume += v6;
    weighted += v6 * (a + b + c);
  }
  if (!(six_volume > 0.0) || !std::isfinite(six_volume)) return invalid;
  return reference + weighted / (4.0 * six_volume);
}

core::Result<std::vector<StablePose>> ComputeStablePoses(const TriangleMesh& mesh,
                                                         const StablePoseOptions& options) {
  if (!std::isfinite(options.min_probability) || options.min_probability < 0.0) {
    return core::MakeError(core::ErrorCode::kInvalidArgument,
                           "min_probability must be a finite number >= 0", "min_probability");
  }
  const auto measured = PointsOf(mesh);
  if (!measured.ok()) return measured.error();
  const std::vector<Eigen::Vector3d>& points = measured.value().points;
  const double diagonal = measured.value().diagonal;
  const double flat = kFlatTolerance * diagonal;
  const auto com_or = CentreOfMass(mesh, options);
  if (!com_or.ok()) return com_or.error();
  const Eigen::Vector3d& com = com_or.value();
  const auto hull = HullOf(points, flat);
  if (!hull.ok()) return hull.error();
  const std::vector<HullFacet>& facets = hull.value();
  const std::size_t num_facets = facets.size();
  const auto heights = ComHeights(facets, com, flat);
  if (!heights.ok()) return heights.error();
  const std::vector<double>& height = heights.value();
  const std::vector<double> prior = SolidAnglePriors(points, facets, com);

  auto graph = TopplingGraph(points, facets, height, com, diagonal, flat);
  if (!graph.ok()) return graph.error();
  std::vector<int>& next = graph.value();
  CutCycles(height, next);
  const std::vector<int> sink = Sinks(next);
  std::vector<double> probability(num_facets, 0.0);
  for (std::size_t i = 0; i < num_facets; ++i) {
    probability[static_cast<std::size_t>(sink[i])] += prior[i];
  }

  std::vector<StablePose> poses;
  for (std::size_t i = 0; i < num_facets; ++i) {
    if (!(probability[i] > options.min_probability)) continue;
    poses.push_back(PoseOn(facets[i], probability[i], height[i], com));
  }
  std::sort(poses.begin(), poses.end(), [](const StablePose& a, const StablePose& b) {
    if (a.probability != b.probability) return a.probability > b.probability;
    return a.face_vertex_indices < b.face_vertex_indices;
  });
  return poses;
}

}  // namespace softgrasp::mesh
