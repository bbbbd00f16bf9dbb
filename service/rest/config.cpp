#include "service/rest/config.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

namespace softgrasp::rest {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

// A setter reads one JSON value into the config, or says what is wrong with it.
using Setter = std::function<std::string(const json&)>;

template <class T>
Setter Number(T* target, double min, double max) {
  return [=](const json& v) -> std::string {
    if (!v.is_number()) return "must be a number";
    const double x = v.get<double>();
    if (!std::isfinite(x) || x < min || x > max) {
      std::ostringstream os;
      os << "must be in [" << min << ", " << max << "]";
      return os.str();
    }
    if constexpr (std::is_integral_v<T>) {
      if (x != std::floor(x)) return "must be an integer";
    }
    *target = static_cast<T>(x);
    return {};
  };
}

// A size the file gives in millimetres, kept in metres.
Setter Millimetres(double* target_m, double min_mm, double max_mm) {
  return [=](const json& v) -> std::string {
    double mm = 0;
    const std::string problem = Number(&mm, min_mm, max_mm)(v);
    if (problem.empty()) *target_m = core::MetresFromMm(mm);
    return problem;
  };
}

Setter String(std::string* target) {
  return [=](const json& v) -> std::string {
    if (!v.is_string()) return "must be a string";
    *target = v.get<std::string>();
    return {};
  };
}

core::Result<long long> ParseInteger(const char* text, const std::string& name);

Setter Bool(bool* target) {
  return [=](const json& v) -> std::string {
    if (!v.is_boolean()) return "must be true or false";
    *target = v.get<bool>();
    return {};
  };
}

// Says what is wrong with a token without ever echoing it.
std::string TokenProblem(const std::string& token) {
  if (token.size() < 16 || token.size() > 512) return "must be 16 to 512 characters long";
  for (const char c : token) {
    if (c <= 0x20 || c >= 0x7f || c == ',') {
      return "must be visible ASCII characters without commas or spaces";
    }
  }
  return {};
}

Setter Tokens(std::vector<std::string>* target) {
  return [=](const json& v) -> std::string {
    if (!v.is_array()) return "must be an array of strings";
    std::vector<std::string> tokens;
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!v[i].is_string()) return "[" + std::to_string(i) + "] must be a string";
      if (std::string p = TokenProblem(v[i].get<std::string>()); !p.empty()) {
        return "[" + std::to_string(i) + "] " + p;
      }
      tokens.push_back(v[i].get<std::string>());
    }
    *target = std::move(tokens);
    return {};
  };
}

Setter WorkspaceBox(bridge::Workspace* target) {
  return [=](const json& v) -> std::string {
    if (!v.is_object()) return "must be an object {frame_id, min_m, max_m}";
    bridge::Workspace w = *target;
    for (const auto& [key, value] : v.items()) {
      if (key == "frame_id") {
        if (!value.is_string() || value.get<std::string>().empty()) {
          return ".frame_id must be a non-empty string";
        }
        w.frame_id = value.get<std::string>();
      } else if (key == "min_m" || key == "max_m") {
        if (!value.is_array() || value.size() != 3) return "." + key + " must be 3 numbers";
        auto& corner = key == "min_m" ? w.min_m : w.max_m;
        for (std::size_t i = 0; i < 3; ++i) {
          if (!value[i].is_number() || !std::isfinite(value[i].get<double>())) {
            return "." + key + " must be 3 finite numbers";
          }
          corner[i] = value[i].get<double>();
        }
      } else {
        return "has an unknown key '" + key + "'";
      }
    }
    for (std::size_t i = 0; i < 3; ++i) {
      if (!(w.min_m[i] < w.max_m[i])) return "min_m must be below max_m on every axis";
    }
    *target = w;
    return {};
  };
}

constexpr double kMaxBytes = 4.0 * 1024 * 1024 * 1024;
constexpr double kMaxMinDepthM = 100.0;

