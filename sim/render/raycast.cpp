#include "sim/render/raycast.h"

#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "service/raycast/raycast.h"

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;

std::optional<core::Error> CheckObject(const PlacedObject& placed, std::size_t index) {
  const std::string field = "objects[" + std::to_string(index) + "]";
  // Labels are 16-bit images (render.h), and 0 is the support.
  if (placed.instance_id < 1 || placed.instance_id > std::numeric_limits<std::uint16_t>::max()) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "instance_id " + std::to_string(placed.instance_id) +
                         " is outside [1, 65535] (0 is the support)",
                     field + ".instance_id");
  }
  if (!placed.object) {
    return MakeError(ErrorCode::kInvalidArgument, "object is null", field + ".object");
  }
  if (!placed.world_from_object.matrix().allFinite()) {
    return MakeError(ErrorCode::kInvalidArgument, "world_from_object is not finite",
                     field + ".world_from_object");
  }
  const SimObject& object = *placed.object;
  if (auto error = raycast::CheckMesh(object.mesh_o, field + ".mesh_o")) return error;
  if (object.vertex_stiffness.size() != object.mesh_o.vertices.size()) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "vertex_stiffness has " + std::to_string(object.vertex_stiffness.size()) +
                         " entries for " + std::to_string(object.mesh_o.vertices.size()) +
                         " vertices",
                     field + ".vertex_stiffness");
  }
  for (float s : object.vertex_stiffness) {
    if (!std::isfinite(s)) {
      return MakeError(ErrorCode::kInvalidArgument, "vertex_stiffness has a non-finite score",
                       field + ".vertex_stiffness");
    }
  }
  return std::nullopt;
}

}  // namespace

struct SceneRaycaster::Impl {
  raycast::MeshRaycaster caster;
  /// Per surface after the support (surface 0, stiffness 0): the object, kept alive for its
  /// faces and vertex stiffness.
  std::vector<std::shared_ptr<const SimObject>> objects;

  explicit Impl(raycast::MeshRaycaster c) : caster(std::move(c)) {}

  RayHit ToRayHit(const raycast::Hit& hit) const {
    RayHit out;
    out.distance_m = hit.distance_m;
    out.point_w = hit.point_w;
    out.normal_w = hit.normal_w;
    out.instance_id = hit.surface_id;
    if (hit.surface > 0) {
      // QuantizeStiffness of the barycentric interpolation of the face's vertex scores.
      const SimObject& object = *objects[static_cast<std::size_t>(hit.surface) - 1];
      const std::vector<float>& stiffness = object.vertex_stiffness;
      const auto& face = object.mesh_o.faces[static_cast<std::size_t>(hit.face)];
      const double interpolated = hit.barycentric[0] * stiffness[face[0]] +
                                  hit.barycentric[1] * stiffness[face[1]] +
                                  hit.barycentric[2] * stiffness[face[2]];
      out.stiffness = QuantizeStiffness(static_cast<float>(interpolated));
    }
    return out;
  }
};

core::Result<SceneRaycaster> SceneRaycaster::Build(const SimScene& scene) {
  std::set<int> seen_ids;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    if (auto error = CheckObject(scene.objects[i], i)) return *error;
    if (!seen_ids.insert(scene.objects[i].instance_id).second) {
      return MakeError(
          ErrorCode::kInvalidArgument,
          "instance_id " + std::to_string(scene.objects[i].instance_id) + " is used twice",
          "objects[" + std::to_string(i) + "].instance_id");
    }
  }
  // The support in W is surface 0 (id 0), then the objects in order (id = instance id).
  const mesh::TriangleMesh support_w = SupportMesh(scene.support);
  if (auto error = raycast::CheckMesh(support_w, "support")) return *error;
  std::vector<raycast::Surface> surfaces;
  surfaces.push_back({0, &support_w, Eigen::Isometry3d::Identity()});
  for (const PlacedObject& placed : scene.objects) {
    surfaces.push_back({placed.instance_id, &placed.object->mesh_o, placed.world_from_object});
  }
  auto caster = raycast::MeshRaycaster::Build(surfaces);
  if (!caster.ok()) return caster.error();
  auto impl = std::make_unique<Impl>(std::move(caster).value());
  for (const PlacedObject& placed : scene.objects) impl->objects.push_back(placed.object);
  return SceneRaycaster(std::move(impl));
}

SceneRaycaster::SceneRaycaster(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SceneRaycaster::SceneRaycaster(SceneRaycaster&&) noexcept = default;
SceneRaycaster& SceneRaycaster::operator=(SceneRaycaster&&) noexcept = default;
SceneRaycaster::~SceneRaycaster() = default;

std::optional<RayHit> SceneRaycaster::Cast(const Eigen::Vector3d& origin_w,
                                           const Eigen::Vector3d& direction_w,
                                           double max_distance_m, double min_distance_m) const {
  if (!impl_) throw std::logic_error("SceneRaycaster::Cast on a moved-from raycaster");
  const auto hit = impl_->caster.Cast(origin_w, direction_w, max_distance_m, min_distance_m);
  if (!hit) return std::nullopt;
  return impl_->ToRayHit(*hit);
}

void SceneRaycaster::CastMany(const Eigen::Vector3d& origin_w,
                              std::span<const Eigen::Vector3d> directions_w, double max_distance_m,
                              std::span<std::optional<RayHit>> hits_out,
                              double min_distance_m) const {
  if (!impl_) throw std::logic_error("SceneRaycaster::CastMany on a moved-from raycaster");
  if (hits_out.size() != directions_w.size()) {
    throw std::invalid_argument("SceneRaycaster::CastMany: hits_out.size() != directions_w.size()");
  }
  std::vector<std::optional<raycast::Hit>> hits(directions_w.size());
  impl_->caster.CastMany(origin_w, directions_w, max_distance_m, hits, min_distance_m);
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (hits[i]) {
      hits_out[i] = impl_->ToRayHit(*hits[i]);
    } else {
      hits_out[i].reset();
    }
  }
}

bool SceneRaycaster::Occluded(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                              double max_distance_m, double min_distance_m) const {
  if (!impl_) throw std::logic_error("SceneRaycaster::Occluded on a moved-from raycaster");
  return impl_->caster.Occluded(origin_w, direction_w, max_distance_m, min_distance_m);
}

void SceneRaycaster::CastPixelRays(const core::Camera& camera,
                                   const Eigen::Isometry3d& world_from_camera,
                                   const PixelCallback& on_hit) const {
  if (!impl_) throw std::logic_error("SceneRaycaster::CastPixelRays on a moved-from raycaster");
  raycast::CastPixelRays(
      impl_->caster, camera, world_from_camera, [&](const raycast::PixelHit& pixel) {
        on_hit(pixel.u, pixel.v, pixel.depth_m, pixel.cos_incidence, impl_->ToRayHit(*pixel.hit));
      });
}

}  // namespace softgrasp::sim
