#pragma once
/// Ray queries against a whole simulated scene (support + objects, world frame W), over
/// raycast::MeshRaycaster (Embree 3).
/// Rendering (render.h) and grasp execution (sim/grasp) both ask their questions through this.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <span>

#include "service/core/depth.h"
#include "service/core/status.h"
#include "sim/scene/scene.h"

namespace softgrasp::sim {

/// What a ray hit first.
struct RayHit {
  double distance_m = 0.0;   ///< along the (unit) ray direction from its origin
  Eigen::Vector3d point_w;   ///< hit point in W
  Eigen::Vector3d normal_w;  ///< unit geometric normal of the hit triangle, facing outward
  int instance_id = 0;       ///< 0 = the support, else PlacedObject::instance_id
  float stiffness = 0.0f;    ///< quantised surface stiffness at the hit; 0 on the support
};

/// An immutable BVH over a snapshot of a scene. Build a new one after the scene changes (for
/// example after an object is picked). Thread-safe for concurrent queries once built.
class SceneRaycaster {
 public:
  /// Errors: kInvalidArgument when an object's mesh is empty, has bad indices, non-finite
  /// vertices, or a vertex_stiffness of the wrong length; kInternal when Embree fails.
  static core::Result<SceneRaycaster> Build(const SimScene& scene);

  SceneRaycaster(SceneRaycaster&&) noexcept;
  SceneRaycaster& operator=(SceneRaycaster&&) noexcept;
  ~SceneRaycaster();

  // The queries of raycast::MeshRaycaster, with the same arguments and preconditions; a hit
  // also says which instance it is on (0 = the support) and the surface stiffness there.
  std::optional<RayHit> Cast(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                             double max_distance_m, double min_distance_m = 0.0) const;
  /// @pre hits_out.size() == directions_w.size()
  void CastMany(const Eigen::Vector3d& origin_w, std::span<const Eigen::Vector3d> directions_w,
                double max_distance_m, std::span<std::optional<RayHit>> hits_out,
                double min_distance_m = 0.0) const;
  bool Occluded(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                double max_distance_m, double min_distance_m = 0.0) const;

  /// One ray per pixel centre of a camera (raycast::CastPixelRays): on_hit(u, v, depth_m,
  /// cos_incidence, hit) for each pixel whose ray hits, depth_m being z in the camera frame.
  using PixelCallback =
      std::function<void(int u, int v, double depth_m, double cos_incidence, const RayHit& hit)>;
  void CastPixelRays(const core::Camera& camera, const Eigen::Isometry3d& world_from_camera,
                     const PixelCallback& on_hit) const;

 private:
  struct Impl;
  explicit SceneRaycaster(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace softgrasp::sim
