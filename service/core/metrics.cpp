#include "service/core/metrics.h"

#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace softgrasp::core {
namespace {

std::optional<Error> CheckPair(const cv::Mat1f& truth, const cv::Mat1f& predicted) {
  if (truth.empty() || predicted.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, "stiffness maps must not be empty", "map");
  }
  if (truth.size() != predicted.size()) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "stiffness maps differ in size (" + std::to_string(truth.cols) + "x" +
                         std::to_string(truth.rows) + " vs " + std::to_string(predicted.cols) +
                         "x" + std::to_string(predicted.rows) + ")",
                     "map");
  }
  if (!cv::checkRange(truth) || !cv::checkRange(predicted)) {
    return MakeError(ErrorCode::kInvalidArgument, "stiffness maps must be finite", "map");
  }
  return std::nullopt;
}

}  // namespace

Result<double> StiffnessRmse255(const cv::Mat1f& truth, const cv::Mat1f& predicted) {
  if (auto e = CheckPair(truth, predicted)) return *e;
  double sum = 0;
  for (int r = 0; r < truth.rows; ++r) {
    const float* t = truth.ptr<float>(r);
    const float* p = predicted.ptr<float>(r);
    for (int c = 0; c < truth.cols; ++c) {
      const double d = 255.0 * (static_cast<double>(t[c]) - p[c]);
      sum += d * d;
    }
  }
  return std::sqrt(sum / (static_cast<double>(truth.rows) * truth.cols));
}

double RegionSsim(const cv::Mat1f& truth, const cv::Mat1f& predicted) {
  constexpr double kC1 = (0.01 * 255) * (0.01 * 255);
  constexpr double kC2 = (0.03 * 255) * (0.03 * 255);
  const double n = static_cast<double>(truth.rows) * truth.cols;
  double sx = 0, sy = 0;
  for (int r = 0; r < truth.rows; ++r) {
    for (int c = 0; c < truth.cols; ++c) {
      sx += 255.0 * truth(r, c);
      sy += 255.0 * predicted(r, c);
    }
  }
  const double mx = sx / n, my = sy / n;
  double vx = 0, vy = 0, cxy = 0;
  for (int r = 0; r < truth.rows; ++r) {
    for (int c = 0; c < truth.cols; ++c) {
      const double dx = 255.0 * truth(r, c) - mx;
      const double dy = 255.0 * predicted(r, c) - my;
      vx += dx * dx;
      vy += dy * dy;
      cxy += dx * dy;
    }
  }
  vx /= n;
  vy /= n;
  cxy /= n;
  return ((2 * mx * my + kC1) * (2 * cxy + kC2)) / ((mx * mx + my * my + kC1) * (vx + vy + kC2));
}

Result<double> StiffnessMssim(const cv::Mat1f& truth, const cv::Mat1f& predicted, int grid) {
  if (auto e = CheckPair(truth, predicted)) return *e;
  if (grid < 1 || truth.rows < grid || truth.cols < grid) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "MSSIM needs grid >= 1 and maps of at least grid x grid pixels", "map");
  }
  double sum = 0;
  for (int i = 0; i < grid; ++i) {
    const int r0 = i * truth.rows / grid, r1 = (i + 1) * truth.rows / grid;
    for (int j = 0; j < grid; ++j) {
      const int c0 = j * truth.cols / grid, c1 = (j + 1) * truth.cols / grid;
      const cv::Rect roi(c0, r0, c1 - c0, r1 - r0);
      sum += RegionSsim(truth(roi), predicted(roi));
    }
  }
  return sum / (grid * grid);
}

cv::Mat1b GraspRegionMask(cv::Size size, const Grasp& grasp) {
  cv::Mat1b mask(size, 0);
  const double half_len = grasp.opening_px / 2;
  const double half_w = grasp.finger_width_px / 2;
  const double cs = std::cos(grasp.angle_rad), sn = std::sin(grasp.angle_rad);
  const double reach = std::hypot(half_len, half_w) + 1;
  const int v0 = std::max(0, static_cast<int>(std::floor(grasp.center_v_px - reach)));
  const int v1 = std::min(size.height - 1, static_cast<int>(std::ceil(grasp.center_v_px + reach)));
  const int u0 = std::max(0, static_cast<int>(std::floor(grasp.center_u_px - reach)));
  const int u1 = std::min(size.width - 1, static_cast<int>(std::ceil(grasp.center_u_px + reach)));
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const double du = u - grasp.center_u_px, dv = v - grasp.center_v_px;
      const double a = du * cs + dv * sn, b = -du * sn + dv * cs;
      if (std::abs(a) <= half_len && std::abs(b) <= half_w) mask(v, u) = 255;
    }
  }
  return mask;
}

double MeanStiffnessInGraspRegion(const cv::Mat1f& stiffness, const Grasp& grasp) {
  const cv::Mat1b mask = GraspRegionMask(stiffness.size(), grasp);
  double sum = 0;
  int count = 0;  // R of eq. 3.13
  for (int v = 0; v < stiffness.rows; ++v) {
    for (int u = 0; u < stiffness.cols; ++u) {
      if (mask(v, u) == 0 || !(stiffness(v, u) > 0)) continue;
      sum += stiffness(v, u);
      ++count;
    }
  }
  return count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace softgrasp::core
