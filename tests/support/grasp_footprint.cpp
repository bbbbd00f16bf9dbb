#include "tests/support/grasp_footprint.h"

#include <algorithm>
#include <cmath>

namespace softgrasp::testing {

GraspFootprint RasteriseGrasp(const core::Grasp& grasp, cv::Size image_size, double shrink_px) {
  GraspFootprint fp{cv::Mat1b::zeros(image_size), cv::Mat1b::zeros(image_size)};
  const double half_open = grasp.opening_px / 2;
  const double outer = half_open + grasp.finger_thickness_px - shrink_px;
  const double half_width = grasp.finger_width_px / 2 - shrink_px;
  const double c = std::cos(grasp.angle_rad);
  const double s = std::sin(grasp.angle_rad);
  const int radius = static_cast<int>(std::ceil(std::hypot(outer, half_width))) + 1;
  const int u0 = static_cast<int>(std::lround(grasp.center_u_px));
  const int v0 = static_cast<int>(std::lround(grasp.center_v_px));
  for (int v = std::max(0, v0 - radius); v <= std::min(image_size.height - 1, v0 + radius); ++v) {
    for (int u = std::max(0, u0 - radius); u <= std::min(image_size.width - 1, u0 + radius); ++u) {
      const double du = u - grasp.center_u_px;
      const double dv = v - grasp.center_v_px;
      const double a = std::abs(du * c + dv * s);
      const double b = std::abs(-du * s + dv * c);
      if (b > half_width) continue;
      if (a <= half_open - shrink_px) fp.closing(v, u) = 255;
      if (a > half_open + shrink_px && a <= outer) fp.fingers(v, u) = 255;
    }
  }
  return fp;
}

}  // namespace softgrasp::testing
