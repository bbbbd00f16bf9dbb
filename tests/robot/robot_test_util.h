#pragma once
// Shared by the robot-command tests (tests/robot, tests/rest): a temporary journal folder, a
// robot endpoint on the test's domain that answers like a robot, and a counter of the grasp
// poses the service wrote (one per command written on the bus).

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "api/generated/pose_stamped.h"
#include "service/bridge/bridge.h"
#include "tests/bridge/bridge_test_util.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::robot::testing {

using bridge::testing::TestOptions;
using bridge::testing::WaitUntil;
using softgrasp::testing::TempDir;  // a fresh journal folder per test

inline std::unique_ptr<bridge::ServiceBridge> MakeServiceBridge() {
  auto service = bridge::ServiceBridge::Create(TestOptions());
  if (!service) ADD_FAILURE() << service.error().message;
  return service ? std::move(service).value() : nullptr;
}

inline std::unique_ptr<bridge::RobotEndpoint> MakeRobot(
    const std::string& id, const bridge::Workspace& workspace = bridge::testing::kTestWorkspace) {
  auto robot = bridge::RobotEndpoint::Create(TestOptions(), id, /*simulated=*/true, workspace);
  if (!robot) ADD_FAILURE() << robot.error().message;
  return robot ? std::move(robot).value() : nullptr;
}

/// The result a test robot reports for `command`: contact at the opening, squeezed by 20 %.
inline bridge::GraspResult SqueezeResult(const bridge::GraspCommand& command) {
  bridge::GraspResult r;
  r.command_id = command.command_id;
  r.object_id = command.object_id;
  r.outcome = bridge::GraspOutcome::kSucceeded;
  r.contact_width_m = command.opening_width_m * 0.75;
  r.grasped_width_m = r.contact_width_m * 0.8;
  r.deformation_rate = (r.contact_width_m - r.grasped_width_m) / r.contact_width_m;
  r.execution_s = 1.25;
  r.finished_unix_ns = bridge::UnixNowNs();
  return r;
}

/// Counts the ROS 2 pose samples on rt/softgrasp/grasp_pose: the service writes exactly one per
/// command write, so this counts what went on the bus. Needs the domain opened first (by a
/// bridge made with TestOptions()).
class PoseCounter {
 public:
  PoseCounter() {
    participant_ =
        bridge::Entity(dds_create_participant(SOFTGRASP_BRIDGE_TEST_DOMAIN, nullptr, nullptr));
    EXPECT_GT(participant_.get(), 0);
    const dds_entity_t topic =
        dds_create_topic(participant_.get(), &geometry_msgs_msg_dds__PoseStamped__desc,
                         bridge::kPoseTopic, nullptr, nullptr);
    EXPECT_GT(topic, 0);
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
    reader_ = bridge::Entity(dds_create_reader(participant_.get(), topic, qos, nullptr));
    dds_delete_qos(qos);
    EXPECT_GT(reader_.get(), 0);
  }
  /// Writers matched (the service's pose writer): wait for this before counting.
  int matched() const {
    dds_subscription_matched_status_t status{};
    dds_get_subscription_matched_status(reader_.get(), &status);
    return static_cast<int>(status.current_count);
  }
  /// Takes what arrived and adds it to the running count.
  int count() {
    Take();
    return static_cast<int>(positions_.size());
  }
  /// Whether a pose at exactly `position_m` arrived. Poses come from one writer, in order: once a
  /// command's pose is here, so is every pose written before it.
  bool Seen(const std::array<double, 3>& position_m) {
    Take();
    return std::find(positions_.begin(), positions_.end(), position_m) != positions_.end();
  }

 private:
  void Take() {
    for (;;) {
      geometry_msgs_msg_dds__PoseStamped_ pose{};
      void* samples[1] = {&pose};
      dds_sample_info_t info;
      const dds_return_t n = dds_take(reader_.get(), samples, &info, 1, 1);
      if (n == 1 && info.valid_data) {
        positions_.push_back({pose.pose.position.x, pose.pose.position.y, pose.pose.position.z});
      }
      dds_sample_free(&pose, &geometry_msgs_msg_dds__PoseStamped__desc, DDS_FREE_CONTENTS);
      if (n <= 0) return;
    }
  }

  bridge::Entity participant_;
  bridge::Entity reader_;
  std::vector<std::array<double, 3>> positions_;  // in arrival order
};

}  // namespace softgrasp::robot::testing
