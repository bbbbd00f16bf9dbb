#include "service/gqcnn/crop.h"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace softgrasp::gqcnn {
namespace {

constexpr int kHalfCrop = kCropSizePx / 2;

/// The taps of one output index along one axis: grid offsets (source pixels from the grasp
/// centre) and triangle weights.
struct Taps {
  int first = 0;  ///< grid offset of weights[0]
  std::vector<float> weights;
};

/// Output index k is centred at (k - 16) * scale; taps are the integer offsets strictly within
/// `scale` of it, weighted 1 - |d| / scale (a bilinear filter widened to the shrink factor).
std::array<Taps, kCropSizePx> MakeTaps(double scale) {
  std::array<Taps, kCropSizePx> taps;
  for (int k = 0; k < kCropSizePx; ++k) {
    const double c = (k - kHalfCrop) * scale;
    const int lo = static_cast<int>(std::floor(c - scale)) + 1;
    const int hi = static_cast<int>(std::ceil(c + scale)) - 1;
    taps[k].first = lo;
    for (int t = lo; t <= hi; ++t) {
      const double w = 1.0 - std::abs(t - c) / scale;
      taps[k].weights.push_back(static_cast<float>(std::max(w, 0.0)));
    }
  }
  return taps;
}

}  // namespace

void CropGrasp(const core::DepthImage& depth, const GraspImagePose& grasp, float* out,
               int source_crop_px) {
  if (!std::isfinite(grasp.center_u_px) || !std::isfinite(grasp.center_v_px) ||
      !std::isfinite(grasp.angle_rad)) {
    throw std::invalid_argument("CropGrasp: the grasp centre and angle must be finite");
  }
  if (source_crop_px < kCropSizePx || source_crop_px > 4096) {
    throw std::invalid_argument("CropGrasp: source_crop_px must be in [32, 4096]");
  }
  const double scale = static_cast<double>(source_crop_px) / kCropSizePx;
  // The taps depend on source_crop_px only; the planner calls this with one size, so one cached
  // table per thread.
  thread_local double cached_scale = -1.0;
  thread_local std::array<Taps, kCropSizePx> taps;
  if (cached_scale != scale) {
    taps = MakeTaps(scale);
    cached_scale = scale;
  }
  const int grid_lo = taps.front().first;
  const int grid_hi = taps.back().first + static_cast<int>(taps.back().weights.size()) - 1;
  const int n = grid_hi - grid_lo + 1;

  // Nearest samples of the rotated grid: value (0 when missing) and validity (0 or 1).
  thread_local std::vector<float> value;
  thread_local std::vector<float> valid;
  value.assign(static_cast<std::size_t>(n) * n, 0.0F);
  valid.assign(static_cast<std::size_t>(n) * n, 0.0F);
  const double cos_a = std::cos(grasp.angle_rad);
  const double sin_a = std::sin(grasp.angle_rad);
  const cv::Mat1f& image = depth.depth_m;
  const int width = image.cols;
  const int height = image.rows;
  // Raw row pointer and stride, hoisted: through cv::Mat the compiler reloads both per sample
  // (the stores below may alias the header as far as it can tell).
  const float* const pixels = image.empty() ? nullptr : image.ptr<float>(0);
  const std::size_t stride = image.empty() ? 0 : image.step1();
  // The grid is an affine image of a square: when its four corners round to pixels inside the
  // image, every sample does, and the loop needs no bounds checks.
  const auto inside = [&](double a, double b) {
    const double u = grasp.center_u_px + a * cos_a - b * sin_a + 0.5;
    const double v = grasp.center_v_px + a * sin_a + b * cos_a + 0.5;
    return u >= 0.0 && v >= 0.0 && u < width && v < height;
  };
  const bool all_inside = inside(grid_lo, grid_lo) && inside(grid_hi, grid_lo) &&
                          inside(grid_lo, grid_hi) && inside(grid_hi, grid_hi);
  for (int y = 0; y < n; ++y) {
    const double b = grid_lo + y;  // across the jaws: crop +v = image (-sin, cos)
    // Nearest pixel = truncation of (p + 0.5), which is floor for the non-negative values kept
    // (std::floor is a library call without SSE4.1 and dominated the crop's time).
    double pu = grasp.center_u_px + grid_lo * cos_a - b * sin_a + 0.5;
    double pv = grasp.center_v_px + grid_lo * sin_a + b * cos_a + 0.5;
    float* value_row = value.data() + static_cast<std::size_t>(y) * n;
    float* valid_row = valid.data() + static_cast<std::size_t>(y) * n;
    for (int x = 0; x < n; ++x, pu += cos_a, pv += sin_a) {
      if (!all_inside && (!(pu >= 0.0) || !(pv >= 0.0) || pu >= width || pv >= height)) continue;
      const float z = pixels[static_cast<std::size_t>(static_cast<int>(pv)) * stride +
                             static_cast<std::size_t>(static_cast<int>(pu))];
      // NaN, <= 0 and infinity are no reading (branch-free: depth images are full of holes).
      const bool ok = z > 0.0F && z < std::numeric_limits<float>::infinity();
      value_row[x] = ok ? z : 0.0F;
      valid_row[x] = ok ? 1.0F : 0.0F;
    }
  }

  // Separable filter over valid samples only: across the jaws (rows) first, whole sample rows
  // at a time...
  thread_local std::vector<float> col_sum;
  thread_local std::vector<float> col_weight;
  col_sum.assign(static_cast<std::size_t>(kCropSizePx) * n, 0.0F);
  col_weight.assign(static_cast<std::size_t>(kCropSizePx) * n, 0.0F);
  for (int i = 0; i < kCropSizePx; ++i) {
    const Taps& t = taps[i];
    float* sum_row = col_sum.data() + static_cast<std::size_t>(i) * n;
    float* weight_row = col_weight.data() + static_cast<std::size_t>(i) * n;
    for (std::size_t k = 0; k < t.weights.size(); ++k) {
      const float w = t.weights[k];
      const std::size_t y = static_cast<std::size_t>(t.first - grid_lo) + k;
      // Eigen's maps use SIMD here; GCC's -O2 cost model leaves the plain loop scalar.
      Eigen::Map<Eigen::ArrayXf>(sum_row, n) +=
          w * Eigen::Map<const Eigen::ArrayXf>(value.data() + y * n, n);
      Eigen::Map<Eigen::ArrayXf>(weight_row, n) +=
          w * Eigen::Map<const Eigen::ArrayXf>(valid.data() + y * n, n);
    }
  }
  // ...then along the axis (columns).
  for (int i = 0; i < kCropSizePx; ++i) {
    const float* sum_row = col_sum.data() + static_cast<std::size_t>(i) * n;
    const float* weight_row = col_weight.data() + static_cast<std::size_t>(i) * n;
    for (int j = 0; j < kCropSizePx; ++j) {
      const Taps& t = taps[j];
      const int x0 = t.first - grid_lo;
      double s = 0.0;
      double w = 0.0;
      for (std::size_t k = 0; k < t.weights.size(); ++k) {
        s += static_cast<double>(t.weights[k]) * sum_row[x0 + static_cast<int>(k)];
        w += static_cast<double>(t.weights[k]) * weight_row[x0 + static_cast<int>(k)];
      }
      out[i * kCropSizePx + j] = w > 1e-6 ? static_cast<float>(s / w) : 0.0F;
    }
  }
}

