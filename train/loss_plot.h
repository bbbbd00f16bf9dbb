#pragma once
/// Loss curves of the trainers drawn as a PNG with OpenCV (no plotting library on the machine).

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace softgrasp::models {

struct LossSeries {
  std::string name;
  cv::Scalar colour;           ///< BGR
  std::vector<double> values;  ///< one per step of PlotLossCurves' `steps`
};

/// Draws every series against the step, each smoothed by a moving average over ~1 % of the steps,
/// on one linear axis from 0, with a legend, into an 800 x 500 PNG. Nothing is drawn for no steps.
void PlotLossCurves(const std::string& title, const std::vector<int>& steps,
                    const std::vector<LossSeries>& series, const std::filesystem::path& png);

}  // namespace softgrasp::models
