// The robot routes over real HTTP, with a real CommandTracker, ServiceBridge and RobotEndpoint in
// this process on loopback DDS (this binary's own domain): forward -> executing -> result,
// idempotency counted on the bus, auth, validation, 503s, timeout, restart over the journal.
// Responses are checked against openapi.yaml.
#include "service/rest/robot_api.h"

#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "tests/rest/openapi_schema.h"
#include "tests/rest/server_fixture.h"
#include "tests/robot/robot_test_util.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;
using robot::testing::MakeRobot;
using robot::testing::MakeServiceBridge;
using robot::testing::PoseCounter;
using robot::testing::SqueezeResult;
using robot::testing::TempDir;
using robot::testing::WaitUntil;
using testing::HttpReply;
using testing::RawRequest;
using testing::RunningServer;

const std::string kToken = "test-token-0123456789abcdef";

config::ServiceConfig RobotConfigFor(const std::string& journal_dir, double timeout_s = 20.0) {
  config::ServiceConfig config;
  config.robot.tokens = {"another-token-that-is-long", kToken};
  config.robot.journal_dir = journal_dir;
  config.robot.command_timeout_s = timeout_s;
  config.robot.domain_id = SOFTGRASP_BRIDGE_TEST_DOMAIN;
  return config;
}

std::shared_ptr<robot::CommandTracker> MakeTracker(const config::ServiceConfig& config) {
  robot::TrackerOptions options;
  options.journal_dir = config.robot.journal_dir;
  options.command_timeout_s = config.robot.command_timeout_s;
  options.republish_period_s = 0.2;
  options.log = [](const std::string&) {};
  auto tracker = robot::CommandTracker::Create(options, MakeServiceBridge());
  if (!tracker) ADD_FAILURE() << tracker.error().message;
  return tracker ? std::shared_ptr<robot::CommandTracker>(std::move(tracker).value()) : nullptr;
}

// A grasp as POST /v1/grasps returns it, plus the command id.
json GraspBody(const std::string& id) {
  const double half = 0.2;
  return {{"id", id},
          {"rank", 1},
          {"score", 0.87},
          {"center_px", {{"u", 320}, {"v", 240}}},
          {"angle_rad", 0.4},
          {"opening_m", 0.05},
          {"pose",
           {{"frame", "camera"},
            {"position_m", {0.01, -0.02, 0.65}},
            {"orientation_wxyz", {std::cos(half), 0.0, 0.0, std::sin(half)}}}}};
}

// A valid grasp at a position no other test grasp uses: a marker on the bus. Poses come from one
// writer, in order, so once the marker's pose is here, every pose written before it is too.
constexpr std::array<double, 3> kMarkerPositionM = {0.03, 0.02, 0.7};
json MarkerBody(const std::string& id) {
  json body = GraspBody(id);
  body["pose"]["position_m"] = kMarkerPositionM;
  return body;
}

// The ids of the next `n` commands the robot receives.
std::set<std::string> ReceivedIds(bridge::RobotEndpoint& robot, int n) {
  std::set<std::string> ids;
  for (int i = 0; i < n; ++i) {
    auto command = robot.WaitForCommand(5.0);
    if (!command || !command.value()) break;
    ids.insert(command.value()->command_id);
  }
  return ids;
}

std::string Auth(const std::string& token = kToken) {
  return "Authorization: Bearer " + token + "\r\n";
}

HttpReply Post(const RunningServer& server, const json& body, const std::string& auth = Auth()) {
  return server.Send(RawRequest("POST", "/v1/robot/grasps", "application/json", body.dump(), auth));
}

HttpReply Get(const RunningServer& server, const std::string& target,
              const std::string& auth = Auth()) {
  return server.Send(RawRequest("GET", target, "", "", auth));
}

std::string StateOf(const RunningServer& server, const std::string& id) {
  const HttpReply reply = Get(server, "/v1/robot/grasps/" + id);
  if (reply.status != 200) return "http " + std::to_string(reply.status);
  return json::parse(reply.body)["state"];
}

bool RobotAlive(const robot::CommandTracker& tracker, const std::string& id) {
  for (const auto& r : tracker.Robots()) {
    if (r.status.robot_id == id && r.alive) return true;
  }
  return false;
}

class RobotApiTest : public ::testing::Test {
 protected:
  json spec_ = testing::LoadSpec();
  testing::SchemaValidator validator_{spec_};

