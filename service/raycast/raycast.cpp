#include "service/raycast/raycast.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace softgrasp::raycast {
namespace {

using core::ErrorCode;
using core::MakeError;

/// One Embree geometry, kept in double precision on our side: Embree finds the triangle in
/// float, and the hit is then recomputed exactly against this copy (see RefineHit).
struct Placed {
  int id = 0;
  std::vector<Eigen::Vector3d> vertices_w;
  std::vector<std::array<int, 3>> faces;
  /// Per face: the unit outward normal n and the plane offset n . v0 (so hits cost two dots).
  std::vector<Eigen::Vector3d> face_normals_w;
  std::vector<double> face_offsets_m;
};

Placed Place(int id, const mesh::TriangleMesh& mesh, const Eigen::Isometry3d& world_from_mesh) {
  Placed s;
  s.id = id;
  s.vertices_w.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) {
    s.vertices_w.push_back(world_from_mesh * Eigen::Vector3d(v[0], v[1], v[2]));
  }
  s.faces = mesh.faces;
  s.face_normals_w.reserve(s.faces.size());
  s.face_offsets_m.reserve(s.faces.size());
  for (const auto& f : s.faces) {
    const Eigen::Vector3d& v0 = s.vertices_w[f[0]];
    // Faces are counter-clockwise seen from outside, so (v1 - v0) x (v2 - v0) points outward
    // (Embree's Ng is the same cross product). Degenerate faces get a zero normal; Embree never
    // reports hits on them.
    Eigen::Vector3d n = (s.vertices_w[f[1]] - v0).cross(s.vertices_w[f[2]] - v0);
    const double length = n.norm();
    n = length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
    s.face_normals_w.push_back(n);
    s.face_offsets_m.push_back(n.dot(v0));
  }
  return s;
}

void CheckRay(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
              double max_distance_m, double min_distance_m) {
  const double norm = direction_w.norm();
  if (!origin_w.allFinite() || !direction_w.allFinite() || !(norm > 0.0)) {
    throw std::invalid_argument(
        "MeshRaycaster: ray origin/direction must be finite, direction "
        "non-zero");
  }
  // max may be +inf (an unbounded ray); NaN fails both comparisons.
  if (!(min_distance_m >= 0.0) || !std::isfinite(min_distance_m) ||
      !(max_distance_m >= min_distance_m)) {
    throw std::invalid_argument("MeshRaycaster: need 0 <= min_distance_m <= max_distance_m");
  }
}

RTCRay MakeRay(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& unit_direction_w,
               double max_distance_m, double min_distance_m) {
  RTCRay ray{};
  ray.org_x = static_cast<float>(origin_w.x());
  ray.org_y = static_cast<float>(origin_w.y());
  ray.org_z = static_cast<float>(origin_w.z());
  ray.dir_x = static_cast<float>(unit_direction_w.x());
  ray.dir_y = static_cast<float>(unit_direction_w.y());
  ray.dir_z = static_cast<float>(unit_direction_w.z());
  ray.tnear = static_cast<float>(min_distance_m);
  ray.tfar = static_cast<float>(max_distance_m);  // +inf stays +inf
  ray.mask = 0xFFFFFFFFu;
  ray.time = 0.0f;
  ray.flags = 0;
  return ray;
}

}  // namespace

std::optional<core::Error> CheckMesh(const mesh::TriangleMesh& mesh, const std::string& field) {
  if (mesh.vertices.empty() || mesh.faces.empty()) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "mesh is empty (" + std::to_string(mesh.vertices.size()) + " vertices, " +
                         std::to_string(mesh.faces.size()) + " faces); need a closed surface",
                     field);
  }
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (double c : mesh.vertices[i]) {
      if (!std::isfinite(c)) {
        return MakeError(ErrorCode::kInvalidArgument,
                         "vertex " + std::to_string(i) + " has a non-finite coordinate", field);
      }
    }
  }
  const auto num_vertices = static_cast<long long>(mesh.vertices.size());
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int index : mesh.faces[f]) {
      if (index < 0 || index >= num_vertices) {
        return MakeError(ErrorCode::kInvalidArgument,
                         "face " + std::to_string(f) + " has vertex index " +
                             std::to_string(index) + " outside [0, " +
                             std::to_string(num_vertices) + ")",
                         field);
      }
    }
  }
  return std::nullopt;
}

