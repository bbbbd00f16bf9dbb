#pragma once
/// Antipodal parallel-jaw grasps on a triangle mesh, after Dex-Net 2.0's `AntipodalGraspSampler`,
/// with Embree ray queries (service/raycast) in place of the signed distance field.
///
/// Units: metres and radians, everything in the mesh's own frame. Pure and seeded: the same mesh
/// and parameters give the same grasps in the same order.
///
///   auto caster = raycast::MeshRaycaster::Build(surfaces);  // the mesh alone, identity pose
///   auto grasps = mesh::SampleAntipodalGrasps(mesh, caster.value(), params);

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "service/mesh/mesh.h"
#include "service/mesh_grasps/grasp_quality.h"
#include "service/raycast/raycast.h"

namespace softgrasp::mesh {

/// A parallel-jaw grasp: the jaws close along `axis` through `center_m` and touch the surface at
/// `a` (the jaw on the +axis side) and `b` (the -axis side).
struct JawGrasp {
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();  ///< midway between the contacts
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();     ///< unit, from b towards a
  double width_m = 0.0;                                ///< distance between the contacts
  Contact a;
  Contact b;
};

/// Dex-Net's sampler parameters (REFERENCE §1.4), for a gripper of stroke `max_width_m`.
struct AntipodalParams {
  double friction_coefficient = 0.5;  ///< mu of the cone the axis is drawn in and checked
  double max_width_m = 0.05;          ///< the gripper's stroke
  double min_contact_distance_m = 0.0025;
  int target_num_grasps = 100;
  /// Surface points tried at most (each gives at most one grasp); sampling stops earlier once
  /// `target_num_grasps` are kept.
  int max_surface_points = 4000;
  /// Coverage: a grasp closer than this to a kept one (Dex-Net's grasp distance: centre distance
  /// + 0.05 m x axis angle / (pi / 2)) is dropped. 0 keeps near-duplicates.
  double min_grasp_distance_m = 0.002;
  std::uint64_t seed = 0;
};

/// Where two point jaws closing along `axis` through `center_m`, starting `max_width_m / 2` on
/// either side, first touch the surfaces of `caster` (each jaw travels to the centre at most).
/// nullopt when either jaw touches nothing or starts inside the object (its first hit is the
/// inside of a face: the object is wider than the stroke there). `axis` need not be unit length.
std::optional<std::pair<Contact, Contact>> CloseJaws(const raycast::MeshRaycaster& caster,
                                                     const Eigen::Vector3d& center_m,
                                                     const Eigen::Vector3d& axis,
                                                     double max_width_m);

/// Force-closure antipodal grasps, in sampling order, at most `target_num_grasps`. For each
/// surface point (drawn by area, uniformly on its triangle) with outward normal n, an axis is
/// drawn in the friction cone about -n (v = -n + r (cos t t1 + sin t t2), r ~ U(0, mu)); the ray
/// along v from the point gives the opposite surface, the jaws close along v about the midpoint
/// (CloseJaws), and the grasp is kept when its width is in [min_contact_distance, max_width], it
/// is in force closure (ForceClosure with mu) and it is far enough from the grasps kept. Errors:
/// kInvalidArgument for parameters out of range (field names the parameter).
core::Result<std::vector<JawGrasp>> SampleAntipodalGrasps(const TriangleMesh& mesh,
                                                          const raycast::MeshRaycaster& caster,
                                                          const AntipodalParams& params);

/// Dex-Net's distance between two grasps: |centre_a - centre_b| + 0.05 m x angle between the
/// axes (sign ignored) / (pi / 2).
double GraspDistance(const JawGrasp& a, const JawGrasp& b);

}  // namespace softgrasp::mesh
