#pragma once
/// softgrasp-train's segmentation commands (docs/segmentation.md):
///   segmentation           trains the segmentation network on softgrasp-sim datasets;
///   evaluate-segmentation  scores the model and the PCL baseline on validation sets.

#include <string>
#include <vector>

namespace softgrasp::tools {

extern const char* const kSegmentationUsage;

/// Both return the process exit code (0 ok, 2 bad arguments or failure) and print as they go.
int RunSegmentationTrain(std::vector<std::string> args);
int RunSegmentationEvaluate(std::vector<std::string> args);

}  // namespace softgrasp::tools