std::map<std::string, std::map<std::string, Setter>> Sections(ServiceConfig& c) {
  auto& s = c.server;
  auto& g = c.default_gripper;
  auto& f = c.fge;
  auto& cam = c.default_camera;
  return {
      {"server",
       {{"host", String(&s.host)},
        {"port", Number(&s.port, 0, 65535)},
        {"workers", Number(&s.num_workers, 1, 256)},
        {"queue_capacity", Number(&s.queue_capacity, 1, 100000)},
        {"max_connections", Number(&s.max_connections, 1, 1000000)},
        {"max_connections_per_client", Number(&s.max_connections_per_client, 0, 1000000)},
        {"header_timeout_ms", Number(&s.header_timeout_ms, 1, 3600000)},
        {"body_timeout_ms", Number(&s.body_timeout_ms, 1, 3600000)},
        {"keep_alive_timeout_ms", Number(&s.keep_alive_timeout_ms, 1, 3600000)},
        {"max_body_bytes", Number(&s.limits.max_body_bytes, 1, kMaxBytes)},
        {"max_header_bytes", Number(&s.limits.max_header_bytes, 256, 1 << 20)},
        {"max_uri_bytes", Number(&s.limits.max_uri_bytes, 64, 1 << 20)}}},
      {"camera",
       {{"fx", Number(&cam.fx, 1e-6, 1e7)},
        {"fy", Number(&cam.fy, 1e-6, 1e7)},
        {"cx", Number(&cam.cx, -1e7, 1e7)},
        {"cy", Number(&cam.cy, -1e7, 1e7)},
        {"width", Number(&cam.width, 1, 1e6)},
        {"height", Number(&cam.height, 1, 1e6)}}},
      {"gripper",
       {{"opening_stroke_mm", Millimetres(&g.opening_stroke_m, 1, 1000)},
        {"finger_width_mm", Millimetres(&g.finger_width_m, 0.5, 500)},
        {"finger_thickness_mm", Millimetres(&g.finger_thickness_m, 0.5, 500)},
        {"finger_length_mm", Millimetres(&g.finger_length_m, 1, 1000)}}},
      {"fge",
       {{"num_angles", Number(&f.num_angles, 1, 180)},
        {"height_step_m", Number(&f.height_step_m, 0.001, 0.5)},
        {"num_height_steps", Number(&f.num_height_steps, 1, 50)},
        {"grip_depth_m", Number(&f.grip_depth_m, 0.0, 0.5)},
        {"min_object_area_px", Number(&f.min_object_area_px, 1, 1e8)},
        {"floor_clearance_m", Number(&f.floor_clearance_m, 0.0, 0.5)},
        {"seam_step_m", Number(&f.seam_step_m, 0.001, 1.0)},
        {"top_k", Number(&f.top_k, 1, 1000)},
        {"nms_radius_px", Number(&f.nms_radius_px, 0, 10000)}}},
      {"depth",
       {{"png_unit_m", Number(&c.png_unit_m, 1e-6, 1.0)},
        {"max_image_pixels", Number(&c.max_image_pixels, 1, 1e10)},
        {"min_depth_m", Number(&c.min_depth_m, 0.0, kMaxMinDepthM)}}},
      {"fractals",
       {{"max_points", Number(&c.max_fractal_points, 100, 1e6)},
        {"max_attempts", Number(&c.max_fractal_attempts, 1, 1e7)}}},
      {"web", {{"root", String(&c.web_root)}}},
      {"models",
       {{"stiffness", String(&c.stiffness_model)},
        {"segmentation", String(&c.segmentation_model)}}},
      {"robot",
       {{"enabled", Bool(&c.robot.enabled)},
        {"domain_id", Number(&c.robot.domain_id, 0, 232)},
        {"dds_config", String(&c.robot.dds_config)},
        {"tokens", Tokens(&c.robot.tokens)},
        {"workspace", WorkspaceBox(&c.robot.workspace)},
        {"command_timeout_s", Number(&c.robot.command_timeout_s, 0.1, 86400)},
        {"journal_dir", String(&c.robot.journal_dir)},
        {"retention_s", Number(&c.robot.retention_s, 1, 3.2e8)},
        {"retention_max_commands", Number(&c.robot.retention_max_commands, 1, 1e9)},
        {"default_force_n", Number(&c.robot.default_force_n, 0.01, 1000)}}},
  };
}

core::Result<bool> ParseBool(const char* text, const std::string& name) {
  const std::string t(text);
  if (t == "1" || t == "true" || t == "yes" || t == "on") return true;
  if (t == "0" || t == "false" || t == "no" || t == "off") return false;
  return MakeError(ErrorCode::kInvalidArgument, name + " must be true or false, got '" + t + "'",
                   name);
}

