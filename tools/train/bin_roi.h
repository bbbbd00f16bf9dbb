#pragma once
/// The workspace of a simulated bin-picking cell as the camera sees it, shared by the
/// evaluation commands of softgrasp-train.

#include <opencv2/core.hpp>

#include "service/core/depth.h"
#include "sim/dataset/scene_gen.h"

namespace softgrasp::tools {

/// 255 inside the bin's inner floor area as seen by the camera (shrunk by `margin_px`): the
/// workspace ROI of a bin-picking cell. The planners only see heights there, since FGE alone
/// would happily grasp the bin's free-standing walls.
cv::Mat1b BinRoi(const sim::SceneSpec& spec, const core::Camera& cam, int margin_px);

}  // namespace softgrasp::tools
