#pragma once
/// `softgrasp-sim robot`: the command-line part of the simulated robot (docs/sim-robot.md).

#include <cstdint>
#include <string>
#include <vector>

#include "service/bridge/bridge.h"
#include "service/http/server.h"
#include "sim/dataset/scene_gen.h"

namespace softgrasp::sim {

struct RobotCommandLine {
  SceneSpec spec;  ///< objects, support, noise
  std::uint64_t scene_seed = 1;
  std::string robot_id = "sim-robot";
  bridge::BridgeOptions bridge;  ///< domain_id and dds_config
  http::ServerOptions http;      ///< host and port of the scene views (127.0.0.1:8081)
};

/// The usage text of the `robot` subcommand.
const char* RobotUsage();

/// Parses the arguments after `robot`. Returns an error message, or "" when `out` is filled.
std::string ParseRobotArgs(const std::vector<std::string>& args, RobotCommandLine* out);

/// Runs `softgrasp-sim robot ARGS` until SIGINT or SIGTERM; returns the exit code (0 after a
/// clean stop, 1 when it cannot start, 2 for bad arguments).
int RunRobotCommand(const std::vector<std::string>& args);

}  // namespace softgrasp::sim