core::Result<double> ParseDouble(const char* text, const std::string& name) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text, &end);
  if (errno != 0 || end == text || *end != '\0' || !std::isfinite(v)) {
    return MakeError(ErrorCode::kInvalidArgument, name + " must be a number, got '" + text + "'",
                     name);
  }
  return v;
}

// SOFTGRASP_ROBOT_TOKENS="t1,t2": empty items are ignored; a bad token is named by position only.
core::Result<std::vector<std::string>> ParseTokenList(const std::string& text) {
  std::vector<std::string> tokens;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    std::string token = text.substr(start, end - start);
    while (!token.empty() && (token.back() == ' ' || token.back() == '\t')) token.pop_back();
    while (!token.empty() && (token.front() == ' ' || token.front() == '\t')) token.erase(0, 1);
    if (!token.empty()) {
      if (std::string p = TokenProblem(token); !p.empty()) {
        return MakeError(
            ErrorCode::kInvalidArgument,
            "SOFTGRASP_ROBOT_TOKENS item " + std::to_string(tokens.size() + 1) + " " + p,
            "SOFTGRASP_ROBOT_TOKENS");
      }
      tokens.push_back(std::move(token));
    }
    start = end + 1;
  }
  return tokens;
}

core::Result<ServiceConfig> ApplyRobotEnvironment(ServiceConfig config) {
  RobotConfig& robot = config.robot;
  if (const char* v = std::getenv("SOFTGRASP_ROBOT_ENABLED")) {
    auto b = ParseBool(v, "SOFTGRASP_ROBOT_ENABLED");
    if (!b) return b.error();
    robot.enabled = b.value();
  }
  if (const char* v = std::getenv("SOFTGRASP_ROBOT_DOMAIN_ID")) {
    auto id = ParseInteger(v, "SOFTGRASP_ROBOT_DOMAIN_ID");
    if (!id) return id.error();
    if (id.value() < 0 || id.value() > 232) {
      return MakeError(ErrorCode::kInvalidArgument, "SOFTGRASP_ROBOT_DOMAIN_ID must be in [0, 232]",
                       "SOFTGRASP_ROBOT_DOMAIN_ID");
    }
    robot.domain_id = static_cast<int>(id.value());
  }
  if (const char* v = std::getenv("SOFTGRASP_ROBOT_DDS_CONFIG")) robot.dds_config = v;
  if (const char* v = std::getenv("SOFTGRASP_ROBOT_JOURNAL_DIR")) robot.journal_dir = v;
  if (const char* v = std::getenv("SOFTGRASP_ROBOT_TOKENS")) {
    auto tokens = ParseTokenList(v);
    if (!tokens) return tokens.error();
    robot.tokens = std::move(tokens).value();
  }
  if (const char* v = std::getenv("SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S")) {
    auto t = ParseDouble(v, "SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S");
    if (!t) return t.error();
    if (t.value() < 0.1 || t.value() > 86400) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S must be in [0.1, 86400]",
                       "SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S");
    }
    robot.command_timeout_s = t.value();
  }
  return config;
}

core::Result<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return MakeError(ErrorCode::kInvalidArgument, "cannot read config file " + path, "config");
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

core::Result<long long> ParseInteger(const char* text, const std::string& name) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0') {
    return MakeError(ErrorCode::kInvalidArgument, name + " must be an integer, got '" + text + "'",
                     name);
  }
  return v;
}

}  // namespace

core::Result<ServiceConfig> ApplyConfigJson(ServiceConfig config, const std::string& json_text) {
  const json doc = json::parse(json_text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return MakeError(ErrorCode::kInvalidArgument, "config must be a JSON object", "config");
  }
  auto sections = Sections(config);
  for (const auto& [section_name, section] : doc.items()) {
    const auto known = sections.find(section_name);
    if (known == sections.end()) {
      return MakeError(ErrorCode::kInvalidArgument, "unknown config section '" + section_name + "'",
                       section_name);
    }
    if (!section.is_object()) {
      return MakeError(ErrorCode::kInvalidArgument, section_name + " must be an object",
                       section_name);
    }
    for (const auto& [key, value] : section.items()) {
      const std::string field = section_name + "." + key;
      const auto setter = known->second.find(key);
      if (setter == known->second.end()) {
        return MakeError(ErrorCode::kInvalidArgument, "unknown config key '" + field + "'", field);
      }
      if (const std::string problem = setter->second(value); !problem.empty()) {
        return MakeError(ErrorCode::kInvalidArgument, field + " " + problem, field);
      }
    }
  }
  return config;
}