  std::vector<std::string> Problems(const HttpReply& reply, const std::string& schema) {
    return validator_.Validate(json::parse(reply.body), spec_["components"]["schemas"][schema]);
  }
  void ExpectError(const HttpReply& reply, int status, const std::string& field) {
    EXPECT_EQ(reply.status, status) << reply.body;
    const json body = json::parse(reply.body, nullptr, false);
    ASSERT_TRUE(body.is_object()) << reply.body;
    EXPECT_EQ(Problems(reply, "Error"), std::vector<std::string>{});
    EXPECT_EQ(body["error"].value("field", ""), field) << reply.body;
  }
};

TEST_F(RobotApiTest, ForwardOverHttpRobotExecutesAndResultIsShown) {
  TempDir dir("rest-robot-forward");
  const config::ServiceConfig config = RobotConfigFor(dir.str());
  auto tracker = MakeTracker(config);
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(tracker && robot);
  RunningServer server(config, tracker);
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);

  const HttpReply robots = Get(server, "/v1/robot", "");  // needs no token
  ASSERT_EQ(robots.status, 200) << robots.body;
  EXPECT_EQ(Problems(robots, "RobotList"), std::vector<std::string>{});
  const json list = json::parse(robots.body);
  ASSERT_EQ(list["robots"].size(), 1u);
  EXPECT_EQ(list["robots"][0]["robot_id"], "arm-1");
  EXPECT_EQ(list["robots"][0]["alive"], true);
  EXPECT_EQ(list["robots"][0]["simulated"], true);
  EXPECT_EQ(list["robots"][0]["state"], "idle");
  EXPECT_LT(list["robots"][0]["heartbeat_age_s"].get<double>(), 1.5);

  const HttpReply accepted = Post(server, GraspBody("g-1"));
  ASSERT_EQ(accepted.status, 202) << accepted.body;
  EXPECT_EQ(accepted.header("Location").value_or(""), "/v1/robot/grasps/g-1");
  EXPECT_EQ(Problems(accepted, "RobotCommand"), std::vector<std::string>{});
  const json a = json::parse(accepted.body);
  EXPECT_EQ(a["robot_id"], "arm-1");
  EXPECT_EQ(a["command"]["force_n"], 10.0);  // the configured default
  EXPECT_EQ(a["command"]["frame_id"], "camera");

  // What the robot receives is the grasp: pose (quaternion reordered to x, y, z, w), opening.
  auto received = robot->WaitForCommand(10.0);
  ASSERT_TRUE(received && received.value());
  const bridge::GraspCommand& c = *received.value();
  EXPECT_EQ(c.command_id, "g-1");
  EXPECT_EQ(c.position_m, (std::array<double, 3>{0.01, -0.02, 0.65}));
  EXPECT_DOUBLE_EQ(c.orientation_xyzw[2], std::sin(0.2));
  EXPECT_DOUBLE_EQ(c.orientation_xyzw[3], std::cos(0.2));
  EXPECT_DOUBLE_EQ(c.opening_width_m, 0.05);
  EXPECT_DOUBLE_EQ(c.score, 0.87);
  EXPECT_DOUBLE_EQ(c.approach_m, 0.1);

  ASSERT_TRUE(robot->Heartbeat(bridge::RobotState::kExecuting, "g-1"));
  EXPECT_GE(WaitUntil([&] { return StateOf(server, "g-1") == "executing"; }, 5.0), 0.0);
  ASSERT_TRUE(robot->PublishResult(SqueezeResult(c)));
  ASSERT_TRUE(robot->Heartbeat(bridge::RobotState::kIdle));
  ASSERT_GE(WaitUntil([&] { return StateOf(server, "g-1") == "succeeded"; }, 10.0), 0.0);

  const HttpReply done = Get(server, "/v1/robot/grasps/g-1");
  ASSERT_EQ(done.status, 200);
  EXPECT_EQ(Problems(done, "RobotCommand"), std::vector<std::string>{});
  const json r = json::parse(done.body)["result"];
  EXPECT_EQ(r["outcome"], "succeeded");
  EXPECT_DOUBLE_EQ(r["contact_width_m"].get<double>(), 0.0375);  // 0.75 x opening
  EXPECT_DOUBLE_EQ(r["grasped_width_m"].get<double>(), 0.03);
  EXPECT_NEAR(r["deformation_rate"].get<double>(), 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(r["execution_s"].get<double>(), 1.25);
  EXPECT_EQ(r["late"], false);
  EXPECT_GE(r["round_trip_s"].get<double>(), 0.0);

  ExpectError(Get(server, "/v1/robot/grasps/unknown-id"), 404, "id");
  ExpectError(Get(server, "/v1/robot/grasps/bad%20id"), 400, "id");

  // A robot's own refusal shows as "rejected" with its reason.
  ASSERT_EQ(Post(server, GraspBody("g-2")).status, 202);
  auto second = robot->WaitForCommand(10.0);
  ASSERT_TRUE(second && second.value());
  bridge::GraspResult refusal;
  refusal.command_id = "g-2";
  refusal.outcome = bridge::GraspOutcome::kRejected;
  refusal.reason = "outside the reach of arm-1";
  ASSERT_TRUE(robot->PublishResult(refusal));
  ASSERT_GE(WaitUntil([&] { return StateOf(server, "g-2") == "rejected"; }, 10.0), 0.0);
  EXPECT_EQ(json::parse(Get(server, "/v1/robot/grasps/g-2").body)["result"]["reason"],
            "outside the reach of arm-1");
}

