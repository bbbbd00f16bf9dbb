#include "service/gqcnn/clearance.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace softgrasp::gqcnn {
namespace {

// Narrows [*lo, *hi] to the du with |k du + offset| <= half.
void ClipToSlab(double k, double offset, double half, double* lo, double* hi) {
  if (k == 0.0) {
    if (!(std::fabs(offset) <= half)) *hi = *lo - 1.0;
    return;
  }
  double a = (-half - offset) / k;
  double b = (half - offset) / k;
  if (a > b) std::swap(a, b);
  *lo = std::max(*lo, a);
  *hi = std::min(*hi, b);
}

}  // namespace

GripperClearance MeasureClearance(const cv::Mat1f& depth_m, const cv::Mat1f& height_m,
                                  const GraspImagePose& pose, double fx_px,
                                  const core::Gripper& gripper, double min_height_m) {
  GripperClearance out;
  if (!(pose.depth_m > 0.0) || !(fx_px > 0.0)) return out;
  const double m_per_px = pose.depth_m / fx_px;
  // Every pixel the boxes touch counts: the boxes grown by half a pixel, tested at pixel centres.
  const double half_px_m = 0.5 * m_per_px;
  const double inner_m = 0.5 * gripper.opening_stroke_m - half_px_m;
  const double outer_m = 0.5 * gripper.opening_stroke_m + gripper.finger_thickness_m + half_px_m;
  const double half_width_m = 0.5 * gripper.finger_width_m + half_px_m;
  const double reach_px = std::hypot(outer_m, half_width_m) / m_per_px;
  const double ca = std::cos(pose.angle_rad), sa = std::sin(pose.angle_rad);
  const int u0 = std::max(0, static_cast<int>(std::floor(pose.center_u_px - reach_px)));
  const int u1 =
      std::min(depth_m.cols - 1, static_cast<int>(std::ceil(pose.center_u_px + reach_px)));
  const int v0 = std::max(0, static_cast<int>(std::floor(pose.center_v_px - reach_px)));
  const int v1 =
      std::min(depth_m.rows - 1, static_cast<int>(std::ceil(pose.center_v_px + reach_px)));
  const double outer_px = outer_m / m_per_px;
  const double half_width_px = half_width_m / m_per_px;
  for (int v = v0; v <= v1; ++v) {
    const float* depth_row = depth_m[v];
    const float* height_row = height_m[v];
    const double dv = v - pose.center_v_px;
    // Only the columns where this row crosses the rotated box, a pixel wider on each side (the
    // exact test below decides): the box covers about a fifth of the square around its reach.
    double lo = -reach_px;
    double hi = reach_px;
    ClipToSlab(ca, dv * sa, outer_px, &lo, &hi);
    ClipToSlab(-sa, dv * ca, half_width_px, &lo, &hi);
    if (lo > hi) continue;
    const int row_u0 = std::max(u0, static_cast<int>(std::floor(pose.center_u_px + lo)) - 1);
    const int row_u1 = std::min(u1, static_cast<int>(std::ceil(pose.center_u_px + hi)) + 1);
    for (int u = row_u0; u <= row_u1; ++u) {
      const float z = depth_row[u];
      if (!(z > 0.0F) || !std::isfinite(z) || !std::isfinite(height_row[u])) continue;
      const double du = u - pose.center_u_px;
      const double along_m = std::fabs(du * ca + dv * sa) * m_per_px;
      const double across_m = std::fabs(dv * ca - du * sa) * m_per_px;
      if (along_m > outer_m || across_m > half_width_m) continue;
      const double clearance = z - pose.depth_m;
      if (height_row[u] < min_height_m) {
        if (along_m >= inner_m) out.floor_m = std::min(out.floor_m, clearance);
        continue;
      }
      out.palm_m = std::min(out.palm_m, clearance);
      if (along_m >= inner_m) out.jaws_m = std::min(out.jaws_m, clearance);
    }
  }
  return out;
}

}  // namespace softgrasp::gqcnn
