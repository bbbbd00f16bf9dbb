#pragma once
/// Pixel masks of a grasp's closing region and finger footprints, for checking grasps against
/// object-id masks and height maps in tests.

#include <opencv2/core.hpp>

#include "service/core/grasp.h"

namespace softgrasp::testing {

struct GraspFootprint {
  cv::Mat1b closing;  ///< 255 between the inner finger faces (opening x finger width)
  cv::Mat1b fingers;  ///< 255 under the two finger footprints (thickness x finger width)
};

/// Pixel-centre rule in the grasp frame (a along the closing axis, b across): closing region
/// |a| <= opening/2 - shrink, |b| <= width/2 - shrink; fingers opening/2 + shrink < |a| <=
/// opening/2 + thickness - shrink, |b| <= width/2 - shrink. A positive `shrink_px` absorbs
/// rasterisation differences at the region borders.
GraspFootprint RasteriseGrasp(const core::Grasp& grasp, cv::Size image_size, double shrink_px = 0);

}  // namespace softgrasp::testing