struct MeshRaycaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<Placed> surfaces;  ///< indexed by Embree geomID (attach order)

  // Embree reports errors through a callback, possibly from its build threads.
  std::mutex error_mutex;
  std::string first_error;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl() {
    if (scene != nullptr) rtcReleaseScene(scene);
    if (device != nullptr) rtcReleaseDevice(device);
  }

  static void OnError(void* user, RTCError code, const char* message) {
    auto* self = static_cast<Impl*>(user);
    std::lock_guard<std::mutex> lock(self->error_mutex);
    if (self->first_error.empty()) {
      self->first_error = "Embree error " + std::to_string(static_cast<int>(code)) + ": " +
                          (message != nullptr ? message : "");
    }
  }

  /// The Embree error since the last call (or the device's error code), if any.
  std::optional<core::Error> TakeError(const char* stage) {
    const RTCError code = rtcGetDeviceError(device);
    std::lock_guard<std::mutex> lock(error_mutex);
    if (code == RTC_ERROR_NONE && first_error.empty()) return std::nullopt;
    std::string message =
        std::string("Embree failed while ") + stage + ": " +
        (first_error.empty() ? "error code " + std::to_string(code) : first_error);
    first_error.clear();
    return MakeError(ErrorCode::kInternal, std::move(message));
  }

  /// Adds one triangle geometry (float copy for Embree) and records its surface at its geomID.
  std::optional<core::Error> Attach(Placed surface) {
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (geometry == nullptr) return TakeError("creating a geometry");
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), surface.vertices_w.size()));
    auto* indices = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), surface.faces.size()));
    if (vertices == nullptr || indices == nullptr) {
      rtcReleaseGeometry(geometry);
      return TakeError("allocating geometry buffers");
    }
    for (std::size_t i = 0; i < surface.vertices_w.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        vertices[3 * i + k] = static_cast<float>(surface.vertices_w[i][k]);
      }
    }
    for (std::size_t f = 0; f < surface.faces.size(); ++f) {
      for (int k = 0; k < 3; ++k) indices[3 * f + k] = static_cast<unsigned>(surface.faces[f][k]);
    }
    rtcCommitGeometry(geometry);
    const unsigned geom_id = rtcAttachGeometry(scene, geometry);
    rtcReleaseGeometry(geometry);  // the scene holds its own reference
    if (auto error = TakeError("attaching a geometry")) return error;
    if (geom_id != surfaces.size()) {
      return MakeError(ErrorCode::kInternal, "Embree assigned geometry id " +
                                                 std::to_string(geom_id) + ", expected " +
                                                 std::to_string(surfaces.size()));
    }
    surfaces.push_back(std::move(surface));
    return std::nullopt;
  }

  /// Recomputes the distance and the barycentrics in double on our copy of the triangle Embree
  /// found: float round-off in Embree's t would otherwise show as ~1e-7 relative depth error,
  /// and a flat table would not render at exactly the camera height.
  Hit RefineHit(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& unit_direction_w,
                const RTCHit& hit, float embree_t) const {
    const Placed& surface = surfaces[hit.geomID];
    const Eigen::Vector3d& normal_w = surface.face_normals_w[hit.primID];

    double t = embree_t;
    const double normal_dot_direction = normal_w.dot(unit_direction_w);
    // Skipped for (near-)parallel rays, where Embree's value is as good.
    if (std::abs(normal_dot_direction) > 1e-12) {
      t = (surface.face_offsets_m[hit.primID] - normal_w.dot(origin_w)) / normal_dot_direction;
    }
    Hit out;
    out.distance_m = t;
    out.point_w = origin_w + t * unit_direction_w;
    out.normal_w = normal_w;
    out.surface = static_cast<int>(hit.geomID);
    out.surface_id = surface.id;
    out.face = static_cast<int>(hit.primID);
    out.barycentric = Barycentric(surface, hit, out.point_w);
    return out;
  }

  /// The barycentric weights of point_w on the hit face, clamped into the triangle.
  static std::array<double, 3> Barycentric(const Placed& surface, const RTCHit& hit,
                                           const Eigen::Vector3d& point_w) {
    const auto& face = surface.faces[hit.primID];
    const Eigen::Vector3d& v0 = surface.vertices_w[face[0]];
    const Eigen::Vector3d e1 = surface.vertices_w[face[1]] - v0;
    const Eigen::Vector3d e2 = surface.vertices_w[face[2]] - v0;
    const Eigen::Vector3d p = point_w - v0;
    // Solve p = u e1 + v e2 in the least-squares sense (p lies in the plane up to round-off).
    const double d11 = e1.dot(e1);
    const double d12 = e1.dot(e2);
    const double d22 = e2.dot(e2);
    const double det = d11 * d22 - d12 * d12;
    double u = hit.u;
    double v = hit.v;
    if (det > 0.0) {
      const double p1 = p.dot(e1);
      const double p2 = p.dot(e2);
      u = (d22 * p1 - d12 * p2) / det;
      v = (d11 * p2 - d12 * p1) / det;
    }
    // A hit on an edge may land a hair outside the triangle; pull it back in.
    u = std::clamp(u, 0.0, 1.0);
    v = std::clamp(v, 0.0, 1.0 - u);
    return {1.0 - u - v, u, v};
  }
};

