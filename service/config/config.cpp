#include "service/config/config.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <type_traits>

#include "service/cli/args.h"
#include "service/cli/files.h"
#include "service/codec/json_codec.h"

namespace softgrasp::config {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

constexpr double kMaxBytes = 4.0 * 1024 * 1024 * 1024;

// How one setting is read and written: `set` takes a JSON value (from the file, or converted
// from an environment variable or a flag) and says what is wrong with it ("" = applied); `get`
// gives the effective value for the start-up dump.
struct Access {
  std::function<std::string(const json&)> set;
  std::function<json()> get;
};

std::string RangeText(double min, double max) {
  std::ostringstream os;
  os << "must be in [" << min << ", " << max << "]";
  return os.str();
}

template <class T>
Access Number(T* target, double min, double max) {
  return {[=](const json& v) -> std::string {
            if (!v.is_number()) return "must be a number";
            const double x = v.get<double>();
            if (!std::isfinite(x) || x < min || x > max) return RangeText(min, max);
            if constexpr (std::is_integral_v<T>) {
              if (x != std::floor(x)) return "must be an integer";
            }
            *target = static_cast<T>(x);
            return {};
          },
          [=] { return json(*target); }};
}

// A size the file gives in millimetres, kept in metres.
Access Millimetres(double* target_m, double min_mm, double max_mm) {
  return {[=](const json& v) -> std::string {
            double mm = 0;
            const std::string problem = Number(&mm, min_mm, max_mm).set(v);
            if (problem.empty()) *target_m = core::MetresFromMm(mm);
            return problem;
          },
          [=] { return json(core::MmFromMetres(*target_m)); }};
}

Access String(std::string* target) {
  return {[=](const json& v) -> std::string {
            if (!v.is_string()) return "must be a string";
            *target = v.get<std::string>();
            return {};
          },
          [=] { return json(*target); }};
}

Access Bool(bool* target) {
  return {[=](const json& v) -> std::string {
            if (!v.is_boolean()) return "must be true or false";
            *target = v.get<bool>();
            return {};
          },
          [=] { return json(*target); }};
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

Access Tokens(std::vector<std::string>* target) {
  return {[=](const json& v) -> std::string {
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
          },
          // Secrets: never printed, only how many there are.
          [=] { return json(std::vector<std::string>(target->size(), "***")); }};
}

Access WorkspaceBox(bridge::Workspace* target) {
  return {[=](const json& v) -> std::string {
            if (!v.is_object()) return "must be an object {frame_id, min_m, max_m}";
            // The keys given replace the current box's; the codec names them from "" on, so its
            // message reads on after the setting's name (".min_m must be ...").
            auto w = codec::WorkspaceFromJson(v, "", *target);
            if (!w) return w.error().message;
            *target = std::move(w).value();
            return {};
          },
          [=] { return codec::ToJson(*target); }};
}

// How a flag's or an environment variable's text becomes the JSON value the setting takes.
enum class Text { kNumber, kString, kBool, kTokenList, kNone };

struct Entry {
  Setting setting;
  Text text;
  Access access;
};

// The one table of settings: the file's sections and keys, their environment variables and
// flags, their limits and their help. ApplyConfigJson, ApplyEnvironment, ParseCommandLine,
// ConfigToJson, UsageText and SettingOf all read it.
std::vector<Entry> Table(ServiceConfig& c) {
  auto& s = c.server;
  auto& g = c.default_gripper;
  auto& f = c.fge;
  auto& cam = c.default_camera;
  auto& r = c.robot;
  // A number's limits are stated once: the table's entry and the check that applies it share them.
  const auto num = []<class T>(const char* section, const char* key, const char* env,
                               const char* flag, double min, double max, const char* help,
                               T* target) {
    return Entry{
        {section, key, env, flag, min, max, help}, Text::kNumber, Number(target, min, max)};
  };
  // A size given in millimetres (the file, flags and dump) and kept in metres.
  const auto mm = [](const char* section, const char* key, const char* env, const char* flag,
                     double min_mm, double max_mm, const char* help, double* target_m) {
    return Entry{{section, key, env, flag, min_mm, max_mm, help},
                 Text::kNumber,
                 Millimetres(target_m, min_mm, max_mm)};
  };
  const auto text = [](const char* section, const char* key, const char* env, const char* flag,
                       Text kind, const char* help, Access access) {
    return Entry{{section, key, env, flag, 0, 0, help}, kind, std::move(access)};
  };
  const double max_steps = core::kMaxHeightSteps;
  return {
      text("server", "host", "SOFTGRASP_HOST", "--host", Text::kString, "address to listen on",
           String(&s.host)),
      num("server", "port", "SOFTGRASP_PORT", "--port", 0, 65535,
          "TCP port; 0 picks a free one (printed as 'listening on http://HOST:PORT')", &s.port),
      num("server", "workers", "SOFTGRASP_WORKERS", "--workers", 1, 256, "request worker threads",
          &s.num_workers),
      num("server", "queue_capacity", nullptr, nullptr, 1, 100000,
          "requests waiting for a worker before 503", &s.queue_capacity),
      num("server", "max_connections", nullptr, nullptr, 1, 1000000, "open connections at most",
          &s.max_connections),
      num("server", "max_connections_per_client", nullptr, nullptr, 0, 1000000,
          "open connections per client address (0 = no cap)", &s.max_connections_per_client),
      num("server", "header_timeout_ms", nullptr, nullptr, 1, 3600000,
          "a header block must arrive within this of its first byte", &s.header_timeout_ms),
      num("server", "body_timeout_ms", nullptr, nullptr, 1, 3600000,
          "a body must arrive within this of its headers", &s.body_timeout_ms),
      num("server", "keep_alive_timeout_ms", nullptr, nullptr, 1, 3600000,
          "idle keep-alive connections close after this", &s.keep_alive_timeout_ms),
      num("server", "max_body_bytes", "SOFTGRASP_MAX_BODY_BYTES", nullptr, 1, kMaxBytes,
          "largest request body", &s.limits.max_body_bytes),
      num("server", "max_header_bytes", nullptr, nullptr, 256, 1 << 20, "largest header block",
          &s.limits.max_header_bytes),
      num("server", "max_uri_bytes", nullptr, nullptr, 64, 1 << 20, "longest request target",
          &s.limits.max_uri_bytes),
      num("camera", "fx", nullptr, nullptr, 1e-6, 1e7, "default focal length x, pixels", &cam.fx),
      num("camera", "fy", nullptr, nullptr, 1e-6, 1e7, "default focal length y, pixels", &cam.fy),
      num("camera", "cx", nullptr, nullptr, -1e7, 1e7, "default principal point x, pixels",
          &cam.cx),
      num("camera", "cy", nullptr, nullptr, -1e7, 1e7, "default principal point y, pixels",
          &cam.cy),
      num("camera", "width", nullptr, nullptr, 1, 1e6, "default image width, pixels", &cam.width),
      num("camera", "height", nullptr, nullptr, 1, 1e6, "default image height, pixels",
          &cam.height),
      mm("gripper", "opening_stroke_mm", nullptr, nullptr, 1, 1000,
         "widest distance between the inner finger faces", &g.opening_stroke_m),
      mm("gripper", "finger_width_mm", nullptr, nullptr, 0.5, 500,
         "finger size across the closing axis", &g.finger_width_m),
      mm("gripper", "finger_thickness_mm", nullptr, nullptr, 0.5, 500,
         "finger size along the closing axis", &g.finger_thickness_m),
      mm("gripper", "finger_length_mm", nullptr, nullptr, 1, 1000,
         "how far the fingers reach below the palm", &g.finger_length_m),
      num("fge", "num_angles", nullptr, nullptr, 1, 180, "closing-axis angles searched",
          &f.num_angles),
      num("fge", "height_step_m", nullptr, nullptr, 0.001, 0.5, "height between slices",
          &f.height_step_m),
      num("fge", "num_height_steps", nullptr, nullptr, 1, max_steps,
          "slices searched in one batch from the top", &f.num_height_steps),
      num("fge", "grip_depth_m", nullptr, nullptr, 0.0, 0.5,
          "how far below the contact the fingertips go", &f.grip_depth_m),
      num("fge", "min_object_area_px", nullptr, nullptr, 1, 1e8, "smallest contact region kept",
          &f.min_object_area_px),
      num("fge", "floor_clearance_m", nullptr, nullptr, 0.0, 0.5,
          "fingertips stay this far above the floor", &f.floor_clearance_m),
      num("fge", "seam_step_m", nullptr, nullptr, 0.001, 1.0,
          "height step that separates touching surfaces", &f.seam_step_m),
      num("fge", "top_k", nullptr, nullptr, 1, 100, "grasps answered at most", &f.top_k),
      num("fge", "nms_radius_px", nullptr, nullptr, 0, 10000,
          "grasp centres closer than this are one grasp", &f.nms_radius_px),
      num("depth", "png_unit_m", nullptr, nullptr, 1e-6, 1.0, "metres per 16-bit PNG count",
          &c.png_unit_m),
      num("depth", "max_image_pixels", "SOFTGRASP_MAX_IMAGE_PIXELS", nullptr, 1, 1e10,
          "largest image, checked before decoding", &c.max_image_pixels),
      num("depth", "min_depth_m", "SOFTGRASP_MIN_DEPTH_M", nullptr, 0.0, 100.0,
          "minimum working distance: nearer surfaces are obstacles only", &c.min_depth_m),
      num("fractals", "max_points", nullptr, nullptr, 100, 1e6, "POST /v1/fractals points cap",
          &c.max_fractal_points),
      num("fractals", "max_attempts", nullptr, nullptr, 1, 1e7,
          "IFS draws before a fractal request gives up", &c.max_fractal_attempts),
      num("meshes", "max_triangles", nullptr, nullptr, 4, 1e7,
          "POST /v1/meshes/grasps upload cap (413 above it)", &c.max_mesh_triangles),
      num("meshes", "max_quality_evaluations", nullptr, nullptr, 1, 1e8,
          "POST /v1/meshes/grasps num_grasps x robust_samples cap",
          &c.max_mesh_quality_evaluations),
      text("web", "root", "SOFTGRASP_WEB_ROOT", "--web-root", Text::kString,
           "the built web page (default: ../web next to the executable's folder)",
           String(&c.web_root)),
      text("models", "stiffness", "SOFTGRASP_STIFFNESS_MODEL", "--stiffness-model", Text::kString,
           "pix2stiffness model file, or none (default: the shipped ../models/pix2stiffness.pt)",
           String(&c.stiffness_model)),
      text("models", "segmentation", "SOFTGRASP_SEGMENTATION_MODEL", "--segmentation-model",
           Text::kString,
           "segmentation model file, or none for the PCL baseline (default: the shipped "
           "../models/segmentation.pt)",
           String(&c.segmentation_model)),
      text("models", "gqcnn", "SOFTGRASP_GQCNN_MODEL", "--gqcnn-model", Text::kString,
           "GQ-CNN model file for strategy=gqcnn, or none (default: the shipped "
           "../models/gqcnn.pt)",
           String(&c.gqcnn_model)),
      num("models", "torch_threads", "SOFTGRASP_TORCH_THREADS", "--torch-threads", 0, 256,
          "threads of a model's forward pass; 0 = one per CPU", &c.torch_threads),
      text("robot", "enabled", "SOFTGRASP_ROBOT_ENABLED", nullptr, Text::kBool,
           "serve the robot endpoints (docs/robot-api.md)", Bool(&r.enabled)),
      num("robot", "domain_id", "SOFTGRASP_ROBOT_DOMAIN_ID", nullptr, 0, 232, "DDS domain",
          &r.domain_id),
      text("robot", "dds_config", "SOFTGRASP_ROBOT_DDS_CONFIG", nullptr, Text::kString,
           "Cyclone DDS XML or file URIs", String(&r.dds_config)),
      text("robot", "tokens", "SOFTGRASP_ROBOT_TOKENS", nullptr, Text::kTokenList,
           "bearer tokens (the variable: comma-separated)", Tokens(&r.tokens)),
      text("robot", "workspace", nullptr, nullptr, Text::kNone,
           "{frame_id, min_m, max_m}: poses outside are refused", WorkspaceBox(&r.workspace)),
      num("robot", "command_timeout_s", "SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S", nullptr, 0.1, 86400,
          "no result this long after acceptance: timed_out", &r.command_timeout_s),
      text("robot", "journal_dir", "SOFTGRASP_ROBOT_JOURNAL_DIR", nullptr, Text::kString,
           "folder of the command journal", String(&r.journal_dir)),
      num("robot", "retention_s", nullptr, nullptr, 1, 3.2e8,
          "finished commands are remembered this long", &r.retention_s),
      num("robot", "retention_max_commands", nullptr, nullptr, 1, 1e9,
          "finished commands remembered at most", &r.retention_max_commands),
      num("robot", "default_force_n", nullptr, nullptr, 0.01, 1000,
          "closing force when a request gives none", &r.default_force_n),
  };
}

// SOFTGRASP_ROBOT_TOKENS="t1,t2": empty items are ignored; a bad token is named by position only.
core::Result<json> ParseTokenList(const std::string& text, const std::string& name) {
  json tokens = json::array();
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    std::string token = text.substr(start, end - start);
    while (!token.empty() && (token.back() == ' ' || token.back() == '\t')) token.pop_back();
    while (!token.empty() && (token.front() == ' ' || token.front() == '\t')) token.erase(0, 1);
    if (!token.empty()) {
      if (std::string p = TokenProblem(token); !p.empty()) {
        return MakeError(ErrorCode::kInvalidArgument,
                         name + " item " + std::to_string(tokens.size() + 1) + " " + p, name);
      }
      tokens.push_back(std::move(token));
    }
    start = end + 1;
  }
  return tokens;
}

// The text of an environment variable or a flag as the JSON value its setting takes.
core::Result<json> FromText(const Entry& e, const std::string& text, const std::string& name) {
  switch (e.text) {
    case Text::kNumber: {
      char* end = nullptr;
      errno = 0;
      const double v = std::strtod(text.c_str(), &end);
      if (text.empty() || errno != 0 || end != text.c_str() + text.size() || !std::isfinite(v)) {
        return MakeError(ErrorCode::kInvalidArgument,
                         name + " must be a number, got '" + text + "'", name);
      }
      return json(v);
    }
    case Text::kBool:
      if (text == "1" || text == "true" || text == "yes" || text == "on") return json(true);
      if (text == "0" || text == "false" || text == "no" || text == "off") return json(false);
      return MakeError(ErrorCode::kInvalidArgument,
                       name + " must be true or false, got '" + text + "'", name);
    case Text::kTokenList:
      return ParseTokenList(text, name);
    case Text::kString:
    case Text::kNone:
      break;
  }
  return json(text);
}

core::Result<ServiceConfig> ApplyText(ServiceConfig config, const std::string& setting_name,
                                      const std::string& text, bool flag) {
  for (Entry& e : Table(config)) {
    const char* name = flag ? e.setting.flag : e.setting.env;
    if (name == nullptr || setting_name != name) continue;
    auto value = FromText(e, text, setting_name);
    if (!value.ok()) return value.error();
    if (const std::string problem = e.access.set(value.value()); !problem.empty()) {
      return MakeError(ErrorCode::kInvalidArgument, setting_name + " " + problem, setting_name);
    }
    return config;
  }
  return MakeError(ErrorCode::kInternal, "no setting named " + setting_name, setting_name);
}

core::Result<std::string> ReadConfigFile(const std::string& path) {
  auto text = cli::ReadFile(path);
  if (!text.ok()) {
    return MakeError(ErrorCode::kInvalidArgument, "config file: " + text.error().message, "config");
  }
  return text;
}

}  // namespace

