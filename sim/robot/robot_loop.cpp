#include "sim/robot/robot_loop.h"

#include <chrono>
#include <iostream>
#include <sstream>

namespace softgrasp::sim {
namespace {

// How long one WaitForCommand blocks: bounds how quickly Stop() is noticed.
constexpr double kPollS = 0.2;

std::string Summary(const bridge::GraspCommand& command, const bridge::GraspResult& result) {
  std::ostringstream os;
  os.precision(4);
  os << "command " << command.command_id << ": " << bridge::OutcomeName(result.outcome);
  if (!result.object_id.empty()) os << ", object " << result.object_id;
  if (result.contact_width_m > 0.0) {
    os << ", l_c = " << result.contact_width_m * 1000.0
       << " mm, l_g = " << result.grasped_width_m * 1000.0 << " mm, deformation "
       << result.deformation_rate;
  }
  os << " (" << result.execution_s * 1000.0 << " ms): " << result.reason;
  return os.str();
}

}  // namespace

core::Result<std::unique_ptr<SimRobotLoop>> SimRobotLoop::Start(
    SimRobot& robot, const bridge::BridgeOptions& options, const std::string& robot_id,
    std::function<void(const std::string&)> log) {
  if (!log) log = [](const std::string& line) { std::cerr << line << std::endl; };
  auto endpoint =
      bridge::RobotEndpoint::Create(options, robot_id, /*simulated=*/true, robot.workspace());
  if (!endpoint.ok()) return endpoint.error();
  std::unique_ptr<SimRobotLoop> loop(new SimRobotLoop(robot, std::move(log)));
  loop->endpoint_ = std::move(endpoint).value();
  loop->thread_ = std::thread([raw = loop.get()] { raw->Run(); });
  return loop;
}

SimRobotLoop::~SimRobotLoop() { Stop(); }

void SimRobotLoop::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  // Leaving the bus (deleting the endpoint) tells every service at once that this robot is gone.
  endpoint_.reset();
}

void SimRobotLoop::Run() {
  while (!stop_) {
    auto command = endpoint_->WaitForCommand(kPollS);
    if (!command.ok()) {
      log_("bus error while waiting for commands: " + command.error().message);
      std::this_thread::sleep_for(std::chrono::duration<double>(kPollS));
      continue;
    }
    if (command.value()) RunOne(*command.value());
  }
}

void SimRobotLoop::RunOne(const bridge::GraspCommand& command) {
  if (auto beat = endpoint_->Heartbeat(bridge::RobotState::kExecuting, command.command_id);
      !beat.ok()) {
    log_("heartbeat failed: " + beat.error().message);
  }
  bridge::GraspResult result = robot_.Execute(command);
  result.robot_id = endpoint_->robot_id();
  log_(Summary(command, result));
  if (auto published = endpoint_->PublishResult(result); !published.ok()) {
    log_("publishing the result of " + command.command_id +
         " failed: " + published.error().message);
  }
  if (auto beat = endpoint_->Heartbeat(bridge::RobotState::kIdle); !beat.ok()) {
    log_("heartbeat failed: " + beat.error().message);
  }
  ++commands_done_;
}

}  // namespace softgrasp::sim
