#include "sim/robot/robot_cli.h"

#include <signal.h>

#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

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
    "  (scene_NNNNNN.json) written by `softgrasp-sim generate`; flags after it still apply.\n"
    "  --dds-config takes what CYCLONEDDS_URI takes\n"
    "  (default: CYCLONEDDS_URI, else Cyclone's defaults). SIGINT/SIGTERM stop it.\n";

bool ParseInt(const std::string& text, long long* out) {
  char* end = nullptr;
  *out = std::strtoll(text.c_str(), &end, 10);
  return !text.empty() && end == text.c_str() + text.size();
}

bool ParseRange(const std::string& value, long long* lo, long long* hi) {
  const auto dash = value.find('-');
  if (dash == std::string::npos) return ParseInt(value, lo) && (*hi = *lo, true);
  return ParseInt(value.substr(0, dash), lo) && ParseInt(value.substr(dash + 1), hi);
}

// --scene FILE: the scene of a `softgrasp-sim generate` manifest, rebuilt from its spec and seed.
std::string LoadSceneManifest(const std::string& path, RobotCommandLine* out) {
  std::ifstream in(path);
  if (!in) return "--scene: cannot read " + path;
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json manifest =
      nlohmann::json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
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

std::string ParseRobotArgs(const std::vector<std::string>& args, RobotCommandLine* out) {
  out->spec.render.noise.enabled = true;
  out->http.host = "127.0.0.1";
  out->http.port = 8081;
  for (std::size_t i = 0; i < args.size(); i += 2) {
    const std::string& flag = args[i];
    if (i + 1 >= args.size()) return flag + " needs a value";
    const std::string& value = args[i + 1];
    long long n = 0;
    long long m = 0;
    if (flag == "--scene-seed" && ParseInt(value, &n) && n >= 0) {
      out->scene_seed = static_cast<std::uint64_t>(n);
    } else if (flag == "--scene") {
      if (const std::string problem = LoadSceneManifest(value, out); !problem.empty())
        return problem;
    } else if (flag == "--objects") {
      if (!ParseRange(value, &n, &m) || n < 1 || m > sim::kMaxObjectsPerScene || n > m)
        return "--objects must be N or MIN-MAX within 1-" +
               std::to_string(sim::kMaxObjectsPerScene);
      out->spec.min_objects = static_cast<int>(n);
      out->spec.max_objects = static_cast<int>(m);
    } else if (flag == "--support" && (value == "bin" || value == "table")) {
      out->spec.support.kind = value == "bin" ? Support::Kind::kBin : Support::Kind::kTable;
    } else if (flag == "--noise" && (value == "on" || value == "off")) {
      out->spec.render.noise.enabled = value == "on";
    } else if (flag == "--robot-id") {
      if (value.empty() || value.size() > bridge::kMaxIdBytes)
        return "--robot-id must be 1-256 bytes";
      out->robot_id = value;
    } else if (flag == "--domain" && ParseInt(value, &n) && n >= 0 && n <= 232) {
      out->bridge.domain_id = static_cast<int>(n);
    } else if (flag == "--dds-config") {
      out->bridge.config = value;
    } else if (flag == "--http-host" && !value.empty()) {
      out->http.host = value;
    } else if (flag == "--http-port" && ParseInt(value, &n) && n >= 0 && n <= 65535) {
      out->http.port = static_cast<std::uint16_t>(n);
    } else {
      return "bad argument " + flag + " " + value;
    }
  }
  return "";
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
