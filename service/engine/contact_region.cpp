#include "service/engine/contact_region.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>

namespace softgrasp::engine {
namespace {

// A surface this much above the fingertips is one a finger pad meets (depth noise below it).
constexpr double kSurfaceAboveTipsM = 0.002;

bool Allowed(const cv::Mat1b& allowed, int u, int v) { return allowed.empty() || allowed(v, u); }

// The outermost pixel above `tips_m` on the segment from the centre (u0, v0) to (u1, v1), walked
// from the outer end inwards in steps of at most a pixel; nullopt when none.
std::optional<cv::Point> OutermostSurface(const cv::Mat1f& height_m, double u0, double v0,
                                          double u1, double v1, double tips_m) {
  const int steps = static_cast<int>(std::ceil(std::hypot(u1 - u0, v1 - v0))) + 1;
  for (int i = steps; i >= 0; --i) {
    const double t = static_cast<double>(i) / steps;
    const int u = static_cast<int>(std::lround(u0 + t * (u1 - u0)));
    const int v = static_cast<int>(std::lround(v0 + t * (v1 - v0)));
    if (u < 0 || v < 0 || u >= height_m.cols || v >= height_m.rows) continue;
    if (height_m(v, u) > tips_m) return cv::Point(u, v);
  }
  return std::nullopt;
}

}  // namespace

cv::Mat1b ApplyContactRegion(core::Scene* scene, const core::Camera& camera,
                             const core::Gripper& gripper, const core::FgeParams& fge,
                             const ContactRegionRequest& request) {
  core::RestrictContact(*scene, request.segmask, request.min_depth_m);
  if (!request.target.empty()) core::RestrictContact(*scene, request.target, request.min_depth_m);
  if (!request.free_surfaces) return {};
  // GraspableSurfaces keeps within scene->contact_allowed. Grown by a few pixels: an edge pair's
  // contact pixel may lie on an object's outline, just outside its free top surface.
  cv::Mat1b region = core::GraspableSurfaces(*scene, camera, gripper, fge);
  if (region.empty()) return region;
  cv::dilate(region, region, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(7, 7)));
  if (!scene->contact_allowed.empty()) region &= scene->contact_allowed;
  return region;
}

bool ClosesInRegion(const core::Scene& scene, const cv::Mat1b& region, const core::Grasp& grasp) {
  const cv::Mat1b& allowed = region;
  if (allowed.empty()) return true;
  const double c = std::cos(grasp.angle_rad), s = std::sin(grasp.angle_rad);
  const double half_open = grasp.opening_px / 2;
  const double half_width = grasp.finger_width_px / 2;
  const double tips_m = grasp.grasp_height_m + kSurfaceAboveTipsM;
  bool met_any = false;
  for (const double offset : {-half_width, 0.0, half_width}) {
    // A line parallel to the closing axis, `offset` pixels across it.
    const double u0 = grasp.center_u_px - s * offset, v0 = grasp.center_v_px + c * offset;
    for (const double side : {-1.0, 1.0}) {
      const auto contact = OutermostSurface(scene.height_m, u0, v0, u0 + side * c * half_open,
                                            v0 + side * s * half_open, tips_m);
      if (!contact) continue;
      met_any = true;
      if (!Allowed(allowed, contact->x, contact->y)) return false;
    }
  }
  if (met_any) return true;
  const int u = static_cast<int>(std::lround(grasp.center_u_px));
  const int v = static_cast<int>(std::lround(grasp.center_v_px));
  return u >= 0 && v >= 0 && u < allowed.cols && v < allowed.rows && Allowed(allowed, u, v);
}

}  // namespace softgrasp::engine