TEST_F(RobotApiTest, SameIdTwiceMovesTheRobotOnceAndAnotherBodyIs409) {
  TempDir dir("rest-robot-idempotent");
  const config::ServiceConfig config = RobotConfigFor(dir.str());
  auto tracker = MakeTracker(config);
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(tracker && robot);
  RunningServer server(config, tracker);
  PoseCounter poses;
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1") && poses.matched() > 0; }, 10.0),
            0.0);

  json body = GraspBody("once");
  const HttpReply first = Post(server, body);
  ASSERT_EQ(first.status, 202) << first.body;
  body["rank"] = 7;  // not part of the command: still the same grasp
  const HttpReply again = Post(server, body);
  ASSERT_EQ(again.status, 200) << again.body;
  EXPECT_EQ(again.header("Location").value_or(""), "/v1/robot/grasps/once");
  EXPECT_EQ(json::parse(again.body)["accepted_unix_s"], json::parse(first.body)["accepted_unix_s"]);
  body["opening_m"] = 0.06;
  ExpectError(Post(server, body), 409, "id");

  ASSERT_EQ(Post(server, MarkerBody("marker")).status, 202);
  ASSERT_GE(WaitUntil([&] { return poses.Seen(kMarkerPositionM); }, 5.0), 0.0);
  EXPECT_EQ(poses.count(), 2);  // "once" went on the bus once, then the marker
  EXPECT_EQ(ReceivedIds(*robot, 2), (std::set<std::string>{"marker", "once"}));
}

TEST_F(RobotApiTest, TokensAreCheckedAndNeverLogged) {
  TempDir dir("rest-robot-auth");
  const config::ServiceConfig config = RobotConfigFor(dir.str());
  auto tracker = MakeTracker(config);
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(tracker && robot);
  std::mutex log_mutex;
  std::string log;
  RunningServer server(config, tracker, [&](const std::string& line) {
    std::lock_guard<std::mutex> lock(log_mutex);
    log += line + "\n";
  });
  PoseCounter poses;
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1") && poses.matched() > 0; }, 10.0),
            0.0);

  const HttpReply none = Post(server, GraspBody("a-1"), "");
  ExpectError(none, 401, "Authorization");
  EXPECT_EQ(none.header("WWW-Authenticate").value_or(""), "Bearer realm=\"softgrasp-robot\"");
  ExpectError(Post(server, GraspBody("a-1"), "Authorization: Basic dXNlcjpwYXNz\r\n"), 401,
              "Authorization");
  ExpectError(Post(server, GraspBody("a-1"), Auth("wrong-token-0123456789abcdef")), 403,
              "Authorization");
  ExpectError(Post(server, GraspBody("a-1"), Auth(kToken + "x")), 403, "Authorization");
  ExpectError(Post(server, GraspBody("a-1"), Auth(kToken.substr(1))), 403, "Authorization");
  ExpectError(Get(server, "/v1/robot/grasps/a-1", ""), 401, "Authorization");
  ExpectError(Get(server, "/v1/robot/grasps/a-1", Auth("nope")), 403, "Authorization");
  // Either configured token works; the scheme is case-insensitive.
  const std::string other_token = "Authorization: bearer another-token-that-is-long\r\n";
  EXPECT_EQ(Post(server, MarkerBody("a-2"), other_token).status, 202);

  ASSERT_GE(WaitUntil([&] { return poses.Seen(kMarkerPositionM); }, 5.0), 0.0);
  EXPECT_EQ(poses.count(), 1);  // only the authorised request reached the bus
  std::lock_guard<std::mutex> lock(log_mutex);
  EXPECT_NE(log.find("/v1/robot/grasps"), std::string::npos);
  EXPECT_EQ(log.find(kToken.substr(0, 10)), std::string::npos);
  EXPECT_EQ(log.find("another-token"), std::string::npos);
  EXPECT_EQ(log.find("Bearer"), std::string::npos);
}

