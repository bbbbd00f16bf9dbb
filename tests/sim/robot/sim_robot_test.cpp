// The simulated robot on hand-made scenes: commands in the camera and world frames, the outcome
// mapping (succeeded, failed with the model's reason, crushed, rejected), the re-rendered view,
// its HTTP routes, and a loopback DDS round trip against a ServiceBridge.
#include "sim/robot/sim_robot.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "service/bridge/bridge.h"
#include "service/http/server.h"
#include "service/io/depth_codec.h"
#include "sim/robot/robot_http.h"
#include "sim/robot/robot_loop.h"
#include "tests/sim/test_scenes.h"
#include "tests/support/box_mesh.h"
#include "tests/support/http_client.h"
#include "tests/support/wait_until.h"

namespace softgrasp::sim {
namespace {

using bridge::GraspCommand;
using bridge::GraspOutcome;
using bridge::GraspResult;

// A 30 mm (x) by 40 mm (y) by 50 mm (z) block standing on a table at (x, y) in W.
const Eigen::Vector3d kBlockSize(0.03, 0.04, 0.05);
const Eigen::Vector2d kBlockXy(0.05, -0.03);
constexpr double kCameraHeightM = 0.55;

std::shared_ptr<SimObject> Block(float stiffness, double mass_kg = 0.1) {
  auto object = std::make_shared<SimObject>();
  object->category = "block";
  object->mesh_o = testing::CentredBoxMesh(kBlockSize / 2.0);
  object->vertex_stiffness.assign(object->mesh_o.vertices.size(), stiffness);
  object->mass_kg = mass_kg;
  return object;
}

SimScene BlockOnTable(float stiffness) {
  SimScene scene;
  scene.seed = 7;
  scene.support.kind = Support::Kind::kTable;
  PlacedObject placed;
  placed.instance_id = 1;
  placed.object = Block(stiffness);
  placed.world_from_object.translation() =
      Eigen::Vector3d(kBlockXy.x(), kBlockXy.y(), kBlockSize.z() / 2.0);
  scene.objects.push_back(placed);
  return scene;
}

RenderOptions Overhead() {
  RenderOptions render;
  render.world_from_camera = OverheadCameraPose(kCameraHeightM);
  render.noise.enabled = false;
  return render;
}

std::unique_ptr<SimRobot> MakeRobot(float stiffness = 1.0f) {
  auto robot = SimRobot::FromScene(BlockOnTable(stiffness), Overhead());
  EXPECT_TRUE(robot.ok()) << (robot.ok() ? "" : robot.error().message);
  return robot.ok() ? std::move(robot).value() : nullptr;
}

// A vertical grasp in W, written as a command in the camera frame like the planner's: G's z axis
// (approach) is -z of W, G's x axis (closing) is at `angle_rad` from +x of W.
GraspCommand CameraCommand(const std::string& id, const Eigen::Vector3d& p_WG,
                           double angle_rad = 0.0, double opening_m = 0.05, double force_n = 10.0) {
  const Eigen::Isometry3d world_from_camera = OverheadCameraPose(kCameraHeightM);
  Eigen::Matrix3d R_WG;
  const Eigen::Vector3d x_w(std::cos(angle_rad), std::sin(angle_rad), 0.0);
  const Eigen::Vector3d z_w(0.0, 0.0, -1.0);
  R_WG.col(0) = x_w;
  R_WG.col(1) = z_w.cross(x_w);
  R_WG.col(2) = z_w;
  const Eigen::Vector3d p_CG = world_from_camera.inverse() * p_WG;
  const Eigen::Quaterniond q_CG(world_from_camera.linear().transpose() * R_WG);
  GraspCommand c;
  c.command_id = id;
  c.frame_id = "camera";
  c.position_m = {p_CG.x(), p_CG.y(), p_CG.z()};
  c.orientation_xyzw = {q_CG.x(), q_CG.y(), q_CG.z(), q_CG.w()};
  c.opening_width_m = opening_m;
  c.closing_force_n = force_n;
  c.approach_m = 0.1;
  c.retreat_m = 0.1;
  c.score = 0.5;
  return c;
}

// Fingertips 10 mm above the table, around the block.
const Eigen::Vector3d kOnBlockW(kBlockXy.x(), kBlockXy.y(), 0.01);

// The pixel that sees the top centre of the block.
cv::Point BlockPixel(const SimRobotView& view) {
  const Eigen::Vector3d p_C = view.world_from_camera.inverse() *
                              Eigen::Vector3d(kBlockXy.x(), kBlockXy.y(), kBlockSize.z());
  return {static_cast<int>(std::lround(view.camera.fx * p_C.x() / p_C.z() + view.camera.cx)),
          static_cast<int>(std::lround(view.camera.fy * p_C.y() / p_C.z() + view.camera.cy))};
}

/// Indentation of one finger pushed with `force_n` on a surface of this stiffness, metres.
double DentM(float stiffness, double force_n) {
  return force_n / (1000.0 * ContactSpringRateNPerMm(stiffness));
}

TEST(SimRobot, GraspInCameraFrameSucceedsRemovesTheBlockAndRerenders) {
  auto robot = MakeRobot(0.7f);
  ASSERT_TRUE(robot);
  const auto before = robot->view();
  const cv::Point px = BlockPixel(*before);
  EXPECT_NEAR(before->views.depth.depth_m(px), kCameraHeightM - kBlockSize.z(), 1e-4);
  EXPECT_EQ(before->views.labels(px), 1);
  EXPECT_EQ(before->manifest["objects_left"], 1);

  // Closing along x (the 30 mm side) with a 50 mm opening.
  const GraspResult r = robot->Execute(CameraCommand("pick-1", kOnBlockW));
  ASSERT_EQ(r.outcome, GraspOutcome::kSucceeded) << r.reason;
  EXPECT_EQ(r.command_id, "pick-1");
  EXPECT_EQ(r.object_id, "1");
  EXPECT_NEAR(r.contact_width_m, kBlockSize.x(), 1e-4);
  const double expected_lg = kBlockSize.x() - 2.0 * DentM(0.7f, 10.0);
  EXPECT_NEAR(r.grasped_width_m, expected_lg, 1e-5);
  EXPECT_NEAR(r.deformation_rate, (r.contact_width_m - r.grasped_width_m) / r.contact_width_m,
              1e-9);
  EXPECT_GT(r.execution_s, 0.0);
  EXPECT_GT(r.finished_unix_ns, 0);
  GraspResult on_the_bus = r;
  on_the_bus.robot_id = "sim";  // the loop fills in its robot id
  auto valid = bridge::Validate(on_the_bus);
  EXPECT_TRUE(valid.ok()) << valid.error().message;

  // The camera now sees the table where the block stood, and the manifest lists no object.
  const auto after = robot->view();
  EXPECT_EQ(after->generation, before->generation + 1);
  EXPECT_NEAR(after->views.depth.depth_m(px), kCameraHeightM, 1e-4);
  EXPECT_EQ(after->views.labels(px), 0);
  EXPECT_EQ(after->manifest["objects_left"], 0);
  EXPECT_EQ(after->manifest["objects"].size(), 0u);
  EXPECT_EQ(after->manifest["picked"], nlohmann::json::array({1}));
  // The old view is untouched (readers may still hold it).
  EXPECT_EQ(before->views.labels(px), 1);

  // The same grasp again closes on nothing.
  const GraspResult again = robot->Execute(CameraCommand("pick-2", kOnBlockW));
  EXPECT_EQ(again.outcome, GraspOutcome::kFailed);
  EXPECT_EQ(again.reason.rfind("empty: ", 0), 0u) << again.reason;
}

TEST(SimRobot, WorldFrameCommandIsTheSameGrasp) {
  auto robot = MakeRobot();
  ASSERT_TRUE(robot);
  GraspCommand c = CameraCommand("w-1", kOnBlockW, 0.0);
  c.frame_id = "world";
  c.position_m = {kOnBlockW.x(), kOnBlockW.y(), kOnBlockW.z()};
  // G in W: x along +x, z down: a half turn about x.
  c.orientation_xyzw = {1.0, 0.0, 0.0, 0.0};
  const GraspResult r = robot->Execute(c);
  ASSERT_EQ(r.outcome, GraspOutcome::kSucceeded) << r.reason;
  EXPECT_NEAR(r.contact_width_m, kBlockSize.x(), 1e-4);
}

TEST(SimRobot, FailuresCarryTheExecutionModelsReasonAndLeaveTheScene) {
  auto robot = MakeRobot();
  ASSERT_TRUE(robot);
  const std::uint64_t generation = robot->view()->generation;

  // Onto bare table, away from the block.
  const GraspResult empty =
      robot->Execute(CameraCommand("nothing", Eigen::Vector3d(-0.15, 0.08, 0.01)));
  EXPECT_EQ(empty.outcome, GraspOutcome::kFailed);
  EXPECT_EQ(empty.reason.rfind("empty: ", 0), 0u) << empty.reason;
  EXPECT_EQ(empty.object_id, "");
  EXPECT_EQ(empty.contact_width_m, 0.0);

  // Closing along y (the 40 mm side) with a 35 mm opening: a finger lands on the block.
  const GraspResult wide = robot->Execute(CameraCommand("wide", kOnBlockW, M_PI / 2.0, 0.035));
  EXPECT_EQ(wide.outcome, GraspOutcome::kFailed);
  EXPECT_EQ(wide.reason.rfind("too_wide: ", 0), 0u) << wide.reason;
  EXPECT_EQ(wide.object_id, "1");

  EXPECT_EQ(robot->view()->generation, generation);
  EXPECT_EQ(robot->view()->manifest["objects_left"], 1);
}

TEST(SimRobot, ASoftBlockIsCrushedFailedAndGone) {
  auto robot = MakeRobot(0.1f);  // sponge-like: 0.2 N/mm per finger
  ASSERT_TRUE(robot);
  const GraspResult r = robot->Execute(CameraCommand("squeeze", kOnBlockW, 0.0, 0.05, 10.0));
  EXPECT_EQ(r.outcome, GraspOutcome::kFailed);
  EXPECT_EQ(r.reason.rfind("crushed: ", 0), 0u) << r.reason;
  EXPECT_GT(r.deformation_rate, 0.2);
  EXPECT_NEAR(r.contact_width_m, kBlockSize.x(), 1e-4);
  // Lifted, so it left the bin all the same.
  EXPECT_EQ(robot->view()->manifest["objects_left"], 0);
}

TEST(SimRobot, RejectsWhatItCannotRunAndMovesNothing) {
  auto robot = MakeRobot();
  ASSERT_TRUE(robot);
  const std::uint64_t generation = robot->view()->generation;

  GraspCommand frame = CameraCommand("frame", kOnBlockW);
  frame.frame_id = "base_link";
  GraspResult r = robot->Execute(frame);
  EXPECT_EQ(r.outcome, GraspOutcome::kRejected);
  EXPECT_NE(r.reason.find("unknown frame 'base_link'"), std::string::npos) << r.reason;

  // 0.4 m off to the side: outside the workspace (inner area + 5 cm).
  r = robot->Execute(CameraCommand("far", Eigen::Vector3d(0.4, 0.0, 0.01)));
  EXPECT_EQ(r.outcome, GraspOutcome::kRejected);
  EXPECT_NE(r.reason.find("outside the workspace"), std::string::npos) << r.reason;

  // Approach tilted 30 degrees from vertical.
  GraspCommand tilted = CameraCommand("tilted", kOnBlockW);
  const Eigen::Quaterniond q(tilted.orientation_xyzw[3], tilted.orientation_xyzw[0],
                             tilted.orientation_xyzw[1], tilted.orientation_xyzw[2]);
  const Eigen::Quaterniond q_tilted = q * Eigen::AngleAxisd(M_PI / 6.0, Eigen::Vector3d::UnitX());
  tilted.orientation_xyzw = {q_tilted.x(), q_tilted.y(), q_tilted.z(), q_tilted.w()};
  r = robot->Execute(tilted);
  EXPECT_EQ(r.outcome, GraspOutcome::kRejected);
  EXPECT_NE(r.reason.find("approach axis is 30"), std::string::npos) << r.reason;

  // Wider than the 50 mm stroke, and no force: the execution model refuses the numbers.
  r = robot->Execute(CameraCommand("open", kOnBlockW, 0.0, 0.08));
  EXPECT_EQ(r.outcome, GraspOutcome::kRejected);
  EXPECT_NE(r.reason.find("cannot run this command"), std::string::npos) << r.reason;
  r = robot->Execute(CameraCommand("limp", kOnBlockW, 0.0, 0.05, 0.0));
  EXPECT_EQ(r.outcome, GraspOutcome::kRejected);

  EXPECT_EQ(r.contact_width_m, 0.0);
  EXPECT_EQ(robot->view()->generation, generation);
  EXPECT_EQ(robot->view()->manifest["objects_left"], 1);
}

TEST(SimRobot, WorkspaceIsTheGrownInnerAreaInTheCameraFrame) {
  auto robot = MakeRobot();
  ASSERT_TRUE(robot);
  const bridge::Workspace& w = robot->workspace();
  EXPECT_EQ(w.frame_id, "camera");
  // Overhead camera: x_C = x_W, y_C = -y_W, z_C = 0.55 - z_W. Inner area 0.40 x 0.30 + 0.05.
  EXPECT_NEAR(w.min_m[0], -0.25, 1e-9);
  EXPECT_NEAR(w.max_m[0], 0.25, 1e-9);
  EXPECT_NEAR(w.min_m[1], -0.20, 1e-9);
  EXPECT_NEAR(w.max_m[1], 0.20, 1e-9);
  EXPECT_NEAR(w.min_m[2], kCameraHeightM - 0.30, 1e-9);
  EXPECT_NEAR(w.max_m[2], kCameraHeightM + 0.05, 1e-9);
  EXPECT_TRUE(bridge::Validate(w).ok());
}

TEST(SimRobot, ResetRestoresAHandMadeSceneAndRegeneratesAGeneratedOne) {
  auto robot = MakeRobot();
  ASSERT_TRUE(robot);
  ASSERT_EQ(robot->Execute(CameraCommand("p", kOnBlockW)).outcome, GraspOutcome::kSucceeded);
  ASSERT_TRUE(robot->Reset().ok());
  EXPECT_EQ(robot->view()->manifest["objects_left"], 1);
  EXPECT_EQ(robot->view()->manifest["picked"].size(), 0u);

  SceneSpec spec;
  spec.min_objects = 1;
  spec.max_objects = 2;
  spec.categories = {"block", "box"};
  spec.render.noise.enabled = true;
  auto generated = SimRobot::Generate(spec, 11);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  auto direct = GenerateScene(spec, 11);
  ASSERT_TRUE(direct.ok());
  const auto view = generated.value()->view();
  EXPECT_EQ(view->scene_seed, 11u);
  // Same scene, same noise stream: the robot shows exactly what GenerateScene renders.
  EXPECT_EQ(cv::norm(view->views.labels, direct.value().views.labels, cv::NORM_INF), 0.0);
  const cv::Mat1f& a = view->views.depth.depth_m;
  const cv::Mat1f& b = direct.value().views.depth.depth_m;
  int differing = 0;
  for (int v = 0; v < a.rows; ++v) {
    for (int u = 0; u < a.cols; ++u) {
      const bool same = (std::isnan(a(v, u)) && std::isnan(b(v, u))) || a(v, u) == b(v, u);
      differing += same ? 0 : 1;
    }
  }
  EXPECT_EQ(differing, 0);
  ASSERT_TRUE(generated.value()->Reset(12).ok());
  EXPECT_EQ(generated.value()->view()->scene_seed, 12u);
  ASSERT_TRUE(generated.value()->Reset().ok());
  EXPECT_EQ(generated.value()->view()->scene_seed, 13u);
}

// ---- HTTP ----

using softgrasp::testing::HttpReply;

// One request on its own connection.
HttpReply Fetch(uint16_t port, const std::string& method, const std::string& target,
                const std::string& body = "") {
  const std::string raw = method + " " + target +
                          " HTTP/1.1\r\nHost: t\r\nConnection: close\r\nContent-Length: " +
                          std::to_string(body.size()) + "\r\n\r\n" + body;
  return softgrasp::testing::HttpExchange(port, raw);
}

class ServedRobot {
 public:
  explicit ServedRobot(SimRobot& robot) {
    AddSimRobotRoutes(router_, robot);
    http::ServerOptions options;
    options.port = 0;
    options.access_log = [](const std::string&) {};
    server_ = std::make_unique<http::Server>(
        options, [this](http::Request& r) { return router_.Dispatch(r); });
    server_->Start();
  }
  uint16_t port() const { return server_->port(); }

