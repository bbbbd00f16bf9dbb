#pragma once
/// `softgrasp-train gqcnn-picks`: simulated pick success of strategy=gqcnn against classic FGE
/// on the same scenes (docs/gqcnn.md, "Picks in the simulator"): single held-out objects on a
/// table and clutter of validation-split catalogue objects in a bin; the top grasp of each
/// planner is executed in the simulator. JSON with 95 % paired bootstrap intervals.

#include <string>
#include <vector>

namespace softgrasp::tools {

/// Runs the command on its arguments (after "gqcnn-picks"); returns the exit code (0, or 2 for
/// bad arguments or an unreadable model, with the message on stderr).
int RunGqcnnPicks(std::vector<std::string> args);

}  // namespace softgrasp::tools
