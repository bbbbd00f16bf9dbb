// ServiceBridge and RobotEndpoint in one process on the loopback config, plus plain DDS
// endpoints made from the generated types (a ROS 2-style pose subscriber, a foreign writer).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <set>

#include "api/generated/pose_stamped.h"
#include "service/bridge/bridge.h"
#include "service/bridge/messages_dds.h"
#include "tests/bridge/bridge_test_util.h"

namespace softgrasp::bridge {
namespace {

using testing::kTestWorkspace;
using testing::MakeCommand;
using testing::TestOptions;
using testing::WaitUntil;

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

std::unique_ptr<ServiceBridge> MakeService(const BridgeOptions& options = TestOptions()) {
  auto service = ServiceBridge::Create(options);
  if (!service) ADD_FAILURE() << service.error().message;
  return service ? std::move(service).value() : nullptr;
}

std::unique_ptr<RobotEndpoint> MakeRobot(const std::string& id,
                                         const BridgeOptions& options = TestOptions()) {
  auto robot = RobotEndpoint::Create(options, id, /*simulated=*/true, kTestWorkspace);
  if (!robot) ADD_FAILURE() << robot.error().message;
  return robot ? std::move(robot).value() : nullptr;
}

// A plain participant on the test domain. The bridge must have opened the domain first (it
// carries the loopback config); this participant then joins that domain instance.
class RawParticipant {
 public:
  RawParticipant() : pp_(dds_create_participant(SOFTGRASP_BRIDGE_TEST_DOMAIN, nullptr, nullptr)) {
    EXPECT_GT(pp_.get(), 0);
  }
  dds_entity_t get() const { return pp_.get(); }