 private:
  http::Router router_;
  std::unique_ptr<http::Server> server_;
};

TEST(SimRobotHttp, ServesTheViewTheServiceCanDecode) {
  auto robot = MakeRobot();
  ASSERT_TRUE(robot);
  ServedRobot served(*robot);
  const auto view = robot->view();
  const cv::Point px = BlockPixel(*view);

  const HttpReply npy = Fetch(served.port(), "GET", "/depth.npy");
  ASSERT_EQ(npy.status, 200);
  EXPECT_EQ(npy.header("X-Scene-Generation").value_or(""), "1");
  auto depth = io::DecodeDepth(npy.body);
  ASSERT_TRUE(depth.ok()) << depth.error().message;
  EXPECT_NEAR(depth.value().depth_m(px), kCameraHeightM - kBlockSize.z(), 1e-6);

  const HttpReply png = Fetch(served.port(), "GET", "/depth.png");
  ASSERT_EQ(png.status, 200);
  auto depth_mm = io::DecodeDepth(png.body);
  ASSERT_TRUE(depth_mm.ok()) << depth_mm.error().message;
  EXPECT_NEAR(depth_mm.value().depth_m(px), 0.5, 0.0005);

  const HttpReply intr = Fetch(served.port(), "GET", "/camera.intr");
  ASSERT_EQ(intr.status, 200);
  auto camera = io::ParseIntrinsicsJson(intr.body);
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  EXPECT_EQ(camera.value().fx, view->camera.fx);
  EXPECT_EQ(camera.value().cy, view->camera.cy);
  EXPECT_EQ(camera.value().width, view->camera.width);

  const HttpReply labels = Fetch(served.port(), "GET", "/labels.png");
  ASSERT_EQ(labels.status, 200);
  EXPECT_EQ(labels.body.substr(1, 3), "PNG");
  const HttpReply stiffness = Fetch(served.port(), "GET", "/stiffness.png");
  ASSERT_EQ(stiffness.status, 200);

  // A pick shows up in the next fetch.
  ASSERT_EQ(robot->Execute(CameraCommand("p", kOnBlockW)).outcome, GraspOutcome::kSucceeded);
  const HttpReply scene = Fetch(served.port(), "GET", "/scene.json");
  ASSERT_EQ(scene.status, 200);
  const auto manifest = nlohmann::json::parse(scene.body);
  EXPECT_EQ(manifest["objects_left"], 0);
  EXPECT_EQ(manifest["generation"], 2);
  auto after = io::DecodeDepth(Fetch(served.port(), "GET", "/depth.npy").body);
  ASSERT_TRUE(after.ok());
  EXPECT_NEAR(after.value().depth_m(px), kCameraHeightM, 1e-6);

  // Reset: bad bodies are 400 and change nothing; an empty body restores the block.
  EXPECT_EQ(Fetch(served.port(), "POST", "/reset", "{\"seed\": -1}").status, 400);
  EXPECT_EQ(Fetch(served.port(), "POST", "/reset", "not json").status, 400);
  EXPECT_EQ(Fetch(served.port(), "POST", "/reset", "{\"colour\": 1}").status, 400);
  EXPECT_EQ(robot->view()->manifest["objects_left"], 0);
  const HttpReply reset = Fetch(served.port(), "POST", "/reset");
  ASSERT_EQ(reset.status, 200);
  EXPECT_EQ(nlohmann::json::parse(reset.body)["objects_left"], 1);
  EXPECT_EQ(Fetch(served.port(), "GET", "/nope").status, 404);
  EXPECT_EQ(Fetch(served.port(), "DELETE", "/depth.npy").status, 405);
}

// ---- DDS ----

using softgrasp::testing::WaitUntil;

bridge::BridgeOptions LoopbackOptions() {
  bridge::BridgeOptions options;
  options.domain_id = 121;
  options.config = bridge::LoopbackConfigXml("sim-robot-test-" + std::to_string(::getpid()));
  options.heartbeat_period_s = 0.2;
  return options;
}

TEST(SimRobotLoop, ExecutesCommandsFromTheBusAndAnswersWithResults) {
  auto robot = MakeRobot(0.7f);
  ASSERT_TRUE(robot);
  auto service = bridge::ServiceBridge::Create(LoopbackOptions());
  ASSERT_TRUE(service.ok()) << service.error().message;
  std::vector<std::string> log;
  std::mutex log_mutex;
  auto loop =
      SimRobotLoop::Start(*robot, LoopbackOptions(), "sim-test", [&](const std::string& line) {
        std::lock_guard lock(log_mutex);
        log.push_back(line);
      });
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  bridge::ServiceBridge& bus = *service.value();

  ASSERT_TRUE(WaitUntil([&] { return bus.AliveRobots().size() == 1; }, 10.0));
  const bridge::RobotInfo seen = bus.AliveRobots()[0];
  EXPECT_EQ(seen.status.robot_id, "sim-test");
  EXPECT_TRUE(seen.status.simulated);
  EXPECT_EQ(seen.status.state, bridge::RobotState::kIdle);
  EXPECT_EQ(seen.status.workspace.frame_id, "camera");
  EXPECT_EQ(seen.status.workspace.max_m, robot->workspace().max_m);
  ASSERT_TRUE(WaitUntil([&] { return bus.MatchedCommandReaders().value() >= 1; }, 10.0));

  GraspCommand pick = CameraCommand("bus-pick", kOnBlockW);
  pick.robot_id = "sim-test";
  ASSERT_TRUE(bus.Publish(pick).ok());
  const auto result = bus.WaitForResult("bus-pick", 10.0);
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->outcome, GraspOutcome::kSucceeded) << result->reason;
  EXPECT_EQ(result->robot_id, "sim-test");
  EXPECT_EQ(result->object_id, "1");
  EXPECT_NEAR(result->contact_width_m, kBlockSize.x(), 1e-4);
  EXPECT_LT(result->grasped_width_m, result->contact_width_m);
  EXPECT_EQ(robot->view()->manifest["objects_left"], 0);

