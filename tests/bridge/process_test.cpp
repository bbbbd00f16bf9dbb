// The robot in another process (bridge_robot_helper, forked and exec'd here) on loopback: the
// service forwards a command, reads the result back, and sees the robot go when it hangs or dies.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <optional>
#include <string>
#include <vector>

#include "service/bridge/bridge.h"
#include "tests/bridge/bridge_test_util.h"

extern char** environ;

namespace softgrasp::bridge {
namespace {

using testing::MakeCommand;
using testing::ProcessTag;
using testing::TestOptions;
using testing::WaitUntil;

constexpr double kRobotLeaseS = 1.0;

// The helper process; killed and reaped when this goes, whatever the test did.
class RobotProcess {
 public:
  explicit RobotProcess(const std::string& robot_id) {
    std::vector<std::string> args = {
        BRIDGE_ROBOT_HELPER, "--domain", std::to_string(SOFTGRASP_BRIDGE_TEST_DOMAIN),
        "--robot-id",        robot_id,   "--tag",
        ProcessTag(),        "--lease",  std::to_string(kRobotLeaseS),
        "--period",          "0.2"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, argv[0], nullptr, nullptr, argv.data(), environ) != 0) pid_ = -1;
  }
  ~RobotProcess() {
    if (pid_ > 0) {
      Signal(SIGKILL);
      Reap();
    }
  }
  RobotProcess(const RobotProcess&) = delete;
  RobotProcess& operator=(const RobotProcess&) = delete;

  bool started() const { return pid_ > 0; }
  void Signal(int sig) const { ::kill(pid_, sig); }
  /// Waits for the process to end; returns its wait status.
  int Reap() {
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }
  /// True if the process has already exited (e.g. it could not join the bus).
  bool Exited() const {
    int status = 0;
    return ::waitpid(pid_, &status, WNOHANG) == pid_;
  }

 private:
  pid_t pid_ = -1;
};

std::optional<RobotInfo> FindRobot(const ServiceBridge& service, const std::string& id) {
  for (const RobotInfo& r : service.Robots()) {
    if (r.status.robot_id == id) return r;
  }
  return std::nullopt;
}

bool IsAlive(const ServiceBridge& service, const std::string& id) {
  auto r = FindRobot(service, id);
  return r && r->alive;
}

std::unique_ptr<ServiceBridge> MakeService() {
  auto service = ServiceBridge::Create(TestOptions());
  if (!service) ADD_FAILURE() << service.error().message;
  return service ? std::move(service).value() : nullptr;
}

TEST(BridgeProcess, RoundTripThenRobotKilledIsNotAliveWithinTheLease) {
  auto service = MakeService();
  ASSERT_TRUE(service);
  RobotProcess robot("proc-arm");
  ASSERT_TRUE(robot.started());
  ASSERT_GE(WaitUntil([&] { return IsAlive(*service, "proc-arm"); }, 10.0), 0.0)
      << "robot never appeared (exited: " << robot.Exited() << ")";
  const RobotInfo info = *FindRobot(*service, "proc-arm");
  EXPECT_TRUE(info.status.simulated);
  EXPECT_LT(info.heartbeat_age_s, 1.0);

  const GraspCommand sent = MakeCommand("proc-cmd-1", "proc-arm");
  ASSERT_TRUE(service->Publish(sent).ok());
  auto result = service->WaitForResult("proc-cmd-1", 10.0);
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->robot_id, "proc-arm");
  EXPECT_EQ(result->object_id, sent.object_id);
  EXPECT_EQ(result->outcome, GraspOutcome::kSucceeded);
  // The helper's model: l_c = opening / 2, l_g = 0.8 l_c.
  EXPECT_DOUBLE_EQ(result->contact_width_m, sent.opening_width_m / 2.0);
  EXPECT_DOUBLE_EQ(result->grasped_width_m, 0.8 * sent.opening_width_m / 2.0);
  EXPECT_DOUBLE_EQ(result->deformation_rate, 0.2);

  robot.Signal(SIGKILL);
  robot.Reap();
  const double gone_after_s =
      WaitUntil([&] { return !IsAlive(*service, "proc-arm"); }, kRobotLeaseS + 2.0);
  ASSERT_GE(gone_after_s, 0.0);
  std::printf("killed robot not alive after %.2f s (lease %.1f s)\n", gone_after_s, kRobotLeaseS);
  EXPECT_TRUE(service->AliveRobots().empty());
}

TEST(BridgeProcess, HungRobotLosesLivelinessThenRecovers) {
  auto service = MakeService();
  ASSERT_TRUE(service);
  RobotProcess robot("hung-arm");
  ASSERT_TRUE(robot.started());
  ASSERT_GE(WaitUntil([&] { return IsAlive(*service, "hung-arm"); }, 10.0), 0.0);

  // Frozen process: no heartbeat, no crash, sockets still open.
  robot.Signal(SIGSTOP);
  const double lost_after_s =
      WaitUntil([&] { return !IsAlive(*service, "hung-arm"); }, kRobotLeaseS + 2.0);
  robot.Signal(SIGCONT);
  ASSERT_GE(lost_after_s, 0.0);
  std::printf("stopped robot not alive after %.2f s (lease %.1f s)\n", lost_after_s, kRobotLeaseS);
  // Heartbeats resume and so does liveliness.
  ASSERT_GE(WaitUntil([&] { return IsAlive(*service, "hung-arm"); }, 10.0), 0.0);
  ASSERT_TRUE(service->Publish(MakeCommand("after-hang", "hung-arm")).ok());
  EXPECT_TRUE(service->WaitForResult("after-hang", 10.0).has_value());
}

}  // namespace
}  // namespace softgrasp::bridge
