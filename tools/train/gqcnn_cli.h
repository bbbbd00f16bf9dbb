#pragma once
/// `softgrasp-train gqcnn`, `gqcnn-eval`, `gqcnn-calibrate` and `gqcnn-bench` (docs/gqcnn.md).

#include <string>
#include <vector>

namespace softgrasp::tools {

extern const char* const kGqcnnUsage;

int RunGqcnnTrain(std::vector<std::string> args);
int RunGqcnnEvaluate(std::vector<std::string> args);
int RunGqcnnCalibrate(std::vector<std::string> args);
int RunGqcnnBench(std::vector<std::string> args);

}  // namespace softgrasp::tools
