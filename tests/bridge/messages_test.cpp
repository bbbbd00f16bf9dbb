// Conversions between the C++ message types and the idlc-generated C structs, and validation.
#include "service/bridge/messages.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "service/bridge/messages_dds.h"

namespace softgrasp::bridge {
namespace {

GraspCommand SampleCommand() {
  GraspCommand c;
  c.command_id = "cmd-\xc3\xa9-42";  // UTF-8 survives
  c.robot_id = "arm-1";
  c.object_id = "sponge-3";
  c.frame_id = "camera";
  c.position_m = {0.125, -0.25, 0.875};
  // A unit quaternion: 30 degrees about z.
  c.orientation_xyzw = {0.0, 0.0, std::sin(M_PI / 12), std::cos(M_PI / 12)};
  c.opening_width_m = 0.085;
  c.closing_force_n = 12.5;
  c.approach_m = 0.1;
  c.retreat_m = 0.15;
  c.score = 0.73;
  c.issued_unix_ns = 1'700'000'000'123'456'789LL;
  return c;
}

GraspResult SampleResult() {
  GraspResult r;
  r.command_id = "cmd-42";
  r.robot_id = "arm-1";
  r.object_id = "sponge-3";
  r.outcome = GraspOutcome::kTimedOut;
  r.reason = "no motion within 5 s";
  r.contact_width_m = 0.06;
  r.grasped_width_m = 0.045;
  r.deformation_rate = 0.25;
  r.execution_s = 5.0;
  r.finished_unix_ns = 1'700'000'010'000'000'000LL;
  return r;
}

RobotStatus SampleStatus() {
  RobotStatus s;
  s.robot_id = "arm-1";
  s.state = RobotState::kExecuting;
  s.simulated = true;
  s.workspace = Workspace{"camera", {-0.5, -0.4, 0.3}, {0.5, 0.4, 1.2}};
  s.current_command_id = "cmd-42";
  s.detail = "";
  s.heartbeat_seq = 123456789012ULL;
  s.stamp_unix_ns = 1'700'000'000'000'000'001LL;
  return s;
}

TEST(BridgeMessages, CommandRoundTripsThroughC) {
  const GraspCommand in = SampleCommand();
  ASSERT_TRUE(Validate(in).ok());
  auto c = ToC(in);
  // The C struct owns its own copies of the strings.
  EXPECT_NE(c->command_id, in.command_id.c_str());
  EXPECT_STREQ(c->command_id, in.command_id.c_str());
  EXPECT_EQ(c->orientation_xyzw[3], in.orientation_xyzw[3]);
  auto out = FromC(*c);
  ASSERT_TRUE(out.ok()) << out.error().message;
  const GraspCommand& o = out.value();
  EXPECT_EQ(o.command_id, in.command_id);
  EXPECT_EQ(o.robot_id, in.robot_id);
  EXPECT_EQ(o.object_id, in.object_id);
  EXPECT_EQ(o.frame_id, in.frame_id);
  EXPECT_EQ(o.position_m, in.position_m);
  EXPECT_EQ(o.orientation_xyzw, in.orientation_xyzw);
  EXPECT_EQ(o.opening_width_m, in.opening_width_m);
  EXPECT_EQ(o.closing_force_n, in.closing_force_n);
  EXPECT_EQ(o.approach_m, in.approach_m);
  EXPECT_EQ(o.retreat_m, in.retreat_m);
  EXPECT_EQ(o.score, in.score);
  EXPECT_EQ(o.issued_unix_ns, in.issued_unix_ns);
}

TEST(BridgeMessages, ResultRoundTripsEveryOutcome) {
  for (GraspOutcome outcome : {GraspOutcome::kSucceeded, GraspOutcome::kFailed,
                               GraspOutcome::kRejected, GraspOutcome::kTimedOut}) {
    GraspResult in = SampleResult();
    in.outcome = outcome;
    auto c = ToC(in);
    auto out = FromC(*c);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(out.value().outcome, outcome);
    EXPECT_EQ(out.value().command_id, in.command_id);
    EXPECT_EQ(out.value().robot_id, in.robot_id);
    EXPECT_EQ(out.value().object_id, in.object_id);
    EXPECT_EQ(out.value().reason, in.reason);
    EXPECT_EQ(out.value().contact_width_m, in.contact_width_m);
    EXPECT_EQ(out.value().grasped_width_m, in.grasped_width_m);
    EXPECT_EQ(out.value().deformation_rate, in.deformation_rate);
    EXPECT_EQ(out.value().execution_s, in.execution_s);
    EXPECT_EQ(out.value().finished_unix_ns, in.finished_unix_ns);
  }
  EXPECT_STREQ(OutcomeName(GraspOutcome::kTimedOut), "timed_out");
}

TEST(BridgeMessages, StatusRoundTripsEveryState) {
  for (RobotState state : {RobotState::kIdle, RobotState::kExecuting, RobotState::kFault}) {
    RobotStatus in = SampleStatus();
    in.state = state;
    auto c = ToC(in);
    auto out = FromC(*c);
    ASSERT_TRUE(out.ok()) << out.error().message;
    const RobotStatus& o = out.value();
    EXPECT_EQ(o.state, state);
    EXPECT_EQ(o.robot_id, in.robot_id);
    EXPECT_EQ(o.simulated, in.simulated);
    EXPECT_EQ(o.workspace.frame_id, in.workspace.frame_id);
    EXPECT_EQ(o.workspace.min_m, in.workspace.min_m);
    EXPECT_EQ(o.workspace.max_m, in.workspace.max_m);
    EXPECT_EQ(o.current_command_id, in.current_command_id);
    EXPECT_EQ(o.detail, in.detail);
    EXPECT_EQ(o.heartbeat_seq, in.heartbeat_seq);
    EXPECT_EQ(o.stamp_unix_ns, in.stamp_unix_ns);
  }
  EXPECT_STREQ(RobotStateName(RobotState::kFault), "fault");
}

TEST(BridgeMessages, PoseStampedMirrorsTheCommandFieldForField) {
  const GraspCommand in = SampleCommand();
  auto pose = ToPoseStamped(in);
  EXPECT_EQ(pose->header.stamp.sec, 1'700'000'000);
  EXPECT_EQ(pose->header.stamp.nanosec, 123'456'789u);
  EXPECT_STREQ(pose->header.frame_id, "camera");
  EXPECT_EQ(pose->pose.position.x, 0.125);
  EXPECT_EQ(pose->pose.position.y, -0.25);
  EXPECT_EQ(pose->pose.position.z, 0.875);
  EXPECT_EQ(pose->pose.orientation.x, 0.0);
  EXPECT_EQ(pose->pose.orientation.z, in.orientation_xyzw[2]);
  EXPECT_EQ(pose->pose.orientation.w, in.orientation_xyzw[3]);
  // The ROS 2 type name a rmw_cyclonedds subscriber matches on.
  EXPECT_STREQ(geometry_msgs_msg_dds__PoseStamped__desc.m_typename,
               "geometry_msgs::msg::dds_::PoseStamped_");
}

TEST(BridgeMessages, NonFiniteNumbersAreRejectedWithTheirField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    void (*mutate)(GraspCommand&, double);
    const char* field;
  };
  const Case cases[] = {
      {[](GraspCommand& c, double v) { c.position_m[1] = v; }, "position_m"},
      {[](GraspCommand& c, double v) { c.orientation_xyzw[0] = v; }, "orientation_xyzw"},
      {[](GraspCommand& c, double v) { c.opening_width_m = v; }, "opening_width_m"},
      {[](GraspCommand& c, double v) { c.closing_force_n = v; }, "closing_force_n"},
      {[](GraspCommand& c, double v) { c.approach_m = v; }, "approach_m"},
      {[](GraspCommand& c, double v) { c.retreat_m = v; }, "retreat_m"},
      {[](GraspCommand& c, double v) { c.score = v; }, "score"},
  };
  for (const Case& k : cases) {
    for (double bad : {nan, inf, -inf}) {
      GraspCommand c = SampleCommand();
      k.mutate(c, bad);
      auto v = Validate(c);
      ASSERT_FALSE(v.ok()) << k.field;
      EXPECT_EQ(v.error().code, core::ErrorCode::kUnprocessable);
      EXPECT_EQ(v.error().field, k.field);
      // And the same on the way in from the bus (C struct built by hand, as a foreign writer).
      auto c_struct = ToC(c);
      EXPECT_FALSE(FromC(*c_struct).ok()) << k.field;
    }
  }
  GraspResult r = SampleResult();
  r.deformation_rate = nan;
  EXPECT_EQ(Validate(r).error().field, "deformation_rate");
  RobotStatus s = SampleStatus();
  s.workspace.max_m[2] = inf;
  EXPECT_EQ(Validate(s).error().field, "workspace.max_m");
}

TEST(BridgeMessages, OtherBadInputIsRejected) {
  auto field_of = [](GraspCommand c) { return Validate(std::move(c)).error().field; };
  GraspCommand c = SampleCommand();
  c.command_id.clear();
  EXPECT_EQ(field_of(c), "command_id");
  c = SampleCommand();
  c.command_id = std::string(kMaxIdBytes + 1, 'x');
  EXPECT_EQ(field_of(c), "command_id");
  c = SampleCommand();
  c.robot_id = "arm\n1";
  EXPECT_EQ(field_of(c), "robot_id");
  c = SampleCommand();
  c.frame_id.clear();
  EXPECT_EQ(field_of(c), "frame_id");
  c = SampleCommand();
  c.orientation_xyzw = {0.0, 0.0, 0.0, 0.9};
  EXPECT_EQ(field_of(c), "orientation_xyzw");
  c = SampleCommand();
  c.opening_width_m = 0.0;
  EXPECT_EQ(field_of(c), "opening_width_m");
  c = SampleCommand();
  c.approach_m = -0.01;
  EXPECT_EQ(field_of(c), "approach_m");
  c = SampleCommand();
  c.issued_unix_ns = -1;
  EXPECT_EQ(field_of(c), "issued_unix_ns");
  c = SampleCommand();
  c.issued_unix_ns = 3'000'000'000LL * 1'000'000'000LL;  // past int32 seconds (2038)
  EXPECT_EQ(field_of(c), "issued_unix_ns");

  RobotStatus s = SampleStatus();
  s.workspace.min_m[0] = 1.0;  // min > max
  EXPECT_EQ(Validate(s).error().field, "workspace.max_m");
  GraspResult r = SampleResult();
  r.reason = std::string(kMaxTextBytes + 1, 'r');
  EXPECT_EQ(Validate(r).error().field, "reason");
}

TEST(BridgeMessages, UnknownEnumValuesFromTheBusAreErrors) {
  auto result = ToC(SampleResult());
  // Raw bytes, as a foreign writer could send them (an enum cast would itself be undefined).
  const std::int32_t seven = 7;
  std::memcpy(&result.get()->outcome, &seven, sizeof seven);
  auto r = FromC(*result);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "outcome");
  auto status = ToC(SampleStatus());
  const std::int32_t minus_one = -1;
  std::memcpy(&status.get()->state, &minus_one, sizeof minus_one);
  auto s = FromC(*status);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "state");
}

TEST(BridgeMessages, NullStringsFromCReadAsEmpty) {
  softgrasp_msg_GraspCommand c{};
  c.orientation_xyzw[3] = 1.0;
  c.opening_width_m = 0.05;
  auto out = FromC(c);  // all strings null: command_id is required, so an error, not a crash
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.error().field, "command_id");
}

TEST(BridgeMessages, WorkspaceContainsIsFrameAwareAndClosed) {
  const Workspace w{"camera", {-0.5, -0.4, 0.3}, {0.5, 0.4, 1.2}};
  EXPECT_TRUE(w.Contains("camera", {0.0, 0.0, 0.5}));
  EXPECT_TRUE(w.Contains("camera", {0.5, -0.4, 1.2}));  // corners included
  EXPECT_FALSE(w.Contains("camera", {0.5001, 0.0, 0.5}));
  EXPECT_FALSE(w.Contains("world", {0.0, 0.0, 0.5}));
  EXPECT_FALSE(w.Contains("camera", {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.5}));
}

}  // namespace
}  // namespace softgrasp::bridge
