#pragma once
/// Depth images and pinhole cameras. Camera frame C follows OpenCV: x right, y down, z forward.

#include <opencv2/core.hpp>

namespace softgrasp::core {

/// Pinhole intrinsics in pixels. `width`/`height` are the image size the intrinsics belong to.
struct Camera {
  double fx = 525.0;
  double fy = 525.0;
  double cx = 319.5;
  double cy = 239.5;
  int width = 640;
  int height = 480;
};

/// A depth image: z distance along the optical axis in metres, row-major, one float per pixel.
/// Missing measurements are NaN (decoders turn 0 into NaN).
struct DepthImage {
  cv::Mat1f depth_m;

  int width() const { return depth_m.cols; }
  int height() const { return depth_m.rows; }
  bool empty() const { return depth_m.empty(); }
};

}  // namespace softgrasp::core