 private:
  Entity pp_;
};

TEST(BridgeLoopback, CommandResultHeartbeatAndDisappearance) {
  auto service = MakeService();
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(service && robot);

  ASSERT_GE(WaitUntil([&] { return IsAlive(*service, "arm-1"); }, 5.0), 0.0);
  const RobotInfo seen = *FindRobot(*service, "arm-1");
  EXPECT_TRUE(seen.status.simulated);
  EXPECT_EQ(seen.status.state, RobotState::kIdle);
  EXPECT_EQ(seen.status.workspace.frame_id, "camera");
  EXPECT_EQ(seen.status.workspace.max_m, kTestWorkspace.max_m);
  // Heartbeats keep coming (period 0.2 s): the sequence grows and the last one is fresh.
  const std::uint64_t first_seq = seen.status.heartbeat_seq;
  ASSERT_GE(
      WaitUntil([&] { return FindRobot(*service, "arm-1")->status.heartbeat_seq >= first_seq + 2; },
                3.0),
      0.0);
  EXPECT_LT(FindRobot(*service, "arm-1")->heartbeat_age_s, 1.0);
  ASSERT_EQ(service->AliveRobots().size(), 1u);

  const GraspCommand sent = MakeCommand("cmd-1", "arm-1");
  ASSERT_TRUE(service->Publish(sent).ok());
  auto received = robot->WaitForCommand(5.0);
  ASSERT_TRUE(received.ok()) << received.error().message;
  ASSERT_TRUE(received.value().has_value());
  const GraspCommand& got = *received.value();
  EXPECT_EQ(got.command_id, sent.command_id);
  EXPECT_EQ(got.robot_id, sent.robot_id);
  EXPECT_EQ(got.position_m, sent.position_m);
  EXPECT_EQ(got.orientation_xyzw, sent.orientation_xyzw);
  EXPECT_EQ(got.opening_width_m, sent.opening_width_m);
  EXPECT_EQ(got.issued_unix_ns, sent.issued_unix_ns);

  ASSERT_TRUE(robot->Heartbeat(RobotState::kExecuting, got.command_id).ok());
  ASSERT_GE(
      WaitUntil(
          [&] { return FindRobot(*service, "arm-1")->status.state == RobotState::kExecuting; },
          3.0),
      0.0);
  EXPECT_EQ(FindRobot(*service, "arm-1")->status.current_command_id, "cmd-1");

  GraspResult result;
  result.command_id = got.command_id;
  result.object_id = got.object_id;
  result.outcome = GraspOutcome::kSucceeded;
  result.contact_width_m = 0.06;
  result.grasped_width_m = 0.051;
  result.deformation_rate = (0.06 - 0.051) / 0.06;
  result.execution_s = 1.5;
  ASSERT_TRUE(robot->PublishResult(result).ok());
  auto answer = service->WaitForResult("cmd-1", 5.0);
  ASSERT_TRUE(answer.has_value());
  EXPECT_EQ(answer->robot_id, "arm-1");  // filled in by the endpoint
  EXPECT_EQ(answer->outcome, GraspOutcome::kSucceeded);
  EXPECT_EQ(answer->contact_width_m, 0.06);
  EXPECT_EQ(answer->grasped_width_m, 0.051);
  EXPECT_DOUBLE_EQ(answer->deformation_rate, 0.15);
  EXPECT_GT(answer->finished_unix_ns, 0);
  EXPECT_TRUE(service->TakeResults().empty());

  // The robot process ends: its status writer goes, the instance has no writers left.
  robot.reset();
  const double gone_after_s = WaitUntil([&] { return !IsAlive(*service, "arm-1"); },
                                        TestOptions().liveliness_lease_s + 1.0);
  ASSERT_GE(gone_after_s, 0.0);
  EXPECT_TRUE(service->AliveRobots().empty());
  ASSERT_EQ(service->Robots().size(), 1u);  // still listed, as not alive
  EXPECT_EQ(service->invalid_samples(), 0);
}

TEST(BridgeLoopback, RobotThatStopsHeartbeatingLosesLiveliness) {
  auto service = MakeService();
  BridgeOptions options = TestOptions();
  options.liveliness_lease_s = 0.5;
  options.heartbeat_period_s = 0.0;  // only explicit heartbeats
  auto robot = MakeRobot("quiet", options);
  ASSERT_TRUE(service && robot);
  ASSERT_GE(WaitUntil([&] { return IsAlive(*service, "quiet"); }, 5.0), 0.0);
  // No more heartbeats: the writer's lease runs out though the process and endpoint live on.
  const double lost_after_s = WaitUntil([&] { return !IsAlive(*service, "quiet"); }, 0.5 + 1.5);
  ASSERT_GE(lost_after_s, 0.0);
  // A heartbeat brings it back.
  ASSERT_TRUE(robot->Heartbeat(RobotState::kIdle).ok());
  ASSERT_GE(WaitUntil([&] { return IsAlive(*service, "quiet"); }, 2.0), 0.0);
}

TEST(BridgeLoopback, RosStylePoseSubscriberReadsTheForwardedPose) {
  auto service = MakeService();
  ASSERT_TRUE(service);
  RawParticipant raw;
  const dds_entity_t topic = dds_create_topic(raw.get(), &geometry_msgs_msg_dds__PoseStamped__desc,
                                              "rt/softgrasp/grasp_pose", nullptr, nullptr);
  ASSERT_GT(topic, 0);
  // ROS 2's default subscription QoS: reliable, volatile, keep-last 10.
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  Entity reader(dds_create_reader(raw.get(), topic, qos, nullptr));
  dds_delete_qos(qos);
  ASSERT_GT(reader.get(), 0);
  ASSERT_GE(WaitUntil(
                [&] {
                  dds_subscription_matched_status_t st;
                  return dds_get_subscription_matched_status(reader.get(), &st) == 0 &&
                         st.current_count > 0;
                },
                5.0),
            0.0);

  const GraspCommand sent = MakeCommand("pose-1");
  ASSERT_TRUE(service->Publish(sent).ok());
  geometry_msgs_msg_dds__PoseStamped_ pose{};
  bool got = false;
  ASSERT_GE(WaitUntil(
                [&] {
                  void* samples[1] = {&pose};
                  dds_sample_info_t info;
                  const dds_return_t n = dds_take(reader.get(), samples, &info, 1, 1);
                  got = got || (n == 1 && info.valid_data);
                  return got;
                },
                5.0),
            0.0);
  EXPECT_EQ(pose.header.stamp.sec, 1'750'000'000);
  EXPECT_EQ(pose.header.stamp.nanosec, 250'000'000u);
  EXPECT_STREQ(pose.header.frame_id, "camera");
  EXPECT_EQ(pose.pose.position.x, sent.position_m[0]);
  EXPECT_EQ(pose.pose.position.y, sent.position_m[1]);
  EXPECT_EQ(pose.pose.position.z, sent.position_m[2]);
  EXPECT_EQ(pose.pose.orientation.x, sent.orientation_xyzw[0]);
  EXPECT_EQ(pose.pose.orientation.y, sent.orientation_xyzw[1]);
  EXPECT_EQ(pose.pose.orientation.z, sent.orientation_xyzw[2]);
  EXPECT_EQ(pose.pose.orientation.w, sent.orientation_xyzw[3]);
  dds_sample_free(&pose, &geometry_msgs_msg_dds__PoseStamped__desc, DDS_FREE_CONTENTS);

  // A "latched" (transient-local) subscriber joining later still gets the last pose.
  dds_qos_t* latched = dds_create_qos();
  dds_qset_reliability(latched, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(latched, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(latched, DDS_HISTORY_KEEP_LAST, 1);
  Entity late(dds_create_reader(raw.get(), topic, latched, nullptr));
  dds_delete_qos(latched);
  ASSERT_GT(late.get(), 0);
  geometry_msgs_msg_dds__PoseStamped_ late_pose{};
  bool late_got = false;
  ASSERT_GE(WaitUntil(
                [&] {
                  void* samples[1] = {&late_pose};
                  dds_sample_info_t info;
                  late_got = late_got ||
                             (dds_take(late.get(), samples, &info, 1, 1) == 1 && info.valid_data);
                  return late_got;
                },
                5.0),
            0.0);
  EXPECT_EQ(late_pose.pose.position.z, sent.position_m[2]);
  dds_sample_free(&late_pose, &geometry_msgs_msg_dds__PoseStamped__desc, DDS_FREE_CONTENTS);
}

TEST(BridgeLoopback, LateJoinersGetPendingCommandsAndResultsButNotRetiredCommands) {
  auto service = MakeService();
  ASSERT_TRUE(service);
  ASSERT_TRUE(service->Publish(MakeCommand("early-a")).ok());
  ASSERT_TRUE(service->Publish(MakeCommand("early-b")).ok());

  // A robot joining after the commands were published still receives both (transient-local).
  auto robot = MakeRobot("late-arm");
  ASSERT_TRUE(robot);
  std::set<std::string> ids;
  for (int i = 0; i < 2; ++i) {
    auto c = robot->WaitForCommand(5.0);
    ASSERT_TRUE(c.ok() && c.value().has_value());
    ids.insert(c.value()->command_id);
  }
  EXPECT_EQ(ids, (std::set<std::string>{"early-a", "early-b"}));

  GraspResult done;
  done.command_id = "early-a";
  done.outcome = GraspOutcome::kFailed;
  done.reason = "slipped";
  ASSERT_TRUE(robot->PublishResult(done).ok());
  ASSERT_TRUE(service->WaitForResult("early-a", 5.0).has_value());  // retires early-a

  // A second robot joining now gets the pending command only.
  auto second = MakeRobot("later-arm");
  ASSERT_TRUE(second);
  auto c = second->WaitForCommand(5.0);
  ASSERT_TRUE(c.ok() && c.value().has_value());
  EXPECT_EQ(c.value()->command_id, "early-b");
  // Had the retired early-a reached it, it would come before a command published now.
  ASSERT_TRUE(service->Publish(MakeCommand("marker")).ok());
  auto next = second->WaitForCommand(5.0);
  ASSERT_TRUE(next.ok() && next.value().has_value());
  EXPECT_EQ(next.value()->command_id, "marker");

  // A service joining after a result was written still receives it (transient-local results).
  GraspResult answered;
  answered.command_id = "early-b";
  answered.outcome = GraspOutcome::kSucceeded;
  ASSERT_TRUE(second->PublishResult(answered).ok());
  auto late_service = MakeService();
  ASSERT_TRUE(late_service);
  auto result = late_service->WaitForResult("early-b", 5.0);
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->robot_id, "later-arm");
}

TEST(BridgeLoopback, RobotsSkipOtherRobotsCommandsAndRepeatedIds) {
  auto service = MakeService();
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(service && robot);
  ASSERT_TRUE(service->Publish(MakeCommand("for-arm-2", "arm-2")).ok());
  ASSERT_TRUE(service->Publish(MakeCommand("for-any", "")).ok());
  auto c = robot->WaitForCommand(5.0);
  ASSERT_TRUE(c.ok() && c.value().has_value());
  EXPECT_EQ(c.value()->command_id, "for-any");

  // The same id again (a retry, or a changed command): never delivered twice.
  GraspCommand again = MakeCommand("for-any", "");
  again.score = 0.1;
  ASSERT_TRUE(service->Publish(again).ok());
  // One writer's samples arrive in order: the next command delivered is the one published after
  // the repeat (and not for-arm-2's).
  ASSERT_TRUE(service->Publish(MakeCommand("marker", "")).ok());
  auto next = robot->WaitForCommand(5.0);
  ASSERT_TRUE(next.ok() && next.value().has_value());
  EXPECT_EQ(next.value()->command_id, "marker");
}

// Two service replicas behind a balancer: a client's retry of an id can reach the replica that
// did not send it first. The robot runs the id once and writes its kept result again for the
// second sender, which would otherwise wait for a result that never comes.
TEST(BridgeLoopback, AnIdSentByTwoServicesMovesTheRobotOnceAndBothHearTheResult) {
  auto first = MakeService();
  auto second = MakeService();
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(first && second && robot);
  ASSERT_TRUE(first->Publish(MakeCommand("shared-id", "")).ok());
  auto c = robot->WaitForCommand(5.0);
  ASSERT_TRUE(c.ok() && c.value().has_value());
  EXPECT_EQ(c.value()->command_id, "shared-id");
  GraspResult done;
  done.command_id = "shared-id";
  done.outcome = GraspOutcome::kSucceeded;
  done.reason = "held";
  ASSERT_TRUE(robot->PublishResult(done).ok());
  ASSERT_TRUE(first->WaitForResult("shared-id", 5.0).has_value());
  // The second replica saw that result while it knew nothing of the id (its tracker drops such
  // results); drain it, as the tracker does.
  ASSERT_GE(WaitUntil([&] { return !second->TakeResults().empty(); }, 5.0), 0.0);

  // The client's retry reaches the second replica, which sends the id again, then another.
  // The robot does not get the repeat: the next command it is given is the one sent after it.
  ASSERT_TRUE(second->Publish(MakeCommand("shared-id", "")).ok());
  ASSERT_TRUE(second->Publish(MakeCommand("marker", "")).ok());
  auto next = robot->WaitForCommand(5.0);
  ASSERT_TRUE(next.ok() && next.value().has_value());
  EXPECT_EQ(next.value()->command_id, "marker");
  // Seeing the repeat, it wrote the kept result again, and the second replica hears it.
  auto heard = second->WaitForResult("shared-id", 5.0);
  ASSERT_TRUE(heard.has_value());
  EXPECT_EQ(heard->outcome, GraspOutcome::kSucceeded);
  EXPECT_EQ(heard->reason, "held");
  EXPECT_EQ(heard->robot_id, "arm-1");
}

TEST(BridgeLoopback, NothingIsSentForAnInvalidCommand) {
  auto service = MakeService();
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(service && robot);
  GraspCommand bad = MakeCommand("nan-1");
  bad.position_m[2] = std::numeric_limits<double>::quiet_NaN();
  auto published = service->Publish(bad);
  ASSERT_FALSE(published.ok());
  EXPECT_EQ(published.error().code, core::ErrorCode::kUnprocessable);
  EXPECT_EQ(published.error().field, "position_m");
  ASSERT_TRUE(service->Publish(MakeCommand("good-1")).ok());
  // One writer's samples arrive in order: had the invalid command gone out, it would come first.
  auto c = robot->WaitForCommand(5.0);
  ASSERT_TRUE(c.ok() && c.value().has_value());
  EXPECT_EQ(c.value()->command_id, "good-1");
}

TEST(BridgeLoopback, InvalidCommandFromAForeignWriterIsRejectedByTheRobot) {
  auto service = MakeService();
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(service && robot);
  RawParticipant raw;
  const dds_entity_t topic = dds_create_topic(raw.get(), &softgrasp_msg_GraspCommand_desc,
                                              kCommandTopic, nullptr, nullptr);
  ASSERT_GT(topic, 0);
  Entity writer(dds_create_writer(raw.get(), topic, CommandQos().get(), nullptr));
  ASSERT_GT(writer.get(), 0);
  GraspCommand bad = MakeCommand("foreign-nan");
  auto sample = ToC(bad);  // valid, then broken in the C struct as a foreign writer could
  sample.get()->opening_width_m = std::numeric_limits<double>::infinity();
  ASSERT_GE(WaitUntil(
                [&] {
                  dds_publication_matched_status_t st;
                  return dds_get_publication_matched_status(writer.get(), &st) == 0 &&
                         st.current_count > 0;
                },
                5.0),
            0.0);
  ASSERT_EQ(dds_write(writer.get(), sample.get()), DDS_RETCODE_OK);

  auto none = robot->WaitForCommand(1.0);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none.value().has_value());
  auto result = service->WaitForResult("foreign-nan", 5.0);
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->outcome, GraspOutcome::kRejected);
  EXPECT_NE(result->reason.find("opening_width_m"), std::string::npos) << result->reason;
}

TEST(BridgeLoopback, BadConfigAndOptionsAreClearErrors) {
  BridgeOptions options = TestOptions();
  options.config = "<CycloneDDS><Domain><General><NoSuchSetting>1</NoSuchSetting>";
  auto malformed = ServiceBridge::Create(options);
  ASSERT_FALSE(malformed.ok());
  EXPECT_EQ(malformed.error().code, core::ErrorCode::kInvalidArgument);
  EXPECT_EQ(malformed.error().field, "config");
  EXPECT_NE(malformed.error().message.find("rejected the config"), std::string::npos)
      << malformed.error().message;

  options.config =
      "<CycloneDDS><Domain id=\"any\"><General><NoSuchSetting>1</NoSuchSetting></General>"
      "</Domain></CycloneDDS>";
  auto unknown = RobotEndpoint::Create(options, "arm", false, kTestWorkspace);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().field, "config");

