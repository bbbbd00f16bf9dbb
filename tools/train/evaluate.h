#pragma once
/// `softgrasp-train evaluate`: image metrics and grasp metrics of a stiffness model on a
/// validation dataset, against baselines. Prints JSON on stdout. See docs/stiffness.md.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "service/core/depth.h"
#include "service/core/preprocess.h"

namespace softgrasp::tools {

/// Returns the process exit code (0 ok, 2 bad arguments or data).
int RunEvaluate(std::vector<std::string> args);

/// The hand-made baseline map: on pixels > 5 mm above the floor, 0.3 at a depth edge (outline
/// or a > 5 mm step between neighbours) growing linearly to 0.8 at >= 20 mm inside; 0 elsewhere.
cv::Mat1f HeuristicStiffness(const core::Scene& scene, const core::Camera& camera);

}  // namespace softgrasp::tools