core::Result<ServiceConfig> ApplyEnvironment(ServiceConfig config) {
  if (const char* host = std::getenv("SOFTGRASP_HOST")) config.server.host = host;
  if (const char* web_root = std::getenv("SOFTGRASP_WEB_ROOT")) config.web_root = web_root;
  if (const char* model = std::getenv("SOFTGRASP_STIFFNESS_MODEL")) config.stiffness_model = model;
  if (const char* model = std::getenv("SOFTGRASP_SEGMENTATION_MODEL")) {
    config.segmentation_model = model;
  }
  if (const char* v = std::getenv("SOFTGRASP_MIN_DEPTH_M")) {
    auto d = ParseDouble(v, "SOFTGRASP_MIN_DEPTH_M");
    if (!d) return d.error();
    if (d.value() < 0 || d.value() > kMaxMinDepthM) {
      return MakeError(ErrorCode::kInvalidArgument, "SOFTGRASP_MIN_DEPTH_M must be in [0, 100]",
                       "SOFTGRASP_MIN_DEPTH_M");
    }
    config.min_depth_m = d.value();
  }
  struct IntVar {
    const char* name;
    std::function<void(long long)> set;
    long long min, max;
  };
  const IntVar vars[] = {
      {"SOFTGRASP_PORT", [&](long long v) { config.server.port = static_cast<uint16_t>(v); }, 0,
       65535},
      {"SOFTGRASP_WORKERS", [&](long long v) { config.server.num_workers = static_cast<int>(v); },
       1, 256},
      {"SOFTGRASP_MAX_BODY_BYTES",
       [&](long long v) { config.server.limits.max_body_bytes = static_cast<std::size_t>(v); }, 1,
       static_cast<long long>(kMaxBytes)},
      {"SOFTGRASP_MAX_IMAGE_PIXELS", [&](long long v) { config.max_image_pixels = v; }, 1,
       10'000'000'000LL},
  };
  for (const auto& var : vars) {
    const char* text = std::getenv(var.name);
    if (text == nullptr) continue;
    auto value = ParseInteger(text, var.name);
    if (!value.ok()) return value.error();
    if (value.value() < var.min || value.value() > var.max) {
      return MakeError(ErrorCode::kInvalidArgument,
                       std::string(var.name) + " must be in [" + std::to_string(var.min) + ", " +
                           std::to_string(var.max) + "]",
                       var.name);
    }
    var.set(value.value());
  }
  return ApplyRobotEnvironment(std::move(config));
}

core::Result<CommandLine> ParseCommandLine(const std::vector<std::string>& args) {
  CommandLine out;
  std::map<std::string, std::string> flags;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      out.help = true;
      return out;
    }
    if (a == "--host" || a == "--port" || a == "--config" || a == "--workers" ||
        a == "--web-root" || a == "--stiffness-model" || a == "--segmentation-model") {
      if (i + 1 >= args.size()) {
        return MakeError(ErrorCode::kInvalidArgument, a + " needs a value", a);
      }
      flags[a] = args[++i];
      continue;
    }
    return MakeError(ErrorCode::kInvalidArgument, "unknown argument '" + a + "'", a);
  }
  ServiceConfig config;
  if (const auto file = flags.find("--config"); file != flags.end()) {
    auto text = ReadFile(file->second);
    if (!text.ok()) return text.error();
    auto applied = ApplyConfigJson(config, text.value());
    if (!applied.ok()) return applied.error();
    config = applied.value();
  }
  auto env = ApplyEnvironment(config);
  if (!env.ok()) return env.error();
  config = env.value();
  if (const auto host = flags.find("--host"); host != flags.end())
    config.server.host = host->second;
  if (const auto web = flags.find("--web-root"); web != flags.end()) config.web_root = web->second;
  if (const auto model = flags.find("--stiffness-model"); model != flags.end()) {
    config.stiffness_model = model->second;
  }
  if (const auto model = flags.find("--segmentation-model"); model != flags.end()) {
    config.segmentation_model = model->second;
  }
  for (const char* name : {"--port", "--workers"}) {
    const auto flag = flags.find(name);
    if (flag == flags.end()) continue;
    auto value = ParseInteger(flag->second.c_str(), name);
    if (!value.ok()) return value.error();
    const long long v = value.value();
    if (std::string(name) == "--port") {
      if (v < 0 || v > 65535)
        return MakeError(ErrorCode::kInvalidArgument, "--port must be in [0, 65535]", name);
      config.server.port = static_cast<uint16_t>(v);
    } else {
      if (v < 1 || v > 256)
        return MakeError(ErrorCode::kInvalidArgument, "--workers must be in [1, 256]", name);
      config.server.num_workers = static_cast<int>(v);
    }
  }
  out.config = config;
  return out;
}