std::optional<GraspImagePose> ProjectGrasp(const core::Camera& camera,
                                           const Eigen::Vector3d& center_c,
                                           const Eigen::Vector3d& axis_c, double opening_m) {
  if (!center_c.allFinite() || !axis_c.allFinite() || !std::isfinite(opening_m) ||
      !(opening_m > 0.0) || !(axis_c.norm() > 0.0)) {
    return std::nullopt;
  }
  const Eigen::Vector3d half = 0.5 * opening_m * axis_c.normalized();
  const Eigen::Vector3d a = center_c - half;
  const Eigen::Vector3d b = center_c + half;
  if (!(center_c.z() > 0.0) || !(a.z() > 0.0) || !(b.z() > 0.0)) return std::nullopt;
  const auto project = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector2d(camera.cx + camera.fx * p.x() / p.z(),
                           camera.cy + camera.fy * p.y() / p.z());
  };
  const Eigen::Vector2d pc = project(center_c);
  const Eigen::Vector2d d = project(b) - project(a);
  if (!(d.norm() > 1e-9)) return std::nullopt;
  GraspImagePose pose;
  pose.center_u_px = pc.x();
  pose.center_v_px = pc.y();
  double angle = std::atan2(d.y(), d.x());
  if (angle < 0.0) angle += 2.0 * std::numbers::pi;
  if (angle >= 2.0 * std::numbers::pi) angle = 0.0;
  pose.angle_rad = angle;
  pose.depth_m = center_c.z();
  pose.width_px = d.norm();
  return pose;
}

}  // namespace softgrasp::gqcnn
