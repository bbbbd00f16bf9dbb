// softgrasp-server: wiring and configuration only.
#include <csignal>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "service/bridge/bridge.h"
#include "service/config/config.h"
#include "service/core/preprocess.h"
#include "service/http/server.h"
#include "service/models/gqcnn_model.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/process/allocator.h"
#include "service/rest/api.h"
#include "service/robot/command_tracker.h"

namespace {

// Blocks SIGINT/SIGTERM in every thread (the server's threads inherit the mask) so that the
// main thread can wait for them synchronously and shut down gracefully.
sigset_t BlockShutdownSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

// The running executable's path, for finding the built web page next to it.
std::string ExecutablePath(const char* argv0) {
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::string(argv0) : self.string();
}

// The robot side of the service (docs/robot-api.md): a DDS participant on the configured domain and
// the command tracker over the journal. Null when the robot endpoints are off, with the reason
// printed; an error when they are on but cannot start (the service then does not start either).
softgrasp::core::Result<std::shared_ptr<softgrasp::robot::CommandTracker>> StartRobot(
    softgrasp::config::RobotConfig& robot) {
  using namespace softgrasp;
  if (const std::string reason = config::RobotDisabledReason(robot); !reason.empty()) {
    std::cerr << "softgrasp-server: " << reason << "\n";
    return std::shared_ptr<robot::CommandTracker>();
  }
  if (robot.journal_dir.empty()) robot.journal_dir = config::DefaultJournalDir();
  bridge::BridgeOptions options;
  options.domain_id = robot.domain_id;
  options.config = robot.dds_config;
  auto bridge = bridge::ServiceBridge::Create(options);
  if (!bridge) return bridge.error();
  robot::TrackerOptions tracker_options;
  tracker_options.journal_dir = robot.journal_dir;
  tracker_options.command_timeout_s = robot.command_timeout_s;
  tracker_options.retention_s = robot.retention_s;
  tracker_options.retention_max_commands = robot.retention_max_commands;
  auto tracker = robot::CommandTracker::Create(tracker_options, std::move(bridge).value());
  if (!tracker) return tracker.error();
  const robot::TrackerStats stats = tracker.value()->stats();
  std::cerr << "softgrasp-server: robot endpoints on DDS domain " << robot.domain_id << ", journal "
            << robot.journal_dir << " (" << stats.replayed_commands << " commands replayed, "
            << stats.republished << " re-sent, " << stats.forgotten_commands
            << " finished ones past their retention forgotten)\n";
  return std::shared_ptr<robot::CommandTracker>(std::move(tracker).value());
}

// The pix2stiffness model (docs/stiffness.md), or null when configured "none". A configured
// model that cannot be loaded is an error: the service does not start without what it was told
// to serve.
softgrasp::core::Result<std::shared_ptr<const softgrasp::models::StiffnessModel>>
LoadStiffnessModel(const std::string& path) {
  using namespace softgrasp;
  if (path == "none") {
    std::cerr << "softgrasp-server: no stiffness model (POST /v1/stiffness answers 503, grasps use "
                 "strategy fge)\n";
    return std::shared_ptr<const models::StiffnessModel>();
  }
  auto model = models::StiffnessModel::Load(path);
  if (!model) return model.error();
  // One forward pass now, so the first request does not pay libtorch's one-time set-up.
  const int side = model.value().input_size();
  model.value().PredictModelInput(cv::Mat1f(side, side, -1.0f));
  std::cerr << "softgrasp-server: stiffness model " << path << " (" << model.value().description()
            << ")\n";
  return std::shared_ptr<const models::StiffnessModel>(
      std::make_shared<models::StiffnessModel>(std::move(model).value()));
}

// The instance segmentation model (docs/segmentation.md), or null when configured "none" (the
// PCL baseline then segments). A configured model that cannot be loaded is an error, as above.
softgrasp::core::Result<std::shared_ptr<const softgrasp::models::SegmentationModel>>
LoadSegmentationModel(const std::string& path) {
  using namespace softgrasp;
  if (path == "none") {
    std::cerr << "softgrasp-server: no segmentation model (POST /v1/segmentation uses the PCL "
                 "baseline; method=model answers 503)\n";
    return std::shared_ptr<const models::SegmentationModel>();
  }
  auto model = models::SegmentationModel::Load(path);
  if (!model) return model.error();
  // One run on an empty table now, so the first request does not pay libtorch's set-up.
  core::Camera camera;
  camera.width = model.value().input_width();
  camera.height = model.value().input_height();
  camera.cx = (camera.width - 1) / 2.0;
  camera.cy = (camera.height - 1) / 2.0;
  core::DepthImage table;
  table.depth_m = cv::Mat1f(camera.height, camera.width, 0.6f);
  if (auto scene = core::Preprocess(table, camera); scene.ok()) {
    model.value().SegmentScene(scene.value());
  }
  std::cerr << "softgrasp-server: segmentation model " << path << " ("
            << model.value().description() << ")\n";
  return std::shared_ptr<const models::SegmentationModel>(
      std::make_shared<models::SegmentationModel>(std::move(model).value()));
}

// The GQ-CNN (docs/gqcnn.md), or null when configured "none" (strategy=gqcnn is then refused).
// A configured model that cannot be loaded is an error, as above.
softgrasp::core::Result<std::shared_ptr<const softgrasp::models::GqcnnModel>> LoadGqcnnModel(
    const std::string& path) {
  using namespace softgrasp;
  if (path == "none") {
    std::cerr << "softgrasp-server: no GQ-CNN model (strategy=gqcnn is not served)\n";
    return std::shared_ptr<const models::GqcnnModel>();
  }
  auto model = models::GqcnnModel::Load(path);
  if (!model) return model.error();
  std::cerr << "softgrasp-server: GQ-CNN model " << path << " (" << model.value().description()
            << ")\n";
  return std::shared_ptr<const models::GqcnnModel>(
      std::make_shared<models::GqcnnModel>(std::move(model).value()));
}

}  // namespace

