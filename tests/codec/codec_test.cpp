#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "service/codec/json_codec.h"

namespace softgrasp::codec {
namespace {

using core::ErrorCode;

// The error a reader gives for `j`, or a failure when it accepts it.
template <class Reader>
core::Error ErrorOf(Reader read, const json& j) {
  auto r = read(j);
  if (r.ok()) {
    ADD_FAILURE() << "accepted " << j.dump();
    return {};
  }
  return r.error();
}

TEST(CameraCodec, RoundTripsEveryField) {
  const core::Camera camera{612.5, 610.25, 318.0, 241.5, 1280, 720};
  const json j = ToJson(camera);
  EXPECT_EQ(j.dump(),
            R"({"cx":318.0,"cy":241.5,"fx":612.5,"fy":610.25,"height":720,"width":1280})");
  auto back = CameraFromJson(j, "camera");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back.value().fx, 612.5);
  EXPECT_EQ(back.value().fy, 610.25);
  EXPECT_EQ(back.value().cx, 318.0);
  EXPECT_EQ(back.value().cy, 241.5);
  EXPECT_EQ(back.value().width, 1280);
  EXPECT_EQ(back.value().height, 720);
}

TEST(CameraCodec, NamesTheFieldAtFault) {
  const auto read = [](const json& j) { return CameraFromJson(j, "camera"); };
  json missing = ToJson(core::Camera{});
  missing.erase("cy");
  core::Error e = ErrorOf(read, missing);
  EXPECT_EQ(e.code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(e.field, "camera.cy");
  EXPECT_EQ(e.message, "camera.cy is required");

  json text = ToJson(core::Camera{});
  text["fx"] = "525";
  e = ErrorOf(read, text);
  EXPECT_EQ(e.code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(e.field, "camera.fx");

  json fractional = ToJson(core::Camera{});
  fractional["width"] = 640.5;
  EXPECT_EQ(ErrorOf(read, fractional).field, "camera.width");

  json nan = ToJson(core::Camera{});
  nan["cx"] = std::numeric_limits<double>::quiet_NaN();
  e = ErrorOf(read, nan);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.field, "camera.cx");

  json flat = ToJson(core::Camera{});
  flat["fy"] = 0.0;
  e = ErrorOf(read, flat);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.field, "camera.fy");

  json empty = ToJson(core::Camera{});
  empty["height"] = 0;
  EXPECT_EQ(ErrorOf(read, empty).field, "camera.height");

  e = ErrorOf(read, json::array({1, 2, 3}));
  EXPECT_EQ(e.code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(e.field, "camera");
}

TEST(GripperCodec, WritesMillimetresThatReadBackAsGiven) {
  core::Gripper g;
  g.opening_stroke_m = core::MetresFromMm(85.3);
  g.finger_width_m = core::MetresFromMm(12.7);
  g.closing_force_n = 7.5;
  g.friction_coefficient = 0.8;
  g.max_press_force_n = 3.0;
  const json j = ToJson(g);
  EXPECT_EQ(j.at("opening_stroke_mm").get<double>(), 85.3);
  EXPECT_EQ(j.at("finger_width_mm").get<double>(), 12.7);
  EXPECT_EQ(j.at("finger_thickness_mm").get<double>(), 8.0);
  EXPECT_EQ(j.at("finger_length_mm").get<double>(), 40.0);
  EXPECT_EQ(j.at("closing_force_n").get<double>(), 7.5);
  EXPECT_EQ(j.at("friction_coefficient").get<double>(), 0.8);
  EXPECT_EQ(j.at("max_press_force_n").get<double>(), 3.0);
  EXPECT_EQ(j.size(), 7u);
}

TEST(FgeCodec, WritesTheRequestableSearch) {
  core::FgeParams p;
  p.top_k = 9;
  p.num_angles = 24;
  p.num_height_steps = 7;
  p.height_step_m = 0.004;
  EXPECT_EQ(ToJson(p).dump(),
            R"({"height_step_m":0.004,"num_angles":24,"num_height_steps":7,"top_k":9})");
}

TEST(PoseCodec, RoundTripsAndRefusesANonUnitQuaternion) {
  const Pose pose{"base", {0.1, -0.2, 0.3}, {0.5, 0.5, -0.5, 0.5}};
  const json j = ToJson(pose);
  EXPECT_EQ(
      j.dump(),
      R"({"frame":"base","orientation_wxyz":[0.5,0.5,-0.5,0.5],"position_m":[0.1,-0.2,0.3]})");
  auto back = PoseFromJson(j, "pose");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back.value().frame, "base");
  EXPECT_EQ(back.value().position_m, pose.position_m);
  EXPECT_EQ(back.value().orientation_wxyz, pose.orientation_wxyz);

  // No frame: written without one, read as "".
  EXPECT_FALSE(ToJson(Pose{"", {0, 0, 0}, {1, 0, 0, 0}}).contains("frame"));
  json unframed = j;
  unframed.erase("frame");
  ASSERT_TRUE(PoseFromJson(unframed, "pose").ok());
  EXPECT_EQ(PoseFromJson(unframed, "pose").value().frame, "");

  const auto read = [](const json& x) { return PoseFromJson(x, "pose"); };
  json scaled = j;
  scaled["orientation_wxyz"] = {1.0, 1.0, 0.0, 0.0};
  core::Error e = ErrorOf(read, scaled);
  EXPECT_EQ(e.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(e.field, "pose.orientation_wxyz");
  EXPECT_NE(e.message.find("unit quaternion"), std::string::npos) << e.message;

  json element = j;
  element["position_m"][1] = "x";
  e = ErrorOf(read, element);
  EXPECT_EQ(e.code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(e.field, "pose.position_m[1]");

  json short_vector = j;
  short_vector["position_m"] = {0.0, 0.0};
  EXPECT_EQ(ErrorOf(read, short_vector).field, "pose.position_m");

  json frame = j;
  frame["frame"] = 3;
  EXPECT_EQ(ErrorOf(read, frame).field, "pose.frame");
}

TEST(WorkspaceCodec, KeysGivenReplaceTheBase) {
  const bridge::Workspace base{"base", {-1, -1, 0}, {1, 1, 1}};
  EXPECT_EQ(ToJson(base).dump(),
            R"({"frame_id":"base","max_m":[1.0,1.0,1.0],"min_m":[-1.0,-1.0,0.0]})");
  auto patched = WorkspaceFromJson(json{{"max_m", {2, 2, 2}}}, "workspace", base);
  ASSERT_TRUE(patched.ok()) << patched.error().message;
  EXPECT_EQ(patched.value().frame_id, "base");
  EXPECT_EQ(patched.value().min_m, base.min_m);
  EXPECT_EQ(patched.value().max_m, (std::array<double, 3>{2, 2, 2}));

  const auto read = [&](const json& j) { return WorkspaceFromJson(j, "workspace", base); };
  EXPECT_EQ(ErrorOf(read, json{{"max", {2, 2, 2}}}).field, "workspace.max");
  EXPECT_EQ(ErrorOf(read, json{{"frame_id", ""}}).field, "workspace.frame_id");
  const core::Error inverted = ErrorOf(read, json{{"min_m", {0, 0, 5}}});
  EXPECT_EQ(inverted.code, ErrorCode::kUnprocessable);
  EXPECT_EQ(inverted.field, "workspace.min_m");
}

bridge::GraspCommand SomeCommand() {
  bridge::GraspCommand c;
  c.command_id = "pick-7";
  c.robot_id = "arm-1";
  c.object_id = "3";
  c.frame_id = "camera";
  c.position_m = {0.01, 0.02, 0.6};
  c.orientation_xyzw = {0.0, 0.0, 0.7071067811865476, 0.7071067811865476};
  c.opening_width_m = 0.04;
  c.closing_force_n = 12.0;
  c.approach_m = 0.1;
  c.retreat_m = 0.15;
  c.score = 0.93;
  c.issued_unix_ns = 1'764'000'000'123'456'789;
  return c;
}

TEST(CommandCodec, TheBusFormRoundTripsExactly) {
  const bridge::GraspCommand c = SomeCommand();
  // Through text, as the journal stores it.
  auto back = CommandFromJson(json::parse(ToJson(c).dump()), "command");
  ASSERT_TRUE(back.ok()) << back.error().message;
  const bridge::GraspCommand& b = back.value();
  EXPECT_EQ(b.command_id, c.command_id);
  EXPECT_EQ(b.robot_id, c.robot_id);
  EXPECT_EQ(b.object_id, c.object_id);
  EXPECT_EQ(b.frame_id, c.frame_id);
  EXPECT_EQ(b.position_m, c.position_m);
  EXPECT_EQ(b.orientation_xyzw, c.orientation_xyzw);
  EXPECT_EQ(b.opening_width_m, c.opening_width_m);
  EXPECT_EQ(b.closing_force_n, c.closing_force_n);
  EXPECT_EQ(b.approach_m, c.approach_m);
  EXPECT_EQ(b.retreat_m, c.retreat_m);
  EXPECT_EQ(b.score, c.score);
  EXPECT_EQ(b.issued_unix_ns, c.issued_unix_ns);

  const auto read = [](const json& j) { return CommandFromJson(j, "command"); };
  for (const char* key : {"command_id", "orientation_xyzw", "score", "issued_unix_ns"}) {
    json missing = ToJson(c);
    missing.erase(key);
    EXPECT_EQ(ErrorOf(read, missing).field, std::string("command.") + key);
  }
}

TEST(CommandCodec, TheApiFormSaysWxyzAndTheRequestFieldNames) {
  const json j = ApiCommandJson(SomeCommand());
  EXPECT_EQ(j.at("id"), "pick-7");
  EXPECT_EQ(j.at("opening_m").get<double>(), 0.04);
  EXPECT_EQ(j.at("force_n").get<double>(), 12.0);
  // (x, y, z, w) on the bus is (w, x, y, z) in the API: the same rotation, 90 degrees about z.
  EXPECT_EQ(j.at("orientation_wxyz").get<core::QuaternionWxyz>(),
            (core::QuaternionWxyz{0.7071067811865476, 0.0, 0.0, 0.7071067811865476}));
  EXPECT_FALSE(j.contains("orientation_xyzw"));
  EXPECT_FALSE(j.contains("issued_unix_ns"));
}

TEST(ResultCodec, RoundTripsAndRefusesAnUnknownOutcome) {
  bridge::GraspResult r;
  r.command_id = "pick-7";
  r.robot_id = "arm-1";
  r.object_id = "3";
  r.outcome = bridge::GraspOutcome::kTimedOut;
  r.reason = "arm stalled";
  r.contact_width_m = 0.031;
  r.grasped_width_m = 0.027;
  r.deformation_rate = 0.129;
  r.execution_s = 4.25;
  r.finished_unix_ns = 1'764'000'001'000'000'000;
  auto back = ResultFromJson(json::parse(ToJson(r).dump()), "result");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back.value().outcome, bridge::GraspOutcome::kTimedOut);
  EXPECT_EQ(back.value().reason, r.reason);
  EXPECT_EQ(back.value().grasped_width_m, r.grasped_width_m);
  EXPECT_EQ(back.value().deformation_rate, r.deformation_rate);
  EXPECT_EQ(back.value().finished_unix_ns, r.finished_unix_ns);

  json unknown = ToJson(r);
  unknown["outcome"] = "exploded";
  const core::Error e = ErrorOf([](const json& j) { return ResultFromJson(j, "result"); }, unknown);
  EXPECT_EQ(e.field, "result.outcome");
  EXPECT_NE(e.message.find("exploded"), std::string::npos) << e.message;
}

}  // namespace
}  // namespace softgrasp::codec
