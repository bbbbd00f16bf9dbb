#include "service/rest/config.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

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

Setter String(std::string* target) {
  return [=](const json& v) -> std::string {
    if (!v.is_string()) return "must be a string";
    *target = v.get<std::string>();
    return {};
  };
}

constexpr double kMaxBytes = 4.0 * 1024 * 1024 * 1024;

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
        {"max_connections", Number(&s.max_connections, 1, 100000)},
        {"read_timeout_ms", Number(&s.read_timeout_ms, 1, 3600000)},
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
       {{"opening_stroke_mm", Number(&g.opening_stroke_mm, 1, 1000)},
        {"finger_width_mm", Number(&g.finger_width_mm, 0.5, 500)},
        {"finger_thickness_mm", Number(&g.finger_thickness_mm, 0.5, 500)},
        {"finger_length_mm", Number(&g.finger_length_mm, 1, 1000)}}},
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
        {"max_image_pixels", Number(&c.max_image_pixels, 1, 1e10)}}},
      {"fractals",
       {{"max_points", Number(&c.max_fractal_points, 100, 1e6)},
        {"max_attempts", Number(&c.max_fractal_attempts, 1, 1e7)}}},
      {"web", {{"root", String(&c.web_root)}}},
  };
}

core::Result<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return MakeError(ErrorCode::kInvalidArgument, "cannot read config file " + path, "config");
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
  struct IntVar {
    const char* name;
    std::function<void(long long)> set;
    long long min, max;
  };
  const IntVar vars[] = {
      {"SOFTGRASP_PORT", [&](long long v) { config.server.port = static_cast<uint16_t>(v); }, 0,
       65535},
      {"SOFTGRASP_WORKERS", [&](long long v) { config.server.num_workers = static_cast<int>(v); }, 1,
       256},
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
  return config;
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
        a == "--web-root") {
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
  if (const auto host = flags.find("--host"); host != flags.end()) config.server.host = host->second;
  if (const auto web = flags.find("--web-root"); web != flags.end()) config.web_root = web->second;
  for (const char* name : {"--port", "--workers"}) {
    const auto flag = flags.find(name);
    if (flag == flags.end()) continue;
    auto value = ParseInteger(flag->second.c_str(), name);
    if (!value.ok()) return value.error();
    const long long v = value.value();
    if (std::string(name) == "--port") {
      if (v < 0 || v > 65535) return MakeError(ErrorCode::kInvalidArgument, "--port must be in [0, 65535]", name);
      config.server.port = static_cast<uint16_t>(v);
    } else {
      if (v < 1 || v > 256) return MakeError(ErrorCode::kInvalidArgument, "--workers must be in [1, 256]", name);
      config.server.num_workers = static_cast<int>(v);
    }
  }
  out.config = config;
  return out;
}

std::string UsageText() {
  return "usage: softgrasp-server [--host HOST] [--port PORT] [--workers N] [--config FILE]\n"
         "                        [--web-root DIR]\n"
         "  --port 0 picks a free port; the chosen address is printed as\n"
         "  'listening on http://HOST:PORT'. --web-root: the built web page served at GET /\n"
         "  (default: ../web next to the executable's folder). Environment: SOFTGRASP_HOST,\n"
         "  SOFTGRASP_PORT, SOFTGRASP_WORKERS, SOFTGRASP_MAX_BODY_BYTES,\n"
         "  SOFTGRASP_MAX_IMAGE_PIXELS, SOFTGRASP_WEB_ROOT.\n"
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
        {"read_timeout_ms", s.read_timeout_ms},
        {"keep_alive_timeout_ms", s.keep_alive_timeout_ms},
        {"max_body_bytes", s.limits.max_body_bytes},
        {"max_header_bytes", s.limits.max_header_bytes},
        {"max_uri_bytes", s.limits.max_uri_bytes}}},
      {"camera",
       {{"fx", cam.fx}, {"fy", cam.fy}, {"cx", cam.cx}, {"cy", cam.cy}, {"width", cam.width},
        {"height", cam.height}}},
      {"gripper",
       {{"opening_stroke_mm", g.opening_stroke_mm},
        {"finger_width_mm", g.finger_width_mm},
        {"finger_thickness_mm", g.finger_thickness_mm},
        {"finger_length_mm", g.finger_length_mm}}},
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
      {"depth", {{"png_unit_m", c.png_unit_m}, {"max_image_pixels", c.max_image_pixels}}},
      {"fractals", {{"max_points", c.max_fractal_points}, {"max_attempts", c.max_fractal_attempts}}},
      {"web", {{"root", c.web_root}}},
  };
  return j.dump();
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

}  // namespace softgrasp::rest
