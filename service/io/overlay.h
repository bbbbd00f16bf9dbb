#pragma once
/// Pictures of results: the depth colour-mapped with grasps drawn over it.

#include <vector>

#include <opencv2/core.hpp>

#include "service/core/depth.h"
#include "service/core/grasp.h"

namespace softgrasp::io {

/// Depth colour-mapped (near = warm, missing = black; range from the valid pixels' 1st–99th
/// percentiles), each grasp drawn as its two finger rectangles and the closing line between them.
/// The best grasp (index 0) is drawn thicker in a distinct colour, the others thinner. BGR.
cv::Mat3b RenderGraspOverlay(const core::DepthImage& depth, const std::vector<core::Grasp>& grasps);

/// Depth colour-mapped alone, as above.
cv::Mat3b ColorizeDepth(const core::DepthImage& depth);

}  // namespace softgrasp::io
