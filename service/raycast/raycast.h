#pragma once
/// Ray queries against triangle meshes placed in a world frame W, on Embree 3. Embree finds the
/// triangle in float; the distance, point and barycentrics are then recomputed in double on our
/// copy of that triangle, so a flat surface renders at exactly its height.
///
///   std::vector<raycast::Surface> surfaces{{7, &mesh, world_from_mesh}};
///   auto caster = raycast::MeshRaycaster::Build(surfaces);
///   if (auto hit = caster.value().Cast(origin_w, direction_w, 1.0)) use(hit->point_w);

#include <Eigen/Geometry>
#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "service/core/depth.h"
#include "service/core/status.h"
#include "service/mesh/mesh.h"

namespace softgrasp::raycast {

/// One mesh to cast against: its vertices are mapped into W by world_from_mesh. `id` is what
/// hits on it report (ids need not be distinct).
struct Surface {
  int id = 0;
  const mesh::TriangleMesh* mesh = nullptr;
  Eigen::Isometry3d world_from_mesh = Eigen::Isometry3d::Identity();
};

/// What a ray hit first.
struct Hit {
  double distance_m = 0.0;   ///< along the (unit) ray direction from its origin
  Eigen::Vector3d point_w;   ///< hit point in W
  Eigen::Vector3d normal_w;  ///< unit geometric normal of the hit triangle, facing outward
  int surface = 0;           ///< index of the surface in Build's list
  int surface_id = 0;        ///< that surface's id
  int face = 0;              ///< triangle index in the surface's mesh
  /// Barycentric weights of the hit on the triangle's vertices (faces[face][0..2]), in [0, 1]
  /// and summing to 1.
  std::array<double, 3> barycentric{1.0, 0.0, 0.0};
};

/// Why `mesh` cannot be cast against (no vertices or faces, a face index out of range, a
/// non-finite vertex), as kInvalidArgument naming `field`; nullopt when it can.
std::optional<core::Error> CheckMesh(const mesh::TriangleMesh& mesh, const std::string& field);

/// An immutable BVH over the surfaces. Thread-safe for concurrent queries once built.
class MeshRaycaster {
 public:
  /// Copies the surfaces (the meshes need not outlive the caster). Errors (kInvalidArgument,
  /// field "surfaces[i]"): a null or empty mesh, a face index out of range, a non-finite vertex
  /// or pose; kInternal when Embree fails.
  static core::Result<MeshRaycaster> Build(std::span<const Surface> surfaces);

  MeshRaycaster(MeshRaycaster&&) noexcept;
  MeshRaycaster& operator=(MeshRaycaster&&) noexcept;
  ~MeshRaycaster();

  /// The first hit along origin_w + t * direction_w for t in [min_distance_m, max_distance_m];
  /// direction_w need not be unit length (it is normalised; distances are in metres).
  /// @throws std::invalid_argument on a non-finite origin or direction, a zero direction, or
  ///   distances not satisfying 0 <= min <= max (max may be +inf).
  std::optional<Hit> Cast(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                          double max_distance_m, double min_distance_m = 0.0) const;

  /// One ray per direction from a common origin (a camera): hits_out[i] is what
  /// Cast(origin_w, directions_w[i], ...) returns, through Embree's ray streams (faster than a
  /// loop of Cast for coherent rays). @pre hits_out.size() == directions_w.size()
  void CastMany(const Eigen::Vector3d& origin_w, std::span<const Eigen::Vector3d> directions_w,
                double max_distance_m, std::span<std::optional<Hit>> hits_out,
                double min_distance_m = 0.0) const;

  /// True when any surface crosses the ray between min_distance_m and max_distance_m.
  bool Occluded(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                double max_distance_m, double min_distance_m = 0.0) const;

 private:
  struct Impl;
  explicit MeshRaycaster(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// What the ray through one pixel centre of a pinhole camera hit.
struct PixelHit {
  int u = 0;                   ///< image column
  int v = 0;                   ///< image row
  double depth_m = 0.0;        ///< z of the hit in the camera frame (not the range along the ray)
  double cos_incidence = 0.0;  ///< |cos| of the angle between the ray and the surface normal
  const Hit* hit = nullptr;    ///< the hit itself (valid during the callback)
};

/// Casts one ray through every pixel centre of `camera` placed at `world_from_camera` (camera
/// frame in OpenCV convention: x right, y down, z along the optical axis; pixel (u, v)'s ray
/// passes through ((u - cx) / fx, (v - cy) / fy, 1), the back-projection of
/// service/core/preprocess.cpp) and calls `on_hit` for each pixel whose ray hits, in 8 x 8 pixel
/// tiles (coherent rays for Embree's ray streams). The simulator's renderer and the mesh grasp
/// previews both draw through this.
/// @throws std::invalid_argument for fx, fy <= 0, non-finite cx, cy, a non-positive size or a
///   non-finite pose.
void CastPixelRays(const MeshRaycaster& caster, const core::Camera& camera,
                   const Eigen::Isometry3d& world_from_camera,
                   const std::function<void(const PixelHit&)>& on_hit);

/// The depth image (z in the camera frame, metres; NaN where nothing was hit) of CastPixelRays.
core::DepthImage RenderDepth(const MeshRaycaster& caster, const core::Camera& camera,
                             const Eigen::Isometry3d& world_from_camera);

}  // namespace softgrasp::raycast