std::string UsageText() {
  return "usage: softgrasp-server [--host HOST] [--port PORT] [--workers N] [--config FILE]\n"
         "                        [--web-root DIR] [--stiffness-model FILE|none]\n"
         "                        [--segmentation-model FILE|none]\n"
         "  --port 0 picks a free port; the chosen address is printed as\n"
         "  'listening on http://HOST:PORT'. --web-root: the built web page served at GET /\n"
         "  (default: ../web next to the executable's folder). --stiffness-model: the\n"
         "  pix2stiffness model for /v1/stiffness and strategy=stiffness (default: the shipped\n"
         "  ../models/pix2stiffness.pt; 'none' serves without one). --segmentation-model: the\n"
         "  instance segmentation model for /v1/segmentation (default: the shipped\n"
         "  ../models/segmentation.pt when it exists; 'none' or no file: the PCL baseline).\n"
         "  Environment: SOFTGRASP_HOST,\n"
         "  SOFTGRASP_PORT, SOFTGRASP_WORKERS, SOFTGRASP_MAX_BODY_BYTES,\n"
         "  SOFTGRASP_MAX_IMAGE_PIXELS, SOFTGRASP_MIN_DEPTH_M, SOFTGRASP_WEB_ROOT,\n"
         "  SOFTGRASP_STIFFNESS_MODEL, SOFTGRASP_SEGMENTATION_MODEL.\n"
         "  Robot endpoints: SOFTGRASP_ROBOT_ENABLED, SOFTGRASP_ROBOT_TOKENS,\n"
         "  SOFTGRASP_ROBOT_DOMAIN_ID, SOFTGRASP_ROBOT_DDS_CONFIG, SOFTGRASP_ROBOT_JOURNAL_DIR,\n"
         "  SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S (docs/robot-api.md).\n"
         "  Precedence: flags > environment > config file > defaults (docs/configuration.md).\n";
}