TEST(TokenMatchesTest, ExactMatchOnly) {
  const std::vector<std::string> tokens = {"abcdefghijklmnop", "0123456789abcdef"};
  EXPECT_TRUE(TokenMatches("abcdefghijklmnop", tokens));
  EXPECT_TRUE(TokenMatches("0123456789abcdef", tokens));
  EXPECT_FALSE(TokenMatches("abcdefghijklmno", tokens));
  EXPECT_FALSE(TokenMatches("abcdefghijklmnopabcdefghijklmnop", tokens));  // repeats: cyclic read
  EXPECT_FALSE(TokenMatches("", tokens));
  EXPECT_FALSE(TokenMatches("abcdefghijklmnop", {}));
}

TEST_F(RobotApiTest, BadGraspsAre4xxNamingTheFieldAndNothingIsSent) {
  TempDir dir("rest-robot-validate");
  config::ServiceConfig config = RobotConfigFor(dir.str());
  auto tracker = MakeTracker(config);
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(tracker && robot);
  RunningServer server(config, tracker);
  PoseCounter poses;
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1") && poses.matched() > 0; }, 10.0),
            0.0);

  json outside = GraspBody("v-1");
  outside["pose"]["position_m"] = {0.01, -0.02, 2.5};  // the workspace ends at z = 1.5 m
  ExpectError(Post(server, outside), 422, "pose.position_m");
  // JSON has no NaN; a number too large for a double is the non-finite input it can carry.
  const std::string huge =
      R"({"id":"v-2","opening_m":0.05,"pose":{"position_m":[0.0,0.0,1e400],"orientation_wxyz":[1,0,0,0]}})";
  ExpectError(server.Send(RawRequest("POST", "/v1/robot/grasps", "application/json", huge, Auth())),
              422, "pose.position_m[2]");
  const std::string huge_force =
      R"({"id":"v-2","opening_m":0.05,"force_n":-1e999,"pose":{"position_m":[0,0,0.6],"orientation_wxyz":[1,0,0,0]}})";
  ExpectError(
      server.Send(RawRequest("POST", "/v1/robot/grasps", "application/json", huge_force, Auth())),
      422, "force_n");
  json not_unit = GraspBody("v-3");
  not_unit["pose"]["orientation_wxyz"] = {1.0, 0.5, 0.0, 0.0};
  ExpectError(Post(server, not_unit), 422, "pose.orientation_wxyz");
  json other_frame = GraspBody("v-4");
  other_frame["frame_id"] = "base";
  ExpectError(Post(server, other_frame), 422, "frame_id");
  json no_opening = GraspBody("v-5");
  no_opening["opening_m"] = 0.0;
  ExpectError(Post(server, no_opening), 422, "opening_m");
  json no_id = GraspBody("x");
  no_id.erase("id");
  ExpectError(Post(server, no_id), 400, "id");
  ExpectError(Post(server, GraspBody("has space")), 400, "id");
  ExpectError(Post(server, GraspBody(std::string(65, 'a'))), 400, "id");
  json wrong_type = GraspBody("v-6");
  wrong_type["pose"]["position_m"] = {0.0, "zero", 0.6};
  ExpectError(Post(server, wrong_type), 400, "pose.position_m[1]");
  ExpectError(server.Send(RawRequest("POST", "/v1/robot/grasps", "application/json",
                                     R"({"id": "v-7", "pose": )", Auth())),
              400, "pose");
  ExpectError(server.Send(RawRequest("POST", "/v1/robot/grasps", "text/plain", "{}", Auth())), 415,
              "Content-Type");
  ExpectError(
      server.Send(RawRequest("POST", "/v1/robot/grasps", "application/json", "[1]", Auth())), 400,
      "");

  // Then a valid grasp as a marker: it is the first and only command on the bus.
  ASSERT_EQ(Post(server, MarkerBody("v-ok")).status, 202);
  ASSERT_GE(WaitUntil([&] { return poses.Seen(kMarkerPositionM); }, 5.0), 0.0);
  EXPECT_EQ(poses.count(), 1);
  EXPECT_EQ(ReceivedIds(*robot, 1), (std::set<std::string>{"v-ok"}));
}

