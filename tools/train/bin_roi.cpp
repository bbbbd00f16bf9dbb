#include "tools/train/bin_roi.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

namespace softgrasp::tools {

cv::Mat1b BinRoi(const sim::SceneSpec& spec, const core::Camera& cam, int margin_px) {
  cv::Mat1b roi(cam.height, cam.width, static_cast<unsigned char>(0));
  const Eigen::Isometry3d camera_from_world = spec.render.world_from_camera.inverse();
  std::vector<cv::Point> corners;
  for (const auto& [sx, sy] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    const Eigen::Vector3d p =
        camera_from_world * Eigen::Vector3d(sx * spec.support.inner_size_x_m / 2,
                                            sy * spec.support.inner_size_y_m / 2, 0.0);
    corners.emplace_back(static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx)),
                         static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy)));
  }
  cv::fillConvexPoly(roi, corners, cv::Scalar(255));
  if (margin_px > 0) {
    cv::erode(
        roi, roi,
        cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * margin_px + 1, 2 * margin_px + 1)));
  }
  return roi;
}

}  // namespace softgrasp::tools
