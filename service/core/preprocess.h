#pragma once
/// Depth preprocessing: fill missing pixels, find the floor (table or bin bottom), heights above
/// it.

#include <array>

#include "service/core/depth.h"
#include "service/core/status.h"

namespace softgrasp::core {

/// Plane in the camera frame: n · p_C + d = 0 with |n| = 1, n pointing towards the camera
/// (so the signed distance n · p + d is the height above the plane).
struct Plane {
  std::array<double, 3> n{0, 0, -1};
  double d = 0;
};

struct PreprocessParams {
  double inpaint_radius_px = 3.0;  ///< cv::inpaint radius for missing pixels
  int ransac_iterations = 200;     ///< floor plane fit
  double floor_inlier_m = 0.004;   ///< point-to-plane distance for a floor inlier
  unsigned ransac_seed = 12345;    ///< fixed: same input, same plane
};

struct Scene {
  cv::Mat1f depth_filled_m;  ///< input with missing pixels filled in (inpainting)
  cv::Mat1b missing_mask;    ///< 255 where the input was missing
  cv::Mat1f height_m;        ///< height of each pixel's surface above the floor plane, metres
  Plane floor;               ///< the fitted floor, camera frame
  double missing_fraction = 0;
  /// 255 where a surface may be grasped (a contact surface); elsewhere surfaces are obstacles
  /// only. Empty = everywhere. Set by RestrictContact.
  cv::Mat1b contact_allowed;
};

/// Fills missing pixels, fits the floor (RANSAC plane over the deepest surface), and measures
/// heights above it. Returns kUnprocessable when too few pixels are valid to do that.
Result<Scene> Preprocess(const DepthImage& depth, const Camera& camera,
                         const PreprocessParams& params = {});

/// Where the planners may put contacts: inside `region_of_interest` (image size, non-zero =
/// allowed; empty = the whole image) and on surfaces at least `min_depth_m` from the camera
/// along the optical axis (0 = no limit), and not joined to a nearer one: surfaces above the floor
/// reached from a surface nearer than `min_depth_m` without a height step of 10 mm belong to it
/// (a wrist camera's fingers reach down towards the table, their tips deeper than their base).
/// Surfaces outside stay obstacles: e.g. the robot's own fingers in a wrist camera's view, or the
/// neighbours of the one object a mask selects.
/// Repeated calls narrow the allowed region further.
/// @throws std::invalid_argument if the mask's size differs from the scene's or min_depth_m is
/// negative or not finite.
void RestrictContact(Scene& scene, const cv::Mat1b& region_of_interest, double min_depth_m);

}  // namespace softgrasp::core