TEST_F(RobotApiTest, NoRobotIs503WithRetryAfterAndDisabledRoutesSayWhy) {
  TempDir dir("rest-robot-503");
  const config::ServiceConfig config = RobotConfigFor(dir.str());
  auto tracker = MakeTracker(config);
  ASSERT_TRUE(tracker);
  RunningServer server(config, tracker);
  const HttpReply no_robot = Post(server, GraspBody("n-1"));
  ExpectError(no_robot, 503, "");
  EXPECT_EQ(no_robot.header("Retry-After").value_or(""), "2");
  EXPECT_NE(no_robot.body.find("no robot is alive"), std::string::npos);
  ExpectError(Get(server, "/v1/robot/grasps/n-1"), 404, "id");  // not accepted
  EXPECT_EQ(Problems(Get(server, "/v1/robot"), "RobotList"), std::vector<std::string>{});

  config::ServiceConfig no_tokens;  // the default: robot endpoints on, but no tokens
  RunningServer disabled(no_tokens);
  for (const HttpReply& reply :
       {Post(disabled, GraspBody("n-2")), Get(disabled, "/v1/robot/grasps/n-2"),
        Get(disabled, "/v1/robot")}) {
    ExpectError(reply, 503, "");
    EXPECT_NE(reply.body.find("no tokens are configured"), std::string::npos) << reply.body;
    EXPECT_FALSE(reply.header("Retry-After").has_value());
  }
  const json info = json::parse(disabled.Send(RawRequest("GET", "/v1/info")).body);
  EXPECT_EQ(info["robot"]["enabled"], false);
  const json info_on = json::parse(server.Send(RawRequest("GET", "/v1/info")).body);
  EXPECT_EQ(info_on["robot"]["enabled"], true);
}

TEST_F(RobotApiTest, NoResultInTimeIsTimedOut) {
  TempDir dir("rest-robot-timeout");
  const config::ServiceConfig config = RobotConfigFor(dir.str(), /*timeout_s=*/0.8);
  auto tracker = MakeTracker(config);
  auto robot = MakeRobot("arm-1");  // takes nothing, answers nothing
  ASSERT_TRUE(tracker && robot);
  RunningServer server(config, tracker);
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);
  ASSERT_EQ(Post(server, GraspBody("t-1")).status, 202);
  ASSERT_GE(WaitUntil([&] { return StateOf(server, "t-1") == "timed_out"; }, 5.0), 0.0);
  const HttpReply reply = Get(server, "/v1/robot/grasps/t-1");
  EXPECT_EQ(Problems(reply, "RobotCommand"), std::vector<std::string>{});
  const json body = json::parse(reply.body);
  EXPECT_FALSE(body.contains("result"));
  EXPECT_NE(body["detail"].get<std::string>().find("no result within 0.8 s"), std::string::npos);
}

TEST_F(RobotApiTest, RestartOverTheJournalKeepsOldIdsAndCompletesPendingOnes) {
  TempDir dir("rest-robot-restart");
  const config::ServiceConfig config = RobotConfigFor(dir.str());
  {
    auto tracker = MakeTracker(config);
    auto robot = MakeRobot("arm-1");
    ASSERT_TRUE(tracker && robot);
    RunningServer server(config, tracker);
    ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);
    ASSERT_EQ(Post(server, GraspBody("r-done")).status, 202);
    auto c = robot->WaitForCommand(10.0);
    ASSERT_TRUE(c && c.value());
    ASSERT_TRUE(robot->PublishResult(SqueezeResult(*c.value())));
    ASSERT_GE(WaitUntil([&] { return StateOf(server, "r-done") == "succeeded"; }, 10.0), 0.0);
    ASSERT_EQ(Post(server, GraspBody("r-pending")).status, 202);
    robot.reset();  // the robot leaves before taking it
  }                 // server, tracker and bridge gone: a restart

  auto tracker = MakeTracker(config);
  ASSERT_TRUE(tracker);
  RunningServer server(config, tracker);
  const HttpReply old = Get(server, "/v1/robot/grasps/r-done");
  ASSERT_EQ(old.status, 200) << old.body;
  EXPECT_DOUBLE_EQ(json::parse(old.body)["result"]["grasped_width_m"].get<double>(), 0.03);
  EXPECT_EQ(Post(server, GraspBody("r-done")).status, 200);  // still idempotent

  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(robot);
  auto c = robot->WaitForCommand(10.0);
  ASSERT_TRUE(c && c.value()) << "the pending command was not re-sent after the restart";
  EXPECT_EQ(c.value()->command_id, "r-pending");
  ASSERT_TRUE(robot->PublishResult(SqueezeResult(*c.value())));
  EXPECT_GE(WaitUntil([&] { return StateOf(server, "r-pending") == "succeeded"; }, 10.0), 0.0);
}

}  // namespace
}  // namespace softgrasp::rest