core::Result<MeshRaycaster> MeshRaycaster::Build(std::span<const Surface> surfaces) {
  for (std::size_t i = 0; i < surfaces.size(); ++i) {
    const std::string field = "surfaces[" + std::to_string(i) + "]";
    if (surfaces[i].mesh == nullptr) {
      return MakeError(ErrorCode::kInvalidArgument, "mesh is null", field);
    }
    if (!surfaces[i].world_from_mesh.matrix().allFinite()) {
      return MakeError(ErrorCode::kInvalidArgument, "world_from_mesh is not finite", field);
    }
    if (auto error = CheckMesh(*surfaces[i].mesh, field)) return *error;
  }

  auto impl = std::make_unique<Impl>();
  impl->device = rtcNewDevice(nullptr);
  if (impl->device == nullptr) {
    return MakeError(ErrorCode::kInternal, "Embree could not create a device (error code " +
                                               std::to_string(rtcGetDeviceError(nullptr)) + ")");
  }
  rtcSetDeviceErrorFunction(impl->device, &Impl::OnError, impl.get());
  impl->scene = rtcNewScene(impl->device);
  if (impl->scene == nullptr) {
    if (auto error = impl->TakeError("creating a scene")) return *error;
    return MakeError(ErrorCode::kInternal, "Embree could not create a scene");
  }
  // Robust: watertight traversal, so rays through shared edges never slip between triangles.
  rtcSetSceneFlags(impl->scene, RTC_SCENE_FLAG_ROBUST);
  // Hits depend only on which triangle Embree reports (distance and barycentrics are recomputed
  // in double), so the BVH layout matters only for exact ties; tests compare two builds
  // bitwise. HIGH quality measured no faster to render on our scenes, so the default stays.
  rtcSetSceneBuildQuality(impl->scene, RTC_BUILD_QUALITY_MEDIUM);

  for (const Surface& surface : surfaces) {
    if (auto error = impl->Attach(Place(surface.id, *surface.mesh, surface.world_from_mesh))) {
      return *error;
    }
  }
  rtcCommitScene(impl->scene);
  if (auto error = impl->TakeError("building the BVH")) return *error;
  return MeshRaycaster(std::move(impl));
}

