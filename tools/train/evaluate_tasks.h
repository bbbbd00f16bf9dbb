#pragma once
/// `softgrasp-train evaluate-tasks`: the thesis' three grasping tasks (ch. 5, Tables 5.1-5.3) in
/// the simulator, each comparing fge, stiffness and deformability (both target policies) on the
/// same scenes, with bin clearing for the clutter task. Prints JSON. See docs/deformability.md.

#include <string>
#include <vector>

namespace softgrasp::tools {

/// Returns the process exit code (0 ok, 2 bad arguments or data).
int RunEvaluateTasks(std::vector<std::string> args);

}  // namespace softgrasp::tools
