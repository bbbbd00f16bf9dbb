#pragma once
// Shared by the bridge DDS tests: options on the test's own domain and discovery tag, bounded
// waits, and a sample command.

#include <unistd.h>

#include <cmath>
#include <string>

#include "service/bridge/bridge.h"
#include "tests/support/wait_until.h"

namespace softgrasp::bridge::testing {

inline std::string ProcessTag() { return "softgrasp-test-" + std::to_string(::getpid()); }

/// Loopback config, this binary's domain, and a tag unique to this process so tests run by
/// ctest -j (one process per test) never see each other.
inline BridgeOptions TestOptions() {
  BridgeOptions options;
  options.domain_id = SOFTGRASP_BRIDGE_TEST_DOMAIN;
  options.config = LoopbackConfigXml(ProcessTag());
  options.heartbeat_period_s = 0.2;
  return options;
}

using softgrasp::testing::WaitUntil;

inline GraspCommand MakeCommand(const std::string& id, const std::string& robot_id = "") {
  GraspCommand c;
  c.command_id = id;
  c.robot_id = robot_id;
  c.object_id = "sponge-1";
  c.frame_id = "camera";
  c.position_m = {0.05, -0.02, 0.61};
  c.orientation_xyzw = {0.0, std::sin(0.2), 0.0, std::cos(0.2)};
  c.opening_width_m = 0.08;
  c.closing_force_n = 10.0;
  c.approach_m = 0.1;
  c.retreat_m = 0.12;
  c.score = 0.9;
  c.issued_unix_ns = 1'750'000'000'250'000'000LL;
  return c;
}

inline const Workspace kTestWorkspace{"camera", {-0.5, -0.5, 0.2}, {0.5, 0.5, 1.5}};

}  // namespace softgrasp::bridge::testing