std::vector<Setting> Settings() {
  ServiceConfig scratch;
  std::vector<Setting> out;
  for (const Entry& e : Table(scratch)) out.push_back(e.setting);
  return out;
}

Setting SettingOf(const std::string& section, const std::string& key) {
  for (const Setting& s : Settings()) {
    if (section == s.section && key == s.key) return s;
  }
  throw std::invalid_argument("no setting " + section + "." + key);
}

core::Result<ServiceConfig> ApplyConfigJson(ServiceConfig config, const std::string& json_text) {
  const json doc = json::parse(json_text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return MakeError(ErrorCode::kInvalidArgument, "config must be a JSON object", "config");
  }
  std::vector<Entry> table = Table(config);
  for (const auto& [section_name, section] : doc.items()) {
    bool known_section = false;
    for (const Entry& e : table) known_section = known_section || section_name == e.setting.section;
    if (!known_section) {
      return MakeError(ErrorCode::kInvalidArgument, "unknown config section '" + section_name + "'",
                       section_name);
    }
    if (!section.is_object()) {
      return MakeError(ErrorCode::kInvalidArgument, section_name + " must be an object",
                       section_name);
    }
    for (const auto& [key, value] : section.items()) {
      const std::string field = section_name + "." + key;
      Entry* entry = nullptr;
      for (Entry& e : table) {
        if (section_name == e.setting.section && key == e.setting.key) entry = &e;
      }
      if (entry == nullptr) {
        return MakeError(ErrorCode::kInvalidArgument, "unknown config key '" + field + "'", field);
      }
      if (const std::string problem = entry->access.set(value); !problem.empty()) {
        return MakeError(ErrorCode::kInvalidArgument, field + " " + problem, field);
      }
    }
  }
  return config;
}

