#pragma once
/// Analytic depth images for tests: boxes standing on a table, seen by a pinhole camera looking
/// straight down. Every pixel's depth is an exact ray/plane or ray/box intersection, so expected
/// heights and positions are closed-form.
///
/// Table coordinates (metres): origin on the table where the optical axis meets it, x along the
/// image's +u, y along the image's +v, z up towards the camera (height above the table). (This
/// frame is mirrored with respect to a right-handed one; it keeps image and table directions
/// identical.) Box yaw turns from +x towards +y, like Grasp::angle_rad turns from +u towards +v.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "service/core/depth.h"

namespace softgrasp::testing {

/// An upright box standing on the table.
struct Box {
  double x_m = 0;  ///< centre of the footprint on the table
  double y_m = 0;
  double size_x_m = 0.03;  ///< footprint along the box's own x axis (before yaw)
  double size_y_m = 0.08;
  double height_m = 0.04;
  double yaw_rad = 0;  ///< box x axis at this angle from table +x towards +y
  int id = 1;          ///< written into SyntheticScene::object_id; must be > 0
};

struct SceneSpec {
  core::Camera camera;           ///< intrinsics and image size (default 640 x 480, f 525)
  double camera_height_m = 0.6;  ///< along the optical axis, to the table
  /// Table tilt: the table turns by this angle about the table x axis (image rows then see a
  /// depth gradient along v). 0 = table perpendicular to the optical axis.
  double table_tilt_rad = 0;
  std::vector<Box> boxes;
};

/// Object ids in SyntheticScene::object_id.
inline constexpr int kTableId = 0;
inline constexpr int kNothingId = -1;  ///< ray hits nothing (depth NaN)

struct SyntheticScene {
  core::DepthImage depth;  ///< metres along the optical axis
  core::Camera camera;
  cv::Mat1i object_id;  ///< kTableId, a Box::id, or kNothingId
  cv::Mat1f height_m;   ///< exact height of each pixel's surface above the table
};

SyntheticScene RenderScene(const SceneSpec& spec);

/// Pixel (u, v) where a table point (x, y, z = height above the table) is seen.
cv::Point2d ProjectTablePoint(const SceneSpec& spec, double x_m, double y_m, double z_m);

/// The camera-frame point of a table point (OpenCV camera frame, metres).
cv::Point3d TableToCamera(const SceneSpec& spec, double x_m, double y_m, double z_m);

/// A 640 x 480 clutter scene: boxes of different sizes and heights, some touching, on a table
/// 0.6 m below the camera (used by the FGE benchmark and REST tests).
SceneSpec ClutterSceneSpec();

/// Loads a little-endian float32 .npy array of shape (rows, cols) or (rows, cols, 1), C order,
/// as metres. Throws std::runtime_error on anything else.
cv::Mat1f LoadNpyFloat32(const std::string& path);

}  // namespace softgrasp::testing
