// Depth colour maps and grasp overlays (BGR).
#include "service/io/overlay.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace softgrasp::io {
namespace {

constexpr std::size_t kMaxPercentileSamples = std::size_t{1} << 20;
constexpr int kShift = 4;  // sub-pixel bits for OpenCV's drawing functions
constexpr double kFixedScale = 1 << kShift;
constexpr double kMaxCoordinate = 1e6;  // grasps beyond this are not drawn (and cannot overflow)
constexpr double kMinFingerPx = 2.0;    // fingers stay visible on small images

struct GraspStyle {
  cv::Scalar color;
  int line_thickness;
  int dot_radius;
  bool filled_fingers;
};

const GraspStyle kBestStyle{cv::Scalar(0, 255, 0), 3, 4, true};        // green, filled
const GraspStyle kOtherStyle{cv::Scalar(255, 255, 255), 1, 2, false};  // white, outlined

bool IsValidDepth(float z) { return std::isfinite(z) && z > 0.0f; }

float Percentile(std::vector<float>& values, double q) {
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

/// The valid depths' 1st and 99th percentiles, from at most about a million samples.
std::optional<std::pair<float, float>> ValidRange(const cv::Mat1f& depth) {
  const std::size_t total = depth.total();
  const std::size_t step = std::max<std::size_t>(1, total / kMaxPercentileSamples);
  const auto cols = static_cast<std::size_t>(depth.cols);
  std::vector<float> values;
  for (std::size_t i = 0; i < total; i += step) {
    const float z = depth(static_cast<int>(i / cols), static_cast<int>(i % cols));
    if (IsValidDepth(z)) values.push_back(z);
  }
  if (values.empty()) return std::nullopt;
  const float low = Percentile(values, 0.01);
  const float high = Percentile(values, 0.99);
  return std::make_pair(low, high);
}

cv::Point ToFixed(const cv::Point2d& p) {
  return {cvRound(p.x * kFixedScale), cvRound(p.y * kFixedScale)};
}

bool IsDrawable(const core::Grasp& g) {
  const double coordinates[] = {g.center_u_px, g.center_v_px, g.opening_px, g.finger_width_px,
                                g.finger_thickness_px};
  return std::isfinite(g.angle_rad) &&
         std::all_of(std::begin(coordinates), std::end(coordinates),
                     [](double x) { return std::isfinite(x) && std::abs(x) < kMaxCoordinate; });
}

/// A finger: `thickness` along the closing axis x `width` across it, centred at `center`.
void DrawFinger(cv::Mat3b& image, const cv::Point2d& center, const cv::Point2d& axis,
                double thickness, double width, const GraspStyle& style) {
  const cv::Point2d along = axis * (std::max(thickness, kMinFingerPx) / 2);
  const cv::Point2d across = cv::Point2d(-axis.y, axis.x) * (std::max(width, kMinFingerPx) / 2);
  const std::vector<cv::Point> corners = {
      ToFixed(center - along - across), ToFixed(center + along - across),
      ToFixed(center + along + across), ToFixed(center - along + across)};
  if (style.filled_fingers) {
    cv::fillConvexPoly(image, corners, style.color, cv::LINE_AA, kShift);
  }
  cv::polylines(image, std::vector<std::vector<cv::Point>>{corners}, true, style.color,
                style.line_thickness, cv::LINE_AA, kShift);
}

void DrawGrasp(cv::Mat3b& image, const core::Grasp& g, const GraspStyle& style) {
  if (!IsDrawable(g)) return;
  const cv::Point2d center(g.center_u_px, g.center_v_px);
  const cv::Point2d axis(std::cos(g.angle_rad), std::sin(g.angle_rad));
  const double offset = std::abs(g.opening_px) / 2 + std::abs(g.finger_thickness_px) / 2;
  const cv::Point2d finger_a = center - axis * offset;
  const cv::Point2d finger_b = center + axis * offset;
  DrawFinger(image, finger_a, axis, g.finger_thickness_px, g.finger_width_px, style);
  DrawFinger(image, finger_b, axis, g.finger_thickness_px, g.finger_width_px, style);
  cv::line(image, ToFixed(finger_a), ToFixed(finger_b), style.color, style.line_thickness,
           cv::LINE_AA, kShift);
  cv::circle(image, ToFixed(center), style.dot_radius << kShift, style.color, cv::FILLED,
             cv::LINE_AA, kShift);
}

}  // namespace

cv::Mat3b ColorizeDepth(const core::DepthImage& depth) {
  if (depth.empty()) return {};
  cv::Mat3b out(depth.depth_m.size(), cv::Vec3b(0, 0, 0));
  const auto range = ValidRange(depth.depth_m);
  if (!range) return out;
  const auto [near_m, far_m] = *range;
  const float span = std::max(far_m - near_m, 1e-6f);
  // Near maps to 255, the warm end of the colour map.
  cv::Mat1b levels(depth.depth_m.size(), 0);
  cv::Mat1b valid(depth.depth_m.size(), 0);
  for (int r = 0; r < depth.depth_m.rows; ++r) {
    for (int c = 0; c < depth.depth_m.cols; ++c) {
      const float z = depth.depth_m(r, c);
      if (!IsValidDepth(z)) continue;
      levels(r, c) = cv::saturate_cast<uchar>(255.0f * (far_m - z) / span);
      valid(r, c) = 255;
    }
  }
  cv::Mat colored;
  cv::applyColorMap(levels, colored, cv::COLORMAP_TURBO);
  colored.copyTo(out, valid);
  return out;
}

cv::Mat3b ColorizeStiffness(const cv::Mat1f& stiffness, float background_below) {
  cv::Mat3b out(stiffness.size(), cv::Vec3b(0, 0, 0));
  if (stiffness.empty()) return out;
  cv::Mat1b levels(stiffness.size(), 0);
  cv::Mat1b object(stiffness.size(), 0);
  for (int r = 0; r < stiffness.rows; ++r) {
    const float* s = stiffness.ptr<float>(r);
    for (int c = 0; c < stiffness.cols; ++c) {
      if (!(s[c] >= background_below)) continue;  // NaN is background too
      // Fixed scale: the softest catalogue level (0.1) at the cold end, 1 at the warm end.
      const float t = std::clamp((s[c] - 0.1f) / 0.9f, 0.0f, 1.0f);
      levels(r, c) = cv::saturate_cast<uchar>(255.0f * t);
      object(r, c) = 255;
    }
  }
  cv::Mat colored;
  cv::applyColorMap(levels, colored, cv::COLORMAP_TURBO);
  colored.copyTo(out, object);
  return out;
}

cv::Mat3b DrawGrasps(const cv::Mat3b& background, const std::vector<core::Grasp>& grasps) {
  cv::Mat3b image = background.clone();
  if (image.empty()) return image;
  // Lower-ranked grasps first, so the best one ends up on top.
  for (std::size_t i = grasps.size(); i-- > 0;) {
    DrawGrasp(image, grasps[i], i == 0 ? kBestStyle : kOtherStyle);
  }
  return image;
}

cv::Mat3b RenderGraspOverlay(const core::DepthImage& depth,
                             const std::vector<core::Grasp>& grasps) {
  return DrawGrasps(ColorizeDepth(depth), grasps);
}

cv::Vec3b InstanceColor(int id) {
  // Golden-angle hues: neighbouring ids get far-apart colours; full saturation, bright.
  const double hue = std::fmod(static_cast<double>(id) * 137.50776, 360.0);
  cv::Mat3b hsv(1, 1, cv::Vec3b(cv::saturate_cast<uchar>(hue / 2.0), 200, 255));
  cv::Mat3b bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  return bgr(0, 0);
}

cv::Mat3b DrawInstances(const cv::Mat3b& background, const cv::Mat1w& labels, int highlight_id) {
  if (background.size() != labels.size()) {
    throw std::invalid_argument("DrawInstances: the labels' size differs from the picture's");
  }
  cv::Mat3b image;
  if (background.empty()) return image;
  // The background dimmed to grey, so the instance colours stand out.
  cv::Mat1b grey;
  cv::cvtColor(background, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(grey, CV_8U, 0.6);
  cv::cvtColor(grey, image, cv::COLOR_GRAY2BGR);
  double max_id = 0;
  cv::minMaxLoc(labels, nullptr, &max_id);
  for (int id = 1; id <= static_cast<int>(max_id); ++id) {
    const cv::Mat1b mask = labels == id;
    if (cv::countNonZero(mask) == 0) continue;
    const cv::Vec3b color = InstanceColor(id);
    cv::Mat3b tinted;
    cv::addWeighted(image, 0.35, cv::Mat3b(image.size(), color), 0.65, 0.0, tinted);
    tinted.copyTo(image, mask);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    const bool highlighted = id == highlight_id;
    cv::drawContours(image, contours, -1,
                     highlighted ? cv::Scalar(255, 255, 255) : cv::Scalar(color),
                     highlighted ? 3 : 1, cv::LINE_AA);
    // The label where the instance is thickest: inside it even when it is not convex.
    cv::Mat1f distance;
    cv::Mat1b padded;
    cv::copyMakeBorder(mask, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
    cv::distanceTransform(padded, distance, cv::DIST_L2, 3);
    cv::Point inside;
    cv::minMaxLoc(distance, nullptr, nullptr, nullptr, &inside);
    inside -= cv::Point(1, 1);
    const std::string text = std::to_string(id);
    const double scale = std::clamp(labels.cols / 1100.0, 0.35, 1.5);
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 2, &baseline);
    const cv::Point origin(std::clamp(inside.x - size.width / 2, 0, labels.cols - size.width),
                           std::clamp(inside.y + size.height / 2, size.height, labels.rows - 1));
    cv::putText(image, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 4,
                cv::LINE_AA);
    cv::putText(image, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255), 1,
                cv::LINE_AA);
  }
  return image;
}

cv::Mat3b DrawOutline(const cv::Mat3b& background, const cv::Mat1b& mask) {
  if (background.size() != mask.size()) {
    throw std::invalid_argument("DrawOutline: the mask's size differs from the picture's");
  }
  cv::Mat3b image = background.clone();
  if (image.empty()) return image;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  cv::drawContours(image, contours, -1, cv::Scalar(0, 0, 0), 4, cv::LINE_AA);
  cv::drawContours(image, contours, -1, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  return image;
}

cv::Mat3b ColorizeDeformability(const cv::Mat1f& deformability, const cv::Mat1b& foreground) {
  if (!foreground.empty() && foreground.size() != deformability.size()) {
    throw std::invalid_argument("ColorizeDeformability: the mask's size differs from the map's");
  }
  // Stiffness-like values on ColorizeStiffness's scale: rigid (0) -> 1, very soft (1) -> 0.1.
  cv::Mat1f as_stiffness(deformability.size(), 0.0f);
  for (int r = 0; r < deformability.rows; ++r) {
    const float* d = deformability.ptr<float>(r);
    for (int c = 0; c < deformability.cols; ++c) {
      if (!std::isfinite(d[c]) || (!foreground.empty() && foreground(r, c) == 0)) continue;
      as_stiffness(r, c) = 1.0f - 0.9f * std::clamp(d[c], 0.0f, 1.0f);
    }
  }
  return ColorizeStiffness(as_stiffness, 0.05f);
}

}  // namespace softgrasp::io