MeshRaycaster::MeshRaycaster(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MeshRaycaster::MeshRaycaster(MeshRaycaster&&) noexcept = default;
MeshRaycaster& MeshRaycaster::operator=(MeshRaycaster&&) noexcept = default;
MeshRaycaster::~MeshRaycaster() = default;

std::optional<Hit> MeshRaycaster::Cast(const Eigen::Vector3d& origin_w,
                                       const Eigen::Vector3d& direction_w, double max_distance_m,
                                       double min_distance_m) const {
  if (!impl_) throw std::logic_error("MeshRaycaster::Cast on a moved-from raycaster");
  CheckRay(origin_w, direction_w, max_distance_m, min_distance_m);
  const Eigen::Vector3d unit_direction_w = direction_w.normalized();

  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit ray_hit{};
  ray_hit.ray = MakeRay(origin_w, unit_direction_w, max_distance_m, min_distance_m);
  ray_hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  ray_hit.hit.primID = RTC_INVALID_GEOMETRY_ID;
  ray_hit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &ray_hit);
  if (ray_hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  return impl_->RefineHit(origin_w, unit_direction_w, ray_hit.hit, ray_hit.ray.tfar);
}

void MeshRaycaster::CastMany(const Eigen::Vector3d& origin_w,
                             std::span<const Eigen::Vector3d> directions_w, double max_distance_m,
                             std::span<std::optional<Hit>> hits_out, double min_distance_m) const {
  if (!impl_) throw std::logic_error("MeshRaycaster::CastMany on a moved-from raycaster");
  if (hits_out.size() != directions_w.size()) {
    throw std::invalid_argument("MeshRaycaster::CastMany: hits_out.size() != directions_w.size()");
  }
  for (const Eigen::Vector3d& direction_w : directions_w) {
    CheckRay(origin_w, direction_w, max_distance_m, min_distance_m);
  }
  // Blocks of rays on the stack; Embree regroups a stream into SIMD packets internally.
  constexpr std::size_t kBlock = 64;
  std::array<RTCRayHit, kBlock> block;
  std::array<Eigen::Vector3d, kBlock> unit_directions_w;
  for (std::size_t first = 0; first < directions_w.size(); first += kBlock) {
    const std::size_t count = std::min(kBlock, directions_w.size() - first);
    for (std::size_t k = 0; k < count; ++k) {
      unit_directions_w[k] = directions_w[first + k].normalized();
      block[k] = RTCRayHit{};
      block[k].ray = MakeRay(origin_w, unit_directions_w[k], max_distance_m, min_distance_m);
      block[k].hit.geomID = RTC_INVALID_GEOMETRY_ID;
      block[k].hit.primID = RTC_INVALID_GEOMETRY_ID;
      block[k].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;  // a hint only; results are the same
    rtcIntersect1M(impl_->scene, &context, block.data(), static_cast<unsigned>(count),
                   sizeof(RTCRayHit));
    for (std::size_t k = 0; k < count; ++k) {
      if (block[k].hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        hits_out[first + k].reset();
      } else {
        hits_out[first + k] =
            impl_->RefineHit(origin_w, unit_directions_w[k], block[k].hit, block[k].ray.tfar);
      }
    }
  }
}

bool MeshRaycaster::Occluded(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                             double max_distance_m, double min_distance_m) const {
  if (!impl_) throw std::logic_error("MeshRaycaster::Occluded on a moved-from raycaster");
  CheckRay(origin_w, direction_w, max_distance_m, min_distance_m);
  const Eigen::Vector3d unit_direction_w = direction_w.normalized();

  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray = MakeRay(origin_w, unit_direction_w, max_distance_m, min_distance_m);
  rtcOccluded1(impl_->scene, &context, &ray);
  // Embree marks an occluded ray by setting tfar to -inf.
  return ray.tfar == -std::numeric_limits<float>::infinity();
}

}  // namespace softgrasp::raycast
