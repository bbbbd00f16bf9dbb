#pragma once
/// The simulated robot on the DDS bus: a thread that takes each command for this robot from a
/// bridge::RobotEndpoint, heartbeats EXECUTING with its id, runs it in the SimRobot, publishes
/// the result and heartbeats IDLE again.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "service/bridge/bridge.h"
#include "sim/robot/sim_robot.h"

namespace softgrasp::sim {

class SimRobotLoop {
 public:
  /// Joins the bus as `robot_id` (simulated = true, workspace = robot.workspace()) and starts
  /// the command thread. `log` receives one line per command and per bus error (default:
  /// stderr). `robot` must outlive the loop. Errors: those of RobotEndpoint::Create.
  static core::Result<std::unique_ptr<SimRobotLoop>> Start(
      SimRobot& robot, const bridge::BridgeOptions& options, const std::string& robot_id,
      std::function<void(const std::string&)> log = {});
  ~SimRobotLoop();  ///< Stop()s
  SimRobotLoop(const SimRobotLoop&) = delete;
  SimRobotLoop& operator=(const SimRobotLoop&) = delete;

  /// Lets a running command finish, then leaves the bus. Idempotent.
  void Stop();

  /// Commands executed so far (each has had its result published, or a publish error logged).
  std::int64_t commands_done() const { return commands_done_.load(); }
  bridge::RobotEndpoint& endpoint() { return *endpoint_; }

 private:
  SimRobotLoop(SimRobot& robot, std::function<void(const std::string&)> log)
      : robot_(robot), log_(std::move(log)) {}
  void Run();
  void RunOne(const bridge::GraspCommand& command);

  SimRobot& robot_;
  std::function<void(const std::string&)> log_;
  std::unique_ptr<bridge::RobotEndpoint> endpoint_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> commands_done_{0};
  std::thread thread_;
};

}  // namespace softgrasp::sim
