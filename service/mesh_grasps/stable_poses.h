#pragma once
/// Stable resting poses of a rigid mesh on a horizontal table and their quasi-static
/// probabilities, by the method of meshpy's `stable_poses` (Dex-Net):
///   1. take the convex hull of the vertices (Qhull; coplanar hull triangles are merged into one
///      convex polygonal facet, so a cube has 6 facets, not 12);
///   2. give each hull facet a prior: the solid angle it subtends from the centre of mass (COM)
///      divided by 4 pi (the chance that a uniformly random drop direction hits it first);
///   3. a facet whose COM projection lies inside it (within a small tolerance) is a sink, i.e.
///      stable; any other facet topples over its edge closest to the projected COM onto the hull
///      neighbour across that edge;
///   4. follow the toppling graph to its sinks and add every prior to the sink it reaches.
/// Toppling always lowers the COM in exact arithmetic, so the graph has no cycles; should
/// rounding ever close a cycle, every facet on it goes to the facet on the cycle with the lowest
/// COM height (smallest COM-to-plane distance), which then counts as a sink.
/// Units: lengths in the mesh's units (metres by convention), angles in radians.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "service/core/status.h"
#include "service/mesh/mesh.h"

namespace softgrasp::mesh {

struct StablePoseOptions {
  /// Poses with probability <= this are dropped (0 keeps every pose with p > 0; Dex-Net's
  /// database uses 0.01).
  double min_probability = 0.0;
  /// Centre of mass in the object (mesh) frame. Unset: the volume centroid of the closed mesh
  /// (uniform density, as Dex-Net assumes). Must lie strictly inside the convex hull.
  std::optional<Eigen::Vector3d> center_of_mass;
};

/// One way the object can rest on the table: a convex-hull facet lies on the table plane.
struct StablePose {
  /// Share of random drops that end in this pose (the sum over all poses, before dropping those
  /// at or below min_probability, is 1).
  double probability = 0.0;
  /// Rotation taking object-frame vectors to the table frame (+z up), in which the resting
  /// facet's outward normal points to -z. Proper (det = +1). The in-plane heading is fixed by a
  /// convention (table +x is the object axis least aligned with the normal, projected into the
  /// facet plane); any rotation about table z gives the same pose.
  Eigen::Matrix3d table_from_object_rotation = Eigen::Matrix3d::Identity();
  /// Translation completing table_from_object_rotation so that the resting facet lies in the
  /// table plane z = 0 and the COM sits at (0, 0, com_height_m): p_table = R p_object + t.
  Eigen::Vector3d table_from_object_translation = Eigen::Vector3d::Zero();
  /// Outward unit normal of the resting facet, object frame.
  Eigen::Vector3d face_normal_object = Eigen::Vector3d::UnitZ();
  /// Distance from the COM to the resting facet's plane (mesh units, metres by convention).
  double com_height_m = 0.0;
  /// The resting facet as indices into mesh.vertices: a convex polygon (>= 3 corners; a corner of
  /// a merged facet may sit inside its outline by up to the merge tolerance), counter-clockwise
  /// seen from outside the object (from below the table), in the order of the hull's edges.
  std::vector<int> face_vertex_indices;
};

/// Volume centroid of a closed, outward-oriented mesh (sum of signed tetrahedra). Returns NaNs
/// when the enclosed volume is not positive.
Eigen::Vector3d VolumeCentroid(const TriangleMesh& mesh);

/// The stable poses of `mesh` sorted by probability, highest first (equal probabilities: by
/// face_vertex_indices, lexicographically). Only the vertices are used, plus the faces for the
/// default COM. Hull facets that are flat within 1e-6 of the bounding-box diagonal count as one
/// facet, and a COM projecting within that distance outside a facet still rests on it.
/// Deterministic; pure (no I/O, nothing printed).
/// Errors (kUnprocessable): fewer than 4 vertices, a non-finite coordinate, all vertices coplanar
/// or otherwise no 3-d hull (field "mesh"); no usable default COM (open or inward mesh) or a COM
/// not strictly inside the hull (field "center_of_mass"); kInvalidArgument for a negative or
/// non-finite min_probability (field "min_probability").
core::Result<std::vector<StablePose>> ComputeStablePoses(const TriangleMesh& mesh,
                                                         const StablePoseOptions& options = {});

}  // namespace softgrasp::mesh
