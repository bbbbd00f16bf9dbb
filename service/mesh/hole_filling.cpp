// Hole filling for mesh preparation: boundary loops from a hash of edge face counts, each loop
// triangulated by CGAL's triangulate_hole_polyline (no new vertices), all or nothing.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstddef>
#include <exception>
#include <iterator>
#include <string>
#include <unordered_map>
#include <utility>

#include "service/mesh/hole_filling_internal.h"
#include "service/mesh/mesh_topology_internal.h"

namespace softgrasp::mesh::internal {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Face = std::array<int, 3>;

double TriangleArea(const std::vector<std::array<double, 3>>& p, const Face& t) {
  const auto at = [&](int v) {
    const auto& x = p[static_cast<std::size_t>(v)];
    return Eigen::Vector3d(x[0], x[1], x[2]);
  };
  return 0.5 * (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0])).norm();
}

}  // namespace

HoleFillResult FillHoles(const std::vector<std::array<double, 3>>& positions,
                         std::vector<std::array<int, 3>>& faces, const HoleFillLimits& limits) {
  HoleFillResult result;
  std::unordered_map<std::uint64_t, std::pair<int, std::pair<int, int>>> edges;  // count, a -> b
  edges.reserve(3 * faces.size());
  for (const Face& t : faces) {
    for (std::size_t k = 0; k < 3; ++k) {
      auto& e = edges[EdgeKey(t[k], t[(k + 1) % 3])];
      ++e.first;
      e.second = {t[k], t[(k + 1) % 3]};
    }
  }
  // The boundary's directed edges, as the faces run along them; a hole's patch runs against.
  std::unordered_map<int, int> next;
  std::unordered_map<int, int> incoming;
  int boundary = 0;
  for (const auto& [key, e] : edges) {
    if (e.first != 1) continue;
    ++boundary;
    const auto [from, to] = e.second;
    if (!next.emplace(from, to).second || ++incoming[to] > 1) {
      result.not_filled =
          "two holes meet at a vertex, or the faces around a hole disagree on their orientation";
      return result;
    }
  }
  if (boundary == 0) return result;

  double surface = 0.0;
  for (const Face& t : faces) surface += TriangleArea(positions, t);

  std::vector<Face> patches;
  std::unordered_map<int, char> visited;
  int holes = 0;
  // Walk from the smallest boundary vertex of each loop so the result does not depend on the
  // hash order.
  std::vector<int> starts;
  starts.reserve(next.size());
  for (const auto& [from, to] : next) starts.push_back(from);
  std::sort(starts.begin(), starts.end());
  for (const int start : starts) {
    if (visited.count(start) != 0) continue;
    std::vector<int> loop;
    for (int v = start; visited.count(v) == 0;) {
      visited[v] = 1;
      loop.push_back(v);
      const auto it = next.find(v);
      if (it == next.end()) {  // cannot happen with in = out = 1 at every boundary vertex
        result.not_filled = "a hole's boundary is not a closed loop";
        return result;
      }
      v = it->second;
      if (v != start && visited.count(v) != 0) {
        result.not_filled = "a hole's boundary is not a closed loop";
        return result;
      }
    }
    if (static_cast<int>(loop.size()) > limits.max_boundary_edges) {
      result.not_filled = "a hole has " + std::to_string(loop.size()) +
                          " boundary edges, more than the " +
                          std::to_string(limits.max_boundary_edges) +
                          " of a hole that is filled (is the surface open on one side?)";
      return result;
    }
    std::vector<Kernel::Point_3> polyline;
    polyline.reserve(loop.size());
    for (const int v : loop) {
      const auto& x = positions[static_cast<std::size_t>(v)];
      polyline.emplace_back(x[0], x[1], x[2]);
    }
    // Only the search over the hole points' 3-d Delaunay triangulation: the exhaustive fallback
    // costs O(n^3) (seconds for a tangled 500-edge loop), too much to spend on an upload. A
    // CGAL failure (an exception under its default error policy) leaves the hole unfilled.
    std::vector<CGAL::Triple<int, int, int>> triangles;
    try {
      CGAL::Polygon_mesh_processing::triangulate_hole_polyline(
          polyline, std::back_inserter(triangles),
          CGAL::parameters::use_delaunay_triangulation(true).do_not_use_cubic_algorithm(true));
    } catch (const std::exception&) {
      triangles.clear();
    }
    if (triangles.size() + 2 != loop.size()) {
      result.not_filled =
          "a hole of " + std::to_string(loop.size()) + " boundary edges could not be triangulated";
      return result;
    }
    // The faces run loop[i] -> loop[i + 1]; the patch must run the other way. CGAL orients the
    // patch consistently, so one triangle on the edge loop[0] - loop[1] decides for all.
    bool same_way = false;
    for (const auto& t : triangles) {
      const std::array<int, 3> c = {t.first, t.second, t.third};
      for (std::size_t k = 0; k < 3; ++k) {
        if (c[k] == 0 && c[(k + 1) % 3] == 1) same_way = true;
      }
    }
    for (const auto& t : triangles) {
      Face f = {loop[static_cast<std::size_t>(t.first)], loop[static_cast<std::size_t>(t.second)],
                loop[static_cast<std::size_t>(t.third)]};
      if (same_way) std::swap(f[1], f[2]);
      patches.push_back(f);
    }
    ++holes;
  }

  double added = 0.0;
  for (const Face& t : patches) added += TriangleArea(positions, t);
  const double fraction = surface > 0.0 ? added / surface : 1.0;
  if (!(fraction <= limits.max_area_fraction)) {
    result.not_filled = "filling the " + std::to_string(holes) + (holes == 1 ? " hole" : " holes") +
                        " would add " + Percent(fraction) + " to the surface area, more than the " +
                        Percent(limits.max_area_fraction) +
                        " filled (is the surface open on one side?)";
    return result;
  }
  // Every edge a patch touches must end with two faces. A diagonal across a hole between two
  // vertices that the surface (or another patch) already joins would give that edge a third.
  std::unordered_map<std::uint64_t, int> patch_edges;
  for (const Face& t : patches) {
    for (std::size_t k = 0; k < 3; ++k) ++patch_edges[EdgeKey(t[k], t[(k + 1) % 3])];
  }
  for (const auto& [key, count] : patch_edges) {
    const auto it = edges.find(key);
    if (count + (it == edges.end() ? 0 : it->second.first) != 2) {
      result.not_filled =
          "a patch would join two vertices that the surface already joins by an edge";
      return result;
    }
  }

  faces.insert(faces.end(), patches.begin(), patches.end());
  result.holes = holes;
  result.boundary_edges = boundary;
  result.new_faces = static_cast<int>(patches.size());
  result.area_fraction = fraction;
  return result;
}

}  // namespace softgrasp::mesh::internal
