#pragma once
/// Prepares an uploaded, decoded mesh for grasp analysis: repairs what can be repaired without
/// changing the surface (and says so, one plain line per repair), refuses what cannot be analysed
/// with a message naming the problem and its count, converts to metres and optionally rescales
/// the object as Dex-Net does (smallest principal extent set to a target). Pure: no I/O, no
/// randomness; near-linear in the mesh size (sorting, hashing, union-find, one AABB tree).
///
/// Order: limits and input checks; weld equal vertices; drop faces that repeat a vertex, exact
/// duplicate faces and coincident opposite pairs; drop unused vertices; fill small holes (the one
/// repair that adds surface: scans of real objects have them); refuse other holes and
/// non-manifold edges or vertices; orient every piece consistently and outwards; keep the main
/// piece; remove zero-area faces by edge flips; scale; test self-intersections. The classes,
/// codes and messages are listed in docs/mesh-grasps.md ("Uploaded meshes").

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "service/core/status.h"
#include "service/mesh/mesh.h"
#include "service/mesh/mesh_check.h"

namespace softgrasp::mesh {

/// What to do when two faces of the prepared mesh cut through each other. The grasp analysis
/// (ray casts, contact normals, the hull for stable poses) still works approximately on such a
/// mesh; only its volume and centre of mass are off by the overlap.
enum class SelfIntersectionPolicy {
  kSkip,    ///< do not test
  kWarn,    ///< test, and add a line to PreparedMesh::warnings
  kRefuse,  ///< test, and refuse with kUnprocessable
};

struct PrepareOptions {
  /// Metres per file unit: 1 for m, 0.001 for mm. Finite and > 0, else kInvalidArgument
  /// (field "unit").
  double unit_scale_m = 1.0;
  /// Dex-Net's rescaling (obj_scaling_mode: min): after the unit conversion and the repairs,
  /// scale the mesh about the origin so that its smallest principal extent is this many metres
  /// (Dex-Net: 0.04). Finite and > 0, else kInvalidArgument (field "rescale").
  std::optional<double> rescale_min_extent_m;
  /// More input triangles -> kTooLarge. Counted before any repair.
  std::int64_t max_triangles = 200000;
  /// Size limits on the prepared mesh, in metres (after unit and rescale): smallest principal
  /// extent at least min_extent_m, largest at most max_extent_m, else kUnprocessable. They catch
  /// a wrong unit (a 100 mm part read as metres is 100 m long).
  double min_extent_m = 0.001;
  double max_extent_m = 2.0;
  /// Separate pieces outside the main (largest) piece are dropped as debris when together they
  /// hold at most this fraction of the total volume; more is refused (upload one object). Pieces
  /// entirely inside the main one are always dropped (the outer surface does not change).
  double max_debris_volume_fraction = 0.001;
  /// Holes are filled with triangles between their own boundary vertices (CGAL's
  /// triangulate_hole_polyline) when each has at most fill_hole_max_edges boundary edges and all
  /// of them together add at most fill_hole_max_area_fraction to the surface area; otherwise
  /// none is, and the mesh is refused as not closed. 0 edges: never fill. Scans of real objects
  /// (CGAL's pig, head, lion) have 6-205 boundary edges in 1-5 holes, adding 0.1-23 % (a statue's
  /// cut base); a cut through the middle of a solid adds up to its whole cross-section, while an
  /// open sheet (a mask, a single side) would add about 100 %.
  int fill_hole_max_edges = 500;
  double fill_hole_max_area_fraction = 0.5;
  SelfIntersectionPolicy self_intersections = SelfIntersectionPolicy::kWarn;
  /// The self-intersection test costs about 0.5 us per pair of faces whose bounding boxes
  /// overlap. They are counted first, up to max(self_intersection_min_box_pairs,
  /// self_intersection_box_pairs_per_face x faces); with more the test is skipped, with a
  /// warning, so its cost stays proportional to the mesh size. Plain meshes have 6-10 pairs per
  /// face (a 180k-face torus 6.5, the Dex-Net bar clamp 9.2); a triangle fan of n faces around one
  /// vertex (a finely divided disc) has n^2 / 2: a cylinder with two 12,500-face fan caps took
  /// 50 s.
  double self_intersection_box_pairs_per_face = 32.0;
  std::int64_t self_intersection_min_box_pairs = 100000;
};

/// How much each repair changed; zero when it was not needed.
struct RepairCounts {
  int welded_vertices = 0;      ///< used vertices merged into an earlier one at equal coordinates
  int unused_vertices = 0;      ///< vertices no kept face uses, dropped
  int degenerate_faces = 0;     ///< faces naming a vertex twice (after welding), dropped
  int duplicate_faces = 0;      ///< repeats of a face (or a side's reversed copy), dropped
  int opposite_face_pairs = 0;  ///< coincident faces with opposite orientations, dropped in pairs
  int reoriented_faces = 0;     ///< faces whose vertex order was reversed
  bool turned_inside_out = false;  ///< reoriented_faces is every face: the mesh was inside out
  int inner_pieces = 0;            ///< closed pieces inside the main one, dropped
  int debris_pieces = 0;           ///< small closed pieces outside the main one, dropped
  double dropped_volume_fraction = 0.0;  ///< of the total volume, in the dropped pieces
  int collinear_faces_removed = 0;       ///< zero-area faces removed by edge flips
  int filled_holes = 0;                  ///< holes closed with new faces
  int filled_hole_edges = 0;             ///< boundary edges of those holes
  int hole_faces_added = 0;              ///< faces added to close them
  double filled_area_fraction = 0.0;     ///< their area, of the surface area before filling
};

struct PreparedMesh {
  TriangleMesh mesh;  ///< metres; closed, 2-manifold, one piece, outward, no zero-area face
  /// One plain line per repair done, e.g. "welded 12 duplicate vertices (equal coordinates)".
  std::vector<std::string> repairs;
  /// Things that were not repaired and did not refuse the mesh (self-intersections, a skipped
  /// test).
  std::vector<std::string> warnings;
  RepairCounts counts;
  double unit_scale_m = 1.0;    ///< as asked
  double rescale_factor = 1.0;  ///< applied after the unit conversion (1 when not asked)
  /// Prepared coordinate = file coordinate * scale_applied (= unit_scale_m * rescale_factor).
  double scale_applied = 1.0;
  /// Principal axes of the solid (eigenvectors of its volume covariance), unit vectors in the
  /// mesh frame, ordered by extent ascending. Where principal moments are equal (a cube, a
  /// cylinder's cross-section) the axes in that plane are the file axes projected into it.
  std::array<std::array<double, 3>, 3> principal_axes{};
  /// Extents along principal_axes, after the unit conversion and before the rescale (metres).
  std::array<double, 3> extents_before_rescale_m{};
  std::array<double, 3> extents_m{};  ///< the same on the prepared mesh (metres)
  double volume_m3 = 0.0;
  std::array<double, 3> centroid_m{};  ///< centre of the solid (uniform density)
  /// CheckMesh of the prepared mesh (self-intersection fields filled when the test ran).
  MeshReport report;
};

/// Repairs, checks and scales `mesh` (coordinates in file units). Errors (field "mesh" unless
/// said): kInvalidArgument for a bad unit_scale_m ("unit") or rescale_min_extent_m ("rescale"),
/// a vertex index out of range or a non-finite coordinate (as ReadMesh); kTooLarge for
/// more than max_triangles triangles; kUnprocessable for a mesh that decodes but cannot be
/// analysed: no faces left, not closed (beyond the holes filled), not 2-manifold, not orientable,
/// separate pieces, no volume, too small or too large, zero-area faces that cannot be flipped away,
/// coordinates too large, and (kRefuse) self-intersections. kInternal only if the result fails its
/// own checks (a bug). Never throws on bad data.
/// @throws std::invalid_argument if a limit in `options` is not positive and finite.
core::Result<PreparedMesh> PrepareMesh(TriangleMesh mesh, const PrepareOptions& options = {});

}  // namespace softgrasp::mesh
