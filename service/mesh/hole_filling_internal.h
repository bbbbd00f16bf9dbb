#pragma once
/// Internal to softgrasp::mesh (used by mesh_prepare.cpp): closes small holes of a scanned mesh
/// with CGAL's hole triangulation (Liepa 2003, `triangulate_hole_polyline`), using the hole's own
/// boundary vertices only. Scans of real objects are often closed but for a few holes where the
/// scanner saw nothing (under the object, inside a crease); the grasp analysis needs a solid.

#include <array>
#include <string>
#include <vector>

namespace softgrasp::mesh::internal {

struct HoleFillLimits {
  int max_boundary_edges = 0;      ///< per hole; a longer boundary is an open side, not a hole
  double max_area_fraction = 0.0;  ///< all patches together, of the mesh's surface area
};

struct HoleFillResult {
  int holes = 0;           ///< filled
  int boundary_edges = 0;  ///< on the filled holes
  int new_faces = 0;
  double area_fraction = 0.0;  ///< of the surface area before filling
  /// Empty when every hole was filled or there was none; otherwise why nothing was filled (the
  /// caller's "not closed" refusal quotes it).
  std::string not_filled;
};

/// Finds the boundary loops of `faces` (edges with one face, chained along the faces' own
/// direction) and, when every loop is a simple cycle within `limits`, appends patch triangles
/// oriented against their neighbours. All or nothing: when any hole cannot be filled, `faces` is
/// unchanged. Edges with more than two faces are left alone (the caller refuses them).
HoleFillResult FillHoles(const std::vector<std::array<double, 3>>& positions,
                         std::vector<std::array<int, 3>>& faces, const HoleFillLimits& limits);

}  // namespace softgrasp::mesh::internal
