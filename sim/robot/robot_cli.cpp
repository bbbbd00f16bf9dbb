#include "sim/robot/robot_cli.h"

#include <signal.h>

#include <exception>
#include <iostream>
#include <nlohmann/json.hpp>

#include "service/cli/args.h"
#include "service/cli/files.h"
#include "sim/dataset/scene_gen.h"
#include "sim/robot/robot_http.h"
#include "sim/robot/robot_loop.h"
#include "sim/robot/sim_robot.h"

namespace softgrasp::sim {
namespace {

constexpr const char* kUsage =
    "usage: softgrasp-sim robot [--scene-seed S | --scene MANIFEST] [--objects MIN-MAX]\n"
    "                           [--support bin|table]\n"
    "                           [--noise on|off] [--robot-id ID] [--domain N]\n"
    "                           [--dds-config XML|file://PATH] [--http-host H] [--http-port P]\n"
    "  A SIMULATED robot (docs/sim-robot.md): joins the DDS bus as ID (default sim-robot) on\n"
    "  domain N (default 0), executes each grasp command with the simulator's grasp execution\n"
    "  model in a generated scene (seed S, default 1; objects 3-8, bin, noise on), publishes the\n"
    "  results and removes what it picks. Serves the camera's view on http://H:P (default\n"
    "  127.0.0.1:8081; port 0 picks one): GET /depth.npy /depth.png /camera.intr /scene.json\n"
    "  /stiffness.png /labels.png, POST /reset. --scene rebuilds the scene of a manifest\n"
    "  (scene_NNNNNN.json) written by `softgrasp-sim generate`; the other options still apply.\n"
    "  --dds-config takes what CYCLONEDDS_URI takes\n"
    "  (default: CYCLONEDDS_URI, else Cyclone's defaults). SIGINT/SIGTERM stop it.\n";

// --scene FILE: the scene of a `softgrasp-sim generate` manifest, rebuilt from its spec and seed.
std::string LoadSceneManifest(const std::string& path, RobotCommandLine* out) {
  auto text = cli::ReadFile(path);
  if (!text.ok()) return "--scene: " + text.error().message;
  const nlohmann::json manifest =
      nlohmann::json::parse(text.value(), nullptr, /*allow_exceptions=*/false);
  if (!manifest.is_object() || !manifest.contains("spec") || !manifest.contains("scene_seed") ||
      !manifest["scene_seed"].is_number_unsigned()) {
    return "--scene: " + path + " is not a scene manifest of softgrasp-sim generate";
  }
  auto spec = SceneSpecFromJson(manifest["spec"]);
  if (!spec.ok()) return "--scene: " + path + ": " + spec.error().message;
  out->spec = std::move(spec).value();
  out->scene_seed = manifest["scene_seed"].get<std::uint64_t>();
  return "";
}

}  // namespace

const char* RobotUsage() { return kUsage; }

std::string ParseRobotArgs(const std::vector<std::string>& argv, RobotCommandLine* out) {
  cli::Args args(argv);
  out->spec.render.noise.enabled = true;
  out->http.host = "127.0.0.1";
  out->http.port = 8081;
  // The manifest first: the options below change the scene it describes.
  std::string manifest;
  if (args.Text("--scene", &manifest)) {
    if (const std::string problem = LoadSceneManifest(manifest, out); !problem.empty()) {
      return problem;
    }
  }
  args.Int("--scene-seed", 0, cli::kNoLimit, &out->scene_seed);
  args.Span("--objects", 1, kMaxObjectsPerScene, &out->spec.min_objects, &out->spec.max_objects);
  args.Choice<Support::Kind>("--support",
                             {{"bin", Support::Kind::kBin}, {"table", Support::Kind::kTable}},
                             &out->spec.support.kind);
  args.Choice<bool>("--noise", {{"on", true}, {"off", false}}, &out->spec.render.noise.enabled);
  if (args.Text("--robot-id", &out->robot_id) &&
      (out->robot_id.empty() || out->robot_id.size() > bridge::kMaxIdBytes)) {
    args.Fail("--robot-id must be 1-" + std::to_string(bridge::kMaxIdBytes) + " bytes",
              "--robot-id");
  }
  args.Int("--domain", 0, 232, &out->bridge.domain_id);
  args.Text("--dds-config", &out->bridge.config);
  if (args.Text("--http-host", &out->http.host) && out->http.host.empty()) {
    args.Fail("--http-host must not be empty", "--http-host");
  }
  args.Int("--http-port", 0, 65535, &out->http.port);
  const auto error = args.Finish();
  return error ? error->message : "";
}

int RunRobotCommand(const std::vector<std::string>& args) {
  RobotCommandLine cli;
  if (const std::string problem = ParseRobotArgs(args, &cli); !problem.empty()) {
    std::cerr << "softgrasp-sim robot: " << problem << "\n" << kUsage;
    return 2;
  }
  // Block the stop signals before any thread starts (DDS, HTTP), so all of them inherit the
  // mask and only sigwait below sees SIGINT/SIGTERM.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  const std::string label = "[SIMULATED robot " + cli.robot_id + "] ";
  auto robot = SimRobot::Generate(cli.spec, cli.scene_seed);
  if (!robot.ok()) {
    std::cerr << label << "cannot build the scene: " << robot.error().message << "\n";
    return 1;
  }
  SimRobot& sim = *robot.value();
  auto loop = SimRobotLoop::Start(sim, cli.bridge, cli.robot_id, [&label](const std::string& s) {
    std::cerr << label << s << std::endl;
  });
  if (!loop.ok()) {
    std::cerr << label << "cannot join the DDS bus: " << loop.error().message
              << (loop.error().field.empty() ? "" : " (" + loop.error().field + ")") << "\n";
    return 1;
  }

  http::Router router;
  AddSimRobotRoutes(router, sim);
  cli.http.access_log = [&label](const std::string& line) {
    std::cerr << label << line << std::endl;
  };
  int exit_code = 0;
  try {
    http::Server server(cli.http, [&router](http::Request& r) { return router.Dispatch(r); });
    server.Start();
    const auto view = sim.view();
    const bridge::Workspace& w = sim.workspace();
    std::cout << label << "SIMULATED robot '" << cli.robot_id << "' on DDS domain "
              << cli.bridge.domain_id << ": scene seed " << view->scene_seed << ", "
              << view->manifest["objects_left"].get<int>() << " objects; workspace in frame "
              << w.frame_id << " [" << w.min_m[0] << ", " << w.max_m[0] << "] x [" << w.min_m[1]
              << ", " << w.max_m[1] << "] x [" << w.min_m[2] << ", " << w.max_m[2] << "] m"
              << std::endl;
    const bool ipv6 = cli.http.host.find(':') != std::string::npos;
    std::cout << "listening on http://" << (ipv6 ? "[" : "") << cli.http.host << (ipv6 ? "]" : "")
              << ":" << server.port() << std::endl;
    int signal_number = 0;
    sigwait(&signals, &signal_number);
    std::cerr << label << "stopping (signal " << signal_number << ")" << std::endl;
    server.Stop();
  } catch (const std::exception& e) {
    std::cerr << label << "cannot serve HTTP on " << cli.http.host << ":" << cli.http.port << ": "
              << e.what() << "\n";
    exit_code = 1;
  }
  loop.value()->Stop();
  return exit_code;
}

}  // namespace softgrasp::sim
