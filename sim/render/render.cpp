#include "sim/render/render.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <stdexcept>

namespace softgrasp::sim {
namespace {

// SR305 depth field of view (datasheet: 69 +- 3 x 54 +- 2 degrees).
constexpr double kSr305HorizontalFovDeg = 69.0;
constexpr double kSr305VerticalFovDeg = 54.0;
constexpr int kSr305Width = 640;
constexpr int kSr305Height = 480;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

double DegToRad(double deg) { return deg * std::numbers::pi / 180.0; }

/// Counter-based randomness: a pure function of (seed, pixel, stream), so noise does not depend
/// on loop order or threading. SplitMix64's finaliser, applied twice to mix the inputs.
std::uint64_t Mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Uniform in the open interval (0, 1).
double Uniform(std::uint64_t seed, std::uint64_t pixel, std::uint64_t stream) {
  const std::uint64_t h = Mix(seed ^ Mix(pixel * 4 + stream));
  return (static_cast<double>(h >> 11) + 0.5) * 0x1.0p-53;
}

/// Standard normal by Box-Muller from two independent uniforms of this pixel.
double Gaussian(std::uint64_t seed, std::uint64_t pixel) {
  const double u1 = Uniform(seed, pixel, 1);
  const double u2 = Uniform(seed, pixel, 2);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

enum Stream : std::uint64_t { kEdgeStream = 0 };

void CheckOptions(const RenderOptions& options) {
  const core::Camera& c = options.camera;
  if (!(c.fx > 0.0) || !(c.fy > 0.0) || !std::isfinite(c.fx) || !std::isfinite(c.fy) ||
      !std::isfinite(c.cx) || !std::isfinite(c.cy) || c.width <= 0 || c.height <= 0) {
    throw std::invalid_argument("Render: camera needs fx, fy > 0, finite cx, cy, a positive size");
  }
  if (!options.world_from_camera.matrix().allFinite()) {
    throw std::invalid_argument("Render: world_from_camera is not finite");
  }
  const NoiseModel& n = options.noise;
  if (n.enabled && (!std::isfinite(n.grazing_angle_deg) || !(n.edge_jump_m >= 0.0) ||
                    !(n.edge_dropout_probability >= 0.0 && n.edge_dropout_probability <= 1.0) ||
                    !(n.sigma_base_m >= 0.0) || !(n.sigma_quadratic_per_m >= 0.0) ||
                    !std::isfinite(n.sigma_base_m) || !std::isfinite(n.sigma_quadratic_per_m))) {
    throw std::invalid_argument("Render: noise model parameters out of range");
  }
}

/// True when a 4-neighbour of (row, col) is missing or more than jump_m away in depth.
bool NextToDepthJump(const cv::Mat1f& depth, int row, int col, double jump_m) {
  const float z = depth(row, col);
  constexpr int kOffsets[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
  for (const auto& o : kOffsets) {
    const int r = row + o[0];
    const int c = col + o[1];
    if (r < 0 || c < 0 || r >= depth.rows || c >= depth.cols) continue;  // image border: no jump
    const float zn = depth(r, c);
    if (std::isnan(zn) || std::abs(zn - z) > jump_m) return true;
  }
  return false;
}

}  // namespace

cv::Mat1f ApplyDepthNoise(const cv::Mat1f& clean, const cv::Mat1f& cos_incidence,
                          const NoiseModel& noise) {
  cv::Mat1f out = clean.clone();
  const double min_cos = std::cos(DegToRad(noise.grazing_angle_deg));
  for (int row = 0; row < clean.rows; ++row) {
    for (int col = 0; col < clean.cols; ++col) {
      const float z = clean(row, col);
      if (std::isnan(z)) continue;
      const auto pixel = static_cast<std::uint64_t>(row) * clean.cols + col;
      if (cos_incidence(row, col) < min_cos) {
        out(row, col) = kNaN;
        continue;
      }
      if (noise.edge_dropout_probability > 0.0 &&
          NextToDepthJump(clean, row, col, noise.edge_jump_m) &&
          Uniform(noise.seed, pixel, kEdgeStream) < noise.edge_dropout_probability) {
        out(row, col) = kNaN;
        continue;
      }
      const double sigma_m = noise.sigma_base_m + noise.sigma_quadratic_per_m * z * z;
      out(row, col) = static_cast<float>(z + sigma_m * Gaussian(noise.seed, pixel));
    }
  }
  return out;
}

core::Camera Sr305Camera() {
  core::Camera camera;
  camera.width = kSr305Width;
  camera.height = kSr305Height;
  // The image spans [-0.5, width - 0.5] in pixel-centre coordinates, so half the width (320 px)
  // subtends half the field of view.
  camera.fx = 0.5 * kSr305Width / std::tan(DegToRad(kSr305HorizontalFovDeg / 2.0));
  camera.fy = 0.5 * kSr305Height / std::tan(DegToRad(kSr305VerticalFovDeg / 2.0));
  camera.cx = 0.5 * kSr305Width - 0.5;
  camera.cy = 0.5 * kSr305Height - 0.5;
  return camera;
}

Eigen::Isometry3d OverheadCameraPose(double height_m) {
  Eigen::Matrix3d world_from_camera_rotation;
  // Columns: camera x -> +x_W, camera y (image down) -> -y_W, optical axis -> -z_W.
  world_from_camera_rotation << 1, 0, 0,  //
      0, -1, 0,                           //
      0, 0, -1;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = world_from_camera_rotation;
  pose.translation() = Eigen::Vector3d(0.0, 0.0, height_m);
  return pose;
}

RenderedViews Render(const SceneRaycaster& raycaster, const RenderOptions& options) {
  CheckOptions(options);
  const core::Camera& camera = options.camera;
  RenderedViews views;
  views.depth.depth_m = cv::Mat1f(camera.height, camera.width, kNaN);
  views.labels = cv::Mat1w(camera.height, camera.width, std::uint16_t{0});
  views.stiffness = cv::Mat1f(camera.height, camera.width, 0.0f);
  views.deformability = cv::Mat1f(camera.height, camera.width, 0.0f);
  cv::Mat1f cos_incidence(camera.height, camera.width, 0.0f);
  raycaster.CastPixelRays(camera, options.world_from_camera,
                          [&](int u, int v, double depth_m, double cos, const RayHit& hit) {
                            views.depth.depth_m(v, u) = static_cast<float>(depth_m);
                            cos_incidence(v, u) = static_cast<float>(cos);
                            if (hit.instance_id == 0) return;
                            views.labels(v, u) = static_cast<std::uint16_t>(hit.instance_id);
                            views.stiffness(v, u) = hit.stiffness;
                            views.deformability(v, u) = 1.0f - hit.stiffness;
                          });
  if (options.noise.enabled) {
    views.depth.depth_m = ApplyDepthNoise(views.depth.depth_m, cos_incidence, options.noise);
  }
  return views;
}

}  // namespace softgrasp::sim
