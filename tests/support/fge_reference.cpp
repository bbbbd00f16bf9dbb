// Reference FGE: rotated templates, cv::filter2D at full resolution. Slow on purpose; it is the
// yardstick for the fast path (tests) and the benchmark baseline. See docs/fge.md.
#include "tests/support/fge_reference.h"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "service/core/fge_geometry.h"

namespace softgrasp::core {
namespace {

constexpr double kSlackPx = 1e-9;  // same rounding slack as fge_detail::RasteriseTemplates

struct Kernels {
  cv::Mat1f contact;  // T_t
  cv::Mat1f fingers;  // T_c
};

// Pixel-centre rule: kernel offset (dx, dy) has closing-axis coordinate a = dx cos + dy sin and
// cross coordinate b = -dx sin + dy cos; T_t is |a| <= opening/2, |b| <= width/2; T_c is
// opening/2 < |a| <= opening/2 + thickness, |b| <= width/2.
Kernels RotatedKernels(const GripperPx& g, double angle_rad) {
  const double half_open = g.opening_px / 2 + kSlackPx;
  const double outer = g.opening_px / 2 + g.finger_thickness_px + kSlackPx;
  const double half_width = g.finger_width_px / 2 + kSlackPx;
  const int radius = static_cast<int>(std::ceil(std::hypot(outer, half_width))) + 1;
  const double c = std::cos(angle_rad);
  const double s = std::sin(angle_rad);
  Kernels k{cv::Mat1f::zeros(2 * radius + 1, 2 * radius + 1),
            cv::Mat1f::zeros(2 * radius + 1, 2 * radius + 1)};
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const double a = std::abs(dx * c + dy * s);
      const double b = std::abs(-dx * s + dy * c);
      if (b > half_width) continue;
      if (a <= half_open)
        k.contact(dy + radius, dx + radius) = 1.0f;
      else if (a <= outer)
        k.fingers(dy + radius, dx + radius) = 1.0f;
    }
  }
  return k;
}

cv::Mat1f GrowByOnePixel(const cv::Mat1f& values) {
  cv::Mat1f grown;
  cv::dilate(values, grown, cv::Mat(), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
             cv::Scalar(-std::numeric_limits<float>::infinity()));
  return grown;
}

cv::Mat1f Above(const cv::Mat1f& values, double level) {
  cv::Mat1f out(values.size());
  const auto t = static_cast<float>(level);
  for (int v = 0; v < values.rows; ++v) {
    for (int u = 0; u < values.cols; ++u) out(v, u) = values(v, u) > t ? 1.0f : 0.0f;
  }
  return out;
}

// Correlation with `outside` beyond the image border (1: unknown space is an obstacle).
cv::Mat1f Correlate(const cv::Mat1f& image, const cv::Mat1f& kernel, float outside) {
  const int r = kernel.rows / 2;
  cv::Mat1f padded, out;
  cv::copyMakeBorder(image, padded, r, r, r, r, cv::BORDER_CONSTANT, cv::Scalar(outside));
  cv::filter2D(padded, out, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_CONSTANT);
  return out(cv::Rect(r, r, image.cols, image.rows)).clone();
}

}  // namespace

FgeMaps ComputeFgeMapsReference(const Scene& scene, const Camera& camera, const Gripper& gripper,
                                const FgeParams& params, double angle_rad,
                                double contact_height_m) {
  fge_detail::CheckInputs(camera, gripper, params);
  const fge_detail::Slice slice = fge_detail::SliceAt(contact_height_m, gripper, params);
  const GripperPx g = fge_detail::GripperAtScale(
      gripper, fge_detail::PxPerMetre(scene.floor, camera, contact_height_m));
  const Kernels k = RotatedKernels(g, angle_rad);
  // One-pixel safety margin (as in the fast path): every surface is grown by one pixel.
  const cv::Mat1f height = GrowByOnePixel(scene.height_m);

  // Only free objects are contact surfaces (bin walls, robot parts: obstacles only).
  const cv::Mat1b graspable =
      fge_detail::SearchSlices(scene.height_m, scene.contact_allowed,
                               fge_detail::PxPerMetre(scene.floor, camera, 0), gripper, params)
          .graspable;
  cv::Mat1f contact_surface = Above(height, slice.contact_height_m);
  contact_surface.setTo(0.0f, graspable == 0);
  FgeMaps maps;
  maps.contact = Correlate(contact_surface, k.contact, 0.0f);
  const cv::Mat1f above_tips = Above(height, slice.tip_height_m);
  maps.collision = Correlate(above_tips, k.fingers, 1.0f);
  const cv::Mat1f tips_in_closing = Correlate(above_tips, k.contact, 1.0f);
  const cv::Mat1f palm = Correlate(Above(height, slice.palm_height_m), k.contact + k.fingers, 1.0f);
  const cv::Mat1f seams =
      Correlate(Above(GrowByOnePixel(fge_detail::SeamLevels(scene.height_m, scene.missing_mask,
                                                            params.seam_step_m)),
                      slice.tip_height_m),
                k.contact, 0.0f);

  const int min_contact = fge_detail::MinContactCount(cv::countNonZero(k.contact));
  cv::Mat1f candidate(height.size());
  for (int v = 0; v < height.rows; ++v) {
    for (int u = 0; u < height.cols; ++u) {
      const float contact = maps.contact(v, u);
      const bool slips = tips_in_closing(v, u) > fge_detail::kMaxSlipRatio * contact + 0.5;
      const bool ok = contact > min_contact - 0.5f && maps.collision(v, u) < 0.5f && !slips &&
                      palm(v, u) < 0.5f && seams(v, u) < 0.5f;
      candidate(v, u) = ok ? 1.0f : 0.0f;
    }
  }
  const double sigma = fge_detail::BlurSigmaPx(g);
  const int ksize = fge_detail::GaussianKernelSize(sigma);
  cv::GaussianBlur(candidate, maps.graspability, cv::Size(ksize, ksize), sigma, sigma,
                   cv::BORDER_CONSTANT);
  maps.graspability = maps.graspability.mul(candidate);
  return maps;
}

}  // namespace softgrasp::core