int main(int argc, char** argv) {
  using namespace softgrasp;
  auto command_line = config::ParseCommandLine(std::vector<std::string>(argv + 1, argv + argc));
  if (!command_line.ok()) {
    std::cerr << "softgrasp-server: " << command_line.error().message << "\n"
              << config::UsageText();
    return 2;
  }
  if (command_line.value().help) {
    std::cout << config::UsageText();
    return 0;
  }
  config::ServiceConfig& config = command_line.value().config;
  if (config.web_root.empty()) config.web_root = config::DefaultWebRoot(ExecutablePath(argv[0]));
  if (config.robot.journal_dir.empty()) config.robot.journal_dir = config::DefaultJournalDir();
  if (config.stiffness_model.empty()) {
    config.stiffness_model = config::DefaultStiffnessModel(ExecutablePath(argv[0]));
  }
  if (config.segmentation_model.empty()) {
    config.segmentation_model = config::DefaultSegmentationModel(ExecutablePath(argv[0]));
  }
  if (config.gqcnn_model.empty()) {
    config.gqcnn_model = config::DefaultGqcnnModel(ExecutablePath(argv[0]));
  }
  std::cerr << "config " << config::ConfigToJson(config) << "\n";
  if (std::error_code error; !std::filesystem::is_regular_file(
          std::filesystem::path(config.web_root) / "index.html", error)) {
    std::cerr << "softgrasp-server: no web page in " << config.web_root
              << " (GET / answers 404): run scripts/build.sh or pass --web-root\n";
  }

  process::KeepFreedMemoryForReuse();             // per-request buffers, freed on worker threads
  models::SetTorchThreads(config.torch_threads);  // 0: one per CPU
  auto stiffness_model = LoadStiffnessModel(config.stiffness_model);
  if (!stiffness_model) {
    std::cerr << "softgrasp-server: the stiffness model cannot be loaded: "
              << stiffness_model.error().message << "\n";
    return 1;
  }
  auto segmentation_model = LoadSegmentationModel(config.segmentation_model);
  if (!segmentation_model) {
    std::cerr << "softgrasp-server: the segmentation model cannot be loaded: "
              << segmentation_model.error().message << "\n";
    return 1;
  }
  auto gqcnn_model = LoadGqcnnModel(config.gqcnn_model);
  if (!gqcnn_model) {
    std::cerr << "softgrasp-server: the GQ-CNN model cannot be loaded: "
              << gqcnn_model.error().message << "\n";
    return 1;
  }

  // One descriptor per connection, plus the journal, DDS sockets, model and page files.
  constexpr std::size_t kSpareDescriptors = 256;
  const std::size_t wanted_fds = config.server.max_connections + kSpareDescriptors;
  if (const std::size_t fds = http::RaiseOpenFileLimit(wanted_fds); fds < wanted_fds) {
    std::cerr << "softgrasp-server: the open-file limit is " << fds << " (hard limit), below the "
              << wanted_fds << " that server.max_connections = " << config.server.max_connections
              << " needs; connections over it wait until others close\n";
  }

  // Before any thread starts (DDS and the tracker start threads), so they all inherit the mask.
  const sigset_t signals = BlockShutdownSignals();
  auto robot = StartRobot(config.robot);
  if (!robot) {
    std::cerr << "softgrasp-server: the robot endpoints cannot start: " << robot.error().message
              << (robot.error().field.empty() ? "" : " (" + robot.error().field + ")") << "\n";
    return 1;
  }
  try {
    http::Router router = rest::BuildRouter(config, robot.value(), stiffness_model.value(),
                                            segmentation_model.value(), gqcnn_model.value());
    config.server.answer_inline = [&router](const http::Request& request) {
      return router.AnswersInline(request);
    };
    http::Server server(config.server,
                        [&router](http::Request& request) { return router.Dispatch(request); });
    server.Start();
    const bool ipv6 = config.server.host.find(':') != std::string::npos;
    std::cout << "listening on http://" << (ipv6 ? "[" : "") << config.server.host
              << (ipv6 ? "]" : "") << ":" << server.port() << std::endl;

    int received = 0;
    sigwait(&signals, &received);
    std::cerr << "softgrasp-server: " << (received == SIGINT ? "SIGINT" : "SIGTERM")
              << ", finishing in-flight requests\n";
    server.Stop();
  } catch (const std::exception& e) {
    std::cerr << "softgrasp-server: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