  // A command in an unknown frame comes back REJECTED; the robot keeps serving.
  GraspCommand bad = CameraCommand("bus-bad", kOnBlockW);
  bad.frame_id = "tool0";
  ASSERT_TRUE(bus.Publish(bad).ok());
  const auto rejected = bus.WaitForResult("bus-bad", 10.0);
  ASSERT_TRUE(rejected.has_value());
  EXPECT_EQ(rejected->outcome, GraspOutcome::kRejected);

  // Sent twice, run once: the second publish of the same id is answered with the result the
  // robot keeps (the same sample, finished at the same time), not a second run.
  ASSERT_TRUE(bus.Publish(CameraCommand("bus-empty", kOnBlockW)).ok());
  const auto empty = bus.WaitForResult("bus-empty", 10.0);
  ASSERT_TRUE(empty.has_value());
  EXPECT_EQ(empty->outcome, GraspOutcome::kFailed);
  ASSERT_TRUE(bus.Publish(CameraCommand("bus-empty", kOnBlockW)).ok());
  const auto again = bus.WaitForResult("bus-empty", 10.0);
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->finished_unix_ns, empty->finished_unix_ns);
  EXPECT_EQ(again->reason, empty->reason);
  EXPECT_EQ(loop.value()->commands_done(), 3);

  ASSERT_TRUE(WaitUntil(
      [&] {
        const auto alive = bus.AliveRobots();
        return alive.size() == 1 && alive[0].status.state == bridge::RobotState::kIdle;
      },
      5.0));
  {
    std::lock_guard lock(log_mutex);
    ASSERT_EQ(log.size(), 3u);
    EXPECT_NE(log[0].find("command bus-pick: succeeded, object 1"), std::string::npos) << log[0];
  }

  // Leaving the bus marks the robot gone at once.
  loop.value()->Stop();
  EXPECT_TRUE(WaitUntil([&] { return bus.AliveRobots().empty(); }, 5.0));
}

}  // namespace
}  // namespace softgrasp::sim
