#pragma once
/// Alpha-shape surface reconstruction that always returns a closed, 2-manifold, connected,
/// outward-oriented triangle mesh (or an error), built on CGAL's 3D Delaunay triangulation.
///
/// The solid is the regularized alpha shape: the union of the Delaunay tetrahedra whose
/// circumsphere has radius <= alpha (exactly CGAL::Fixed_alpha_shape_3's INTERIOR cells, decided
/// with the kernel's exact compare_squared_radius_3 against alpha^2). Alpha is a RADIUS in the
/// units of the points; CGAL's own "alpha" is its square. The solid is then made valid:
///   1. keep its largest face-connected piece (by volume), drop the others;
///   2. fill enclosed cavities (exterior tetrahedra not reachable from outside the hull);
///   3. at a non-manifold edge (several solid wedges around it) keep the largest wedge;
///   4. at a non-manifold vertex keep its largest solid fan; if the solid is one fan but the
///      outside reaches the vertex in several places, fill the extra outside fans when every
///      tetrahedron in them has circumradius <= raise_factor * alpha, else cut the solid away
///      from the vertex;
///   5. repeat 2-4 around whatever changed until nothing does (each tetrahedron changes at most
///      once, so this terminates), then drop pieces the repair cut off.
/// If the largest piece holds less than `min_piece_volume_fraction` of the solid (or the repair
/// drops more), the solid is empty, the repair does not settle, or the result fails CheckMesh,
/// alpha is multiplied by `raise_factor` and everything is redone on the same triangulation (up
/// to `max_raises` times). Everything is reported. See docs/fractals.md.
/// The result's facets are facets of one Delaunay triangulation of the exact input points, so
/// they never cross each other; CheckMesh runs here without its self-intersection test.

#include <array>
#include <cstdint>
#include <vector>

#include "service/core/status.h"
#include "service/mesh/mesh.h"

namespace softgrasp::mesh {

struct AlphaShapeOptions {
  double alpha = 0.3;                      ///< ball radius, same units as the points (> 0)
  double raise_factor = 1.5;               ///< alpha grows by this factor per retry (> 1)
  int max_raises = 24;                     ///< retries before giving up (>= 0)
  double min_piece_volume_fraction = 0.5;  ///< largest piece must hold this share of the solid
  int max_repair_rounds = 32;              ///< repair passes per alpha before raising
};

struct AlphaShapeResult {
  /// Vertices are a subset of the input points (exact copies). Canonical order: faces sorted by
  /// their input-point indices (rotated to start at the smallest), vertices numbered in order of
  /// first appearance in the faces. So the result depends only on the triangulation.
  TriangleMesh mesh;
  double alpha_requested = 0.0;
  double alpha_used = 0.0;  ///< alpha_requested * raise_factor^raises
  int raises = 0;           ///< how many times alpha was raised
  int pieces_dropped = 0;   ///< solid pieces dropped at alpha_used (small pieces + pinched-off)
  double dropped_volume_fraction = 0.0;  ///< share of the raw alpha solid's volume dropped
  int cells_removed = 0;                 ///< tetrahedra removed to make edges/vertices manifold
  int cells_filled = 0;                  ///< tetrahedra added (cavities, pinched tunnels)
  int repair_rounds = 0;                 ///< passes until the solid settled at alpha_used
  double volume = 0.0;                   ///< enclosed volume, units^3 (> 0)
};

/// Reconstructs a closed mesh from `points` (see the file comment).
/// Errors: kUnprocessable (field "points") when fewer than 4 distinct points, all points
/// coplanar, a non-finite coordinate, or no valid solid up to the last alpha.
/// @throws std::invalid_argument if options are out of range (alpha <= 0 or not finite,
///         raise_factor <= 1, max_raises < 0, fraction outside [0, 1], max_repair_rounds < 1).
core::Result<AlphaShapeResult> ReconstructAlphaShape(
    const std::vector<std::array<double, 3>>& points, const AlphaShapeOptions& options);

/// The raw boundary of the regularized alpha solid at `alpha` (no piece selection, no repair):
/// every facet between a tetrahedron with circumradius <= alpha and one that is not, oriented
/// away from the solid. Closed by construction but possibly non-manifold and in several pieces.
/// Indices are into `points` (no renumbering). For tests and diagnostics.
/// Errors as ReconstructAlphaShape.  @throws std::invalid_argument if alpha <= 0.
core::Result<std::vector<std::array<int, 3>>> RawAlphaShapeFacets(
    const std::vector<std::array<double, 3>>& points, double alpha);

}  // namespace softgrasp::mesh
