#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>

#include "service/raycast/raycast.h"

namespace softgrasp::raycast {

void CastPixelRays(const MeshRaycaster& caster, const core::Camera& camera,
                   const Eigen::Isometry3d& world_from_camera,
                   const std::function<void(const PixelHit&)>& on_hit) {
  if (!(camera.fx > 0.0) || !(camera.fy > 0.0) || !std::isfinite(camera.fx) ||
      !std::isfinite(camera.fy) || !std::isfinite(camera.cx) || !std::isfinite(camera.cy) ||
      camera.width <= 0 || camera.height <= 0) {
    throw std::invalid_argument(
        "CastPixelRays: camera needs finite fx, fy > 0, finite cx, cy and a positive size");
  }
  if (!world_from_camera.matrix().allFinite()) {
    throw std::invalid_argument("CastPixelRays: world_from_camera is not finite");
  }
  const Eigen::Matrix3d world_from_camera_rotation = world_from_camera.linear();
  const Eigen::Vector3d origin_w = world_from_camera.translation();
  constexpr int kTile = 8;
  constexpr double kUnbounded = std::numeric_limits<double>::infinity();
  std::array<Eigen::Vector3d, kTile * kTile> rays_w;
  std::array<double, kTile * kTile> ray_c_norms;
  std::array<std::optional<Hit>, kTile * kTile> hits;
  for (int tile_v = 0; tile_v < camera.height; tile_v += kTile) {
    for (int tile_u = 0; tile_u < camera.width; tile_u += kTile) {
      const int rows = std::min(kTile, camera.height - tile_v);
      const int cols = std::min(kTile, camera.width - tile_u);
      for (int i = 0; i < rows * cols; ++i) {
        const int u = tile_u + i % cols;
        const int v = tile_v + i / cols;
        const Eigen::Vector3d ray_c((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
        rays_w[i] = world_from_camera_rotation * ray_c;
        ray_c_norms[i] = ray_c.norm();
      }
      const auto count = static_cast<std::size_t>(rows * cols);
      caster.CastMany(origin_w, std::span(rays_w.data(), count), kUnbounded,
                      std::span(hits.data(), count));
      for (int i = 0; i < rows * cols; ++i) {
        if (!hits[i]) continue;
        PixelHit pixel;
        pixel.u = tile_u + i % cols;
        pixel.v = tile_v + i / cols;
        // The unit ray's component along the optical axis is 1 / |ray_c|: depth is z, not range.
        pixel.depth_m = hits[i]->distance_m / ray_c_norms[i];
        pixel.cos_incidence = std::abs(hits[i]->normal_w.dot(rays_w[i])) / ray_c_norms[i];
        pixel.hit = &*hits[i];
        on_hit(pixel);
      }
    }
  }
}

core::DepthImage RenderDepth(const MeshRaycaster& caster, const core::Camera& camera,
                             const Eigen::Isometry3d& world_from_camera) {
  core::DepthImage depth;
  depth.depth_m = cv::Mat1f(std::max(camera.height, 0), std::max(camera.width, 0),
                            std::numeric_limits<float>::quiet_NaN());
  CastPixelRays(caster, camera, world_from_camera, [&](const PixelHit& pixel) {
    depth.depth_m(pixel.v, pixel.u) = static_cast<float>(pixel.depth_m);
  });
  return depth;
}

}  // namespace softgrasp::raycast