  options = TestOptions();
  options.domain_id = 233;
  auto domain = ServiceBridge::Create(options);
  ASSERT_FALSE(domain.ok());
  EXPECT_EQ(domain.error().field, "domain_id");

  // One domain, one config per process.
  auto service = MakeService();
  ASSERT_TRUE(service);
  options = TestOptions();
  options.config = LoopbackConfigXml("another-tag");
  auto clash = RobotEndpoint::Create(options, "arm", false, kTestWorkspace);
  ASSERT_FALSE(clash.ok());
  EXPECT_NE(clash.error().message.find("different Cyclone config"), std::string::npos);

  options = TestOptions();
  options.heartbeat_period_s = options.liveliness_lease_s;
  EXPECT_EQ(RobotEndpoint::Create(options, "arm", false, kTestWorkspace).error().field,
            "heartbeat_period_s");
  Workspace inverted = kTestWorkspace;
  inverted.min_m[1] = 2.0;
  auto bad_ws = RobotEndpoint::Create(TestOptions(), "arm", false, inverted);
  ASSERT_FALSE(bad_ws.ok());
  EXPECT_EQ(bad_ws.error().code, core::ErrorCode::kUnprocessable);
  EXPECT_EQ(RobotEndpoint::Create(TestOptions(), "", false, kTestWorkspace).error().field,
            "robot_id");
}

}  // namespace
}  // namespace softgrasp::bridge