core::Result<ServiceConfig> ApplyEnvironment(ServiceConfig config) {
  for (const Setting& s : Settings()) {
    if (s.env == nullptr) continue;
    const char* text = std::getenv(s.env);
    if (text == nullptr) continue;
    auto applied = ApplyText(std::move(config), s.env, text, /*flag=*/false);
    if (!applied.ok()) return applied.error();
    config = std::move(applied).value();
  }
  return config;
}

core::Result<CommandLine> ParseCommandLine(const std::vector<std::string>& args) {
  CommandLine out;
  cli::Args parsed(args);
  if (parsed.Flag("--help") || parsed.Flag("-h")) {
    out.help = true;
    return out;
  }
  std::string config_file;
  parsed.Text("--config", &config_file);
  std::vector<std::pair<std::string, std::string>> flags;  // in the table's order
  for (const Setting& s : Settings()) {
    std::string value;
    if (s.flag != nullptr && parsed.Text(s.flag, &value)) flags.emplace_back(s.flag, value);
  }
  if (auto problem = parsed.Finish()) return *problem;
  ServiceConfig config;
  if (!config_file.empty()) {
    auto text = ReadConfigFile(config_file);
    if (!text.ok()) return text.error();
    auto applied = ApplyConfigJson(config, text.value());
    if (!applied.ok()) return applied.error();
    config = std::move(applied).value();
  }
  auto env = ApplyEnvironment(std::move(config));
  if (!env.ok()) return env.error();
  config = std::move(env).value();
  for (const auto& [flag, text] : flags) {
    auto applied = ApplyText(std::move(config), flag, text, /*flag=*/true);
    if (!applied.ok()) return applied.error();
    config = std::move(applied).value();
  }
  out.config = std::move(config);
  return out;
}

std::string UsageText() {
  std::ostringstream os;
  os << "usage: softgrasp-server [--config FILE]";
  for (const Setting& s : Settings()) {
    if (s.flag != nullptr) os << " [" << s.flag << " VALUE]";
  }
  os << "\n  --config FILE  a JSON file of the sections below (docs/configuration.md)\n";
  for (const Setting& s : Settings()) {
    if (s.flag != nullptr) os << "  " << s.flag << "  " << s.help << "\n";
  }
  os << "  Environment:\n";
  for (const Setting& s : Settings()) {
    if (s.env != nullptr)
      os << "    " << s.env << "  " << s.section << "." << s.key << ": " << s.help << "\n";
  }
  os << "  Precedence: flags > environment > config file > defaults (docs/configuration.md).\n";
  return os.str();
}

std::string ConfigToJson(const ServiceConfig& config) {
  ServiceConfig copy = config;
  json j = json::object();
  for (const Entry& e : Table(copy)) j[e.setting.section][e.setting.key] = e.access.get();
  j["robot"]["tokens_configured"] = config.robot.tokens.size();
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

std::string DefaultGqcnnModel(const std::string& executable_path) {
  return ShippedModel(executable_path, "gqcnn.pt");
}

}  // namespace softgrasp::config