std::string ConfigToJson(const ServiceConfig& c) {
  const auto& s = c.server;
  const auto& g = c.default_gripper;
  const auto& f = c.fge;
  const auto& cam = c.default_camera;
  json j = {
      {"server",
       {{"host", s.host},
        {"port", s.port},
        {"workers", s.num_workers},
        {"queue_capacity", s.queue_capacity},
        {"max_connections", s.max_connections},
        {"max_connections_per_client", s.max_connections_per_client},
        {"header_timeout_ms", s.header_timeout_ms},
        {"body_timeout_ms", s.body_timeout_ms},
        {"keep_alive_timeout_ms", s.keep_alive_timeout_ms},
        {"max_body_bytes", s.limits.max_body_bytes},
        {"max_header_bytes", s.limits.max_header_bytes},
        {"max_uri_bytes", s.limits.max_uri_bytes}}},
      {"camera",
       {{"fx", cam.fx},
        {"fy", cam.fy},
        {"cx", cam.cx},
        {"cy", cam.cy},
        {"width", cam.width},
        {"height", cam.height}}},
      {"gripper",
       {{"opening_stroke_mm", core::MmFromMetres(g.opening_stroke_m)},
        {"finger_width_mm", core::MmFromMetres(g.finger_width_m)},
        {"finger_thickness_mm", core::MmFromMetres(g.finger_thickness_m)},
        {"finger_length_mm", core::MmFromMetres(g.finger_length_m)}}},
      {"fge",
       {{"num_angles", f.num_angles},
        {"height_step_m", f.height_step_m},
        {"num_height_steps", f.num_height_steps},
        {"grip_depth_m", f.grip_depth_m},
        {"min_object_area_px", f.min_object_area_px},
        {"floor_clearance_m", f.floor_clearance_m},
        {"seam_step_m", f.seam_step_m},
        {"top_k", f.top_k},
        {"nms_radius_px", f.nms_radius_px}}},
      {"depth",
       {{"png_unit_m", c.png_unit_m},
        {"max_image_pixels", c.max_image_pixels},
        {"min_depth_m", c.min_depth_m}}},
      {"fractals",
       {{"max_points", c.max_fractal_points}, {"max_attempts", c.max_fractal_attempts}}},
      {"web", {{"root", c.web_root}}},
      {"models", {{"stiffness", c.stiffness_model}, {"segmentation", c.segmentation_model}}},
      {"robot",
       {{"enabled", c.robot.enabled},
        {"domain_id", c.robot.domain_id},
        {"dds_config", c.robot.dds_config},
        // Secrets: only how many there are.
        {"tokens", json::array()},
        {"tokens_configured", c.robot.tokens.size()},
        {"workspace",
         {{"frame_id", c.robot.workspace.frame_id},
          {"min_m", c.robot.workspace.min_m},
          {"max_m", c.robot.workspace.max_m}}},
        {"command_timeout_s", c.robot.command_timeout_s},
        {"journal_dir", c.robot.journal_dir},
        {"retention_s", c.robot.retention_s},
        {"retention_max_commands", c.robot.retention_max_commands},
        {"default_force_n", c.robot.default_force_n}}},
  };
  for (std::size_t i = 0; i < c.robot.tokens.size(); ++i) j["robot"]["tokens"].push_back("***");
  return j.dump();
}

std::string RobotDisabledReason(const RobotConfig& robot) {
  if (!robot.enabled) return "the robot endpoints are disabled in this service (robot.enabled)";
  if (robot.tokens.empty()) {
    return "the robot endpoints are disabled: no tokens are configured (robot.tokens or "
           "SOFTGRASP_ROBOT_TOKENS)";
  }
  return {};
}

std::string DefaultJournalDir() {
  namespace fs = std::filesystem;
  if (const char* state = std::getenv("XDG_STATE_HOME"); state != nullptr && *state != '\0') {
    return (fs::path(state) / "softgrasp" / "robot-journal").string();
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && *home != '\0') {
    return (fs::path(home) / ".local" / "state" / "softgrasp" / "robot-journal").string();
  }
  return {};
}

std::string DefaultWebRoot(const std::string& executable_path) {
  namespace fs = std::filesystem;
  // Lexically, not through the file system: "<bin>/.." must not depend on what <bin> links to.
  const fs::path prefix = fs::path(executable_path).lexically_normal().parent_path().parent_path();
  const fs::path candidates[] = {prefix / "web", prefix / "share" / "softgrasp" / "web"};
  for (const fs::path& candidate : candidates) {
    std::error_code error;
    if (fs::is_regular_file(candidate / "index.html", error)) return candidate.string();
  }
  return candidates[0].string();
}

namespace {

// <prefix>/models/NAME, else <prefix>/share/softgrasp/models/NAME, else "none".
std::string ShippedModel(const std::string& executable_path, const char* name) {
  namespace fs = std::filesystem;
  const fs::path prefix = fs::path(executable_path).lexically_normal().parent_path().parent_path();
  const fs::path relative = fs::path("models") / name;
  for (const fs::path& candidate : {prefix / relative, prefix / "share" / "softgrasp" / relative}) {
    std::error_code error;
    if (fs::is_regular_file(candidate, error)) return candidate.string();
  }
  return "none";
}

}  // namespace

std::string DefaultStiffnessModel(const std::string& executable_path) {
  return ShippedModel(executable_path, "pix2stiffness.pt");
}

std::string DefaultSegmentationModel(const std::string& executable_path) {
  return ShippedModel(executable_path, "segmentation.pt");
}

}  // namespace softgrasp::rest
