#pragma once
/// The service's configuration: defaults, then a JSON file, then SOFTGRASP_* environment
/// variables, then command-line flags, all read through one table of settings (Settings():
/// section and key in the file, environment variable, flag, limits, help). Printed at start-up.
/// Process wiring, not REST: the handlers only read the ServiceConfig they are given.

#include <optional>
#include <string>
#include <vector>

#include "service/bridge/messages.h"
#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/grasp.h"
#include "service/core/status.h"
#include "service/http/server.h"

namespace softgrasp::config {

/// The robot endpoints (docs/robot-api.md): forwarding grasps to robots over DDS.
struct RobotConfig {
  /// Off: the robot routes answer 503 and no DDS participant is created. On but with no tokens:
  /// the same (a robot must never move for an anonymous request).
  bool enabled = true;
  int domain_id = 0;       ///< DDS domain (= ROS_DOMAIN_ID), 0..232
  std::string dds_config;  ///< Cyclone XML or file URIs; "" = CYCLONEDDS_URI, else defaults
  /// Bearer tokens accepted on the robot routes (16..512 visible ASCII characters, no commas).
  /// Secret: masked in ConfigToJson, never logged.
  std::vector<std::string> tokens;
  /// Poses outside this box (in its frame) are refused with 422 before anything is sent.
  bridge::Workspace workspace{"camera", {-0.5, -0.5, 0.1}, {0.5, 0.5, 1.5}};
  double command_timeout_s = 60.0;  ///< no result this long after acceptance: timed_out
  /// Folder of the command journal; "" = DefaultJournalDir().
  std::string journal_dir;
  /// Finished commands (and their ids' idempotency) are kept this long, and at most this many;
  /// older ones are forgotten when the journal is compacted (robot::TrackerOptions).
  double retention_s = 86400.0;
  long long retention_max_commands = 100000;
  double default_force_n = 10.0;  ///< closing force when a request gives none
};

struct ServiceConfig {
  http::ServerOptions server;   ///< host, port, workers, limits, timeouts
  core::Camera default_camera;  ///< used when a request gives no intrinsics
  core::Gripper default_gripper;
  core::FgeParams fge;
  double png_unit_m = 0.001;  ///< metres per 16-bit PNG count unless the request says
  long long max_image_pixels = 4096LL * 4096;  ///< decompression-bomb guard, before decoding
  /// Minimum working distance: surfaces nearer the camera than this (along its axis) are never
  /// grasped, only avoided (e.g. the gripper's own fingers in a wrist camera). 0 = no limit;
  /// requests may override it with the field min_depth_m.
  double min_depth_m = 0.0;
  int max_fractal_points = 200'000;   ///< POST /v1/fractals "points" cap (400 above it)
  int max_fractal_attempts = 20'000;  ///< IFS draws before a fractal request gives up (422)
  int max_mesh_triangles = 200'000;   ///< POST /v1/meshes/grasps upload cap (413 above it)
  /// POST /v1/meshes/grasps work cap: num_grasps x max(1, robust_samples) per request (400 above
  /// it; 25,000 is about 2.5 s of one worker).
  int max_mesh_quality_evaluations = 25'000;
  /// Folder of the built web page served at GET / and /assets/ (scripts/build.sh writes it to
  /// <build>/web). Empty: softgrasp-server uses DefaultWebRoot() next to its executable.
  std::string web_root;
  /// pix2stiffness model file (docs/stiffness.md) for POST /v1/stiffness and strategy=stiffness.
  /// Empty: softgrasp-server uses DefaultStiffnessModel() next to its executable; "none": no
  /// model (those requests answer 503 / 400, and strategy=fge is the default).
  std::string stiffness_model;
  /// Instance segmentation model file (docs/segmentation.md) for POST /v1/segmentation and the
  /// instance options of /v1/grasps. Empty: softgrasp-server uses DefaultSegmentationModel()
  /// next to its executable; "none": no model (segmentation uses the PCL baseline, and
  /// method=model answers 503).
  std::string segmentation_model;
  /// GQ-CNN model file (docs/gqcnn.md) for strategy=gqcnn. Empty: softgrasp-server uses
  /// DefaultGqcnnModel() next to its executable; "none": no model (strategy=gqcnn answers 400).
  std::string gqcnn_model;
  /// Threads of one model's forward pass (libtorch intra-op, process-wide). 0: one per online
  /// CPU. libtorch's own default on a worker thread can be 1 (it counts physical cores).
  int torch_threads = 0;
  RobotConfig robot;
};

/// "" when the robot endpoints can serve, else why not (the 503 message and /v1/info's reason).
std::string RobotDisabledReason(const RobotConfig& robot);

/// ${XDG_STATE_HOME:-$HOME/.local/state}/softgrasp/robot-journal, or "" when neither is set.
std::string DefaultJournalDir();

/// One setting of the table: {"section": {"key": value}} in the file, and optionally an
/// environment variable and a flag. Numbers must lie in [min, max] (in the file's units) wherever
/// they come from; requests that override a setting are held to the same limits.
struct Setting {
  const char* section;
  const char* key;
  const char* env;          ///< SOFTGRASP_..., or null
  const char* flag;         ///< --..., or null
  double min = 0, max = 0;  ///< numbers only
  const char* help;
};

/// Every setting, in the order of docs/configuration.md and the start-up dump.
std::vector<Setting> Settings();
/// The setting `section`.`key`. @throws std::invalid_argument for an unknown one.
Setting SettingOf(const std::string& section, const std::string& key);

/// Applies a JSON config document (see docs/configuration.md) onto `config`.
/// kInvalidArgument naming the key when a value has the wrong type or range.
core::Result<ServiceConfig> ApplyConfigJson(ServiceConfig config, const std::string& json_text);

/// Applies the settings' environment variables (Settings() with an env; tokens comma-separated).
/// kInvalidArgument naming the variable when its value is not a number, true/false, or in range.
core::Result<ServiceConfig> ApplyEnvironment(ServiceConfig config);

/// Parses argv: --config FILE, the settings' flags (Settings() with a flag), --help. The config
/// file is applied first, then the environment, then the other flags. `help` is set for --help.
struct CommandLine {
  ServiceConfig config;
  bool help = false;
};
core::Result<CommandLine> ParseCommandLine(const std::vector<std::string>& args);

/// The flags and environment variables with their help, from Settings().
std::string UsageText();

/// Where the built page is when no web root is configured, given the server executable's path
/// <prefix>/<bin>/softgrasp-server: "<prefix>/web" (the build tree: build/service/ -> build/web)
/// if it holds an index.html, else "<prefix>/share/softgrasp/web" (an installed layout) if that
/// does, else "<prefix>/web".
std::string DefaultWebRoot(const std::string& executable_path);

/// The shipped model when no model is configured, given the server executable's path
/// <prefix>/<bin>/softgrasp-server: "<prefix>/models/pix2stiffness.pt" (the build tree, where the
/// build copies it) if it exists, else "<prefix>/share/softgrasp/models/pix2stiffness.pt" if that
/// does, else "none".
std::string DefaultStiffnessModel(const std::string& executable_path);

/// The shipped segmentation model when none is configured, as DefaultStiffnessModel:
/// "<prefix>/models/segmentation.pt", else "<prefix>/share/softgrasp/models/segmentation.pt",
/// else "none" (the PCL baseline serves).
std::string DefaultSegmentationModel(const std::string& executable_path);
/// The shipped ../models/gqcnn.pt next to the executable's folder, or "none" when absent.
std::string DefaultGqcnnModel(const std::string& executable_path);

/// The effective configuration as JSON, with the robot tokens masked.
std::string ConfigToJson(const ServiceConfig& config);

}  // namespace softgrasp::config
