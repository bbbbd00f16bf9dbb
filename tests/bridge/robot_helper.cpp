// A robot in its own process for bridge_process_test: joins the bus as --robot-id on --domain
// with the loopback config and --tag, answers every command with a result computed from it, and
// runs until killed. Exit code 2 on bad arguments or a bridge error.
//
// The "measurement" is a fixed function of the command so the test can check it:
// contact_width_m = opening_width_m / 2, grasped_width_m = 0.8 * contact_width_m,
// deformation_rate = 0.2, object_id echoed, outcome SUCCEEDED.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "service/bridge/bridge.h"

using softgrasp::bridge::BridgeOptions;
using softgrasp::bridge::GraspOutcome;
using softgrasp::bridge::GraspResult;
using softgrasp::bridge::RobotEndpoint;
using softgrasp::bridge::RobotState;
using softgrasp::bridge::Workspace;

int main(int argc, char** argv) {
  BridgeOptions options;
  std::string robot_id = "helper";
  std::string tag;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const std::string value = argv[i + 1];
    if (flag == "--domain") {
      options.domain_id = std::atoi(value.c_str());
    } else if (flag == "--robot-id") {
      robot_id = value;
    } else if (flag == "--tag") {
      tag = value;
    } else if (flag == "--lease") {
      options.liveliness_lease_s = std::atof(value.c_str());
    } else if (flag == "--period") {
      options.heartbeat_period_s = std::atof(value.c_str());
    } else {
      std::fprintf(stderr, "unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  options.config = softgrasp::bridge::LoopbackConfigXml(tag);
  auto robot = RobotEndpoint::Create(options, robot_id, /*simulated=*/true,
                                     Workspace{"camera", {-1.0, -1.0, 0.0}, {1.0, 1.0, 2.0}});
  if (!robot) {
    std::fprintf(stderr, "robot: %s\n", robot.error().message.c_str());
    return 2;
  }
  for (;;) {
    auto command = robot.value()->WaitForCommand(0.2);
    if (!command) {
      std::fprintf(stderr, "robot: %s\n", command.error().message.c_str());
      return 2;
    }
    if (!command.value()) continue;
    const auto& c = *command.value();
    (void)robot.value()->Heartbeat(RobotState::kExecuting, c.command_id);
    GraspResult result;
    result.command_id = c.command_id;
    result.object_id = c.object_id;
    result.outcome = GraspOutcome::kSucceeded;
    result.contact_width_m = c.opening_width_m / 2.0;
    result.grasped_width_m = 0.8 * result.contact_width_m;
    result.deformation_rate = 0.2;
    result.execution_s = 0.01;
    auto published = robot.value()->PublishResult(result);
    if (!published) {
      std::fprintf(stderr, "robot: %s\n", published.error().message.c_str());
      return 2;
    }
    (void)robot.value()->Heartbeat(RobotState::kIdle);
  }
}
