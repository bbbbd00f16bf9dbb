#include "service/core/finger_clearance.h"

#include <algorithm>
#include <cmath>

namespace softgrasp::core {

FingerClearance::FingerClearance(const Scene& scene, const Camera& camera)
    : scene_(scene), camera_(camera) {
  double lo = 0;
  cv::minMaxIdx(scene.depth_filled_m, &lo, nullptr);
  nearest_depth_m_ = std::isfinite(lo) && lo > 0 ? lo : 0;
}

int FingerClearance::PointsInFingers(const Grasp& g, const Gripper& gripper) const {
  const cv::Mat1f& depth = scene_.depth_filled_m;
  const cv::Mat1f& height = scene_.height_m;
  const double tip_depth = g.p_CG_m[2];
  if (depth.empty() || !(tip_depth > 0) || !(nearest_depth_m_ > 0) || !std::isfinite(g.p_CG_m[0]) ||
      !std::isfinite(g.p_CG_m[1]) || !std::isfinite(tip_depth)) {
    return 0;
  }
  const double ca = std::cos(g.angle_rad);
  const double sa = std::sin(g.angle_rad);
  // The finger box grown by kMarginM on every side.
  const double half_width = gripper.finger_width_m / 2 + kMarginM;
  const double inner = g.opening_m / 2 - kMarginM;
  const double outer = g.opening_m / 2 + gripper.finger_thickness_m + kMarginM;
  const double top_depth = std::min(nearest_depth_m_, tip_depth);
  const float min_height = static_cast<float>(g.grasp_height_m + kToleranceM);
  int worst = 0;
  for (const double side : {-1.0, 1.0}) {
    // The column's image: its corners projected at the fingertips and at the nearest surface
    // (a fixed x-y point moves monotonically along its image ray with depth).
    double u_lo = camera_.width, u_hi = -1, v_lo = camera_.height, v_hi = -1;
    for (const double a : {side * inner, side * outer}) {
      for (const double b : {-half_width, half_width}) {
        const double x = g.p_CG_m[0] + a * ca - b * sa;
        const double y = g.p_CG_m[1] + a * sa + b * ca;
        for (const double z : {tip_depth, top_depth}) {
          const double u = camera_.cx + camera_.fx * x / z;
          const double v = camera_.cy + camera_.fy * y / z;
          u_lo = std::min(u_lo, u), u_hi = std::max(u_hi, u);
          v_lo = std::min(v_lo, v), v_hi = std::max(v_hi, v);
        }
      }
    }
    // Clamped in double first: a surface very near the camera projects far outside the image.
    const auto clamp_to = [](double x, int size) {
      return static_cast<int>(std::clamp(x, -1.0, static_cast<double>(size)));
    };
    const int u0 = std::max(0, clamp_to(std::floor(u_lo), depth.cols) - 1);
    const int u1 = std::min(depth.cols - 1, clamp_to(std::ceil(u_hi), depth.cols) + 1);
    const int v0 = std::max(0, clamp_to(std::floor(v_lo), depth.rows) - 1);
    const int v1 = std::min(depth.rows - 1, clamp_to(std::ceil(v_hi), depth.rows) + 1);
    int inside = 0;
    for (int v = v0; v <= v1; ++v) {
      const float* z_row = depth.ptr<float>(v);
      const float* h_row = height.ptr<float>(v);
      const double ry = (v - camera_.cy) / camera_.fy;
      for (int u = u0; u <= u1; ++u) {
        if (!(h_row[u] > min_height)) continue;
        const double z = z_row[u];
        if (!(z > 0)) continue;
        const double dx = z * (u - camera_.cx) / camera_.fx - g.p_CG_m[0];
        const double dy = z * ry - g.p_CG_m[1];
        const double a = side * (dx * ca + dy * sa);
        const double b = -dx * sa + dy * ca;
        if (a > inner && a <= outer && std::abs(b) <= half_width) ++inside;
      }
    }
    worst = std::max(worst, inside);
  }
  return worst;
}

}  // namespace softgrasp::core
