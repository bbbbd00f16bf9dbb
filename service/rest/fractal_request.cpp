#include "service/rest/fractal_request.h"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

namespace softgrasp::rest {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

core::Error FieldError(const std::string& field, const std::string& message) {
  return MakeError(ErrorCode::kInvalidArgument, field + " " + message, field);
}

// An integer in [min, max] (JSON numbers with no fractional part count as integers).
core::Result<long long> Integer(const json& v, const std::string& field, long long min,
                                long long max) {
  if (!v.is_number() || !std::isfinite(v.get<double>()) ||
      v.get<double>() != std::floor(v.get<double>())) {
    return FieldError(field, "must be an integer");
  }
  const double x = v.get<double>();
  if (x < static_cast<double>(min) || x > static_cast<double>(max)) {
    return FieldError(field,
                      "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return static_cast<long long>(x);
}

core::Result<double> Number(const json& v, const std::string& field) {
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    return FieldError(field, "must be a number");
  return v.get<double>();
}

core::Result<mesh::MeshFormat> ParseFormat(const json& v, bool* stats_only) {
  if (!v.is_string()) return FieldError("format", "must be a string");
  const std::string s = v.get<std::string>();
  *stats_only = s == "json";
  if (*stats_only) return mesh::MeshFormat::kObj;
  if (const auto format = mesh::MeshFormatFromName(s)) return *format;
  return FieldError("format",
                    "must be one of json, obj, ply, ply_ascii, ply_binary, stl, stl_ascii, "
                    "stl_binary");
}

core::Result<bool> ApplyMaps(const json& v, mesh::FractalParams& p) {
  if (v.is_array()) {
    if (v.size() != 2) return FieldError("maps", "must be N or [min, max]");
    auto lo = Integer(v[0], "maps", 1, 32);
    auto hi = Integer(v[1], "maps", 1, 32);
    if (!lo.ok()) return lo.error();
    if (!hi.ok()) return hi.error();
    if (lo.value() > hi.value()) return FieldError("maps", "min must not exceed max");
    p.min_maps = static_cast<int>(lo.value());
    p.max_maps = static_cast<int>(hi.value());
    return true;
  }
  auto n = Integer(v, "maps", 1, 32);
  if (!n.ok()) return n.error();
  p.min_maps = p.max_maps = static_cast<int>(n.value());
  return true;
}

core::Result<bool> ApplyScale(const json& v, mesh::FractalParams& p) {
  if (!v.is_object()) return FieldError("scale", "must be an object {opening_mm, fit_fraction}");
  for (const auto& [key, value] : v.items()) {
    const std::string field = "scale." + key;
    auto x = Number(value, field);
    if (!x.ok()) return x.error();
    if (key == "opening_mm") {
      if (x.value() <= 0 || x.value() > 2000) return FieldError(field, "must be in (0, 2000]");
      p.gripper_opening_m = x.value() / 1000.0;
    } else if (key == "fit_fraction") {
      if (x.value() <= 0 || x.value() > 1) return FieldError(field, "must be in (0, 1]");
      p.fit_fraction = x.value();
    } else {
      return FieldError(field, "is not a known key (opening_mm, fit_fraction)");
    }
  }
  return true;
}

}  // namespace

core::Result<FractalRequest> ParseFractalRequest(std::string_view body,
                                                 const config::ServiceConfig& config) {
  FractalRequest out;
  out.params.max_attempts = config.max_fractal_attempts;
  const json doc = body.empty() ? json::object() : json::parse(body, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) {
    return MakeError(ErrorCode::kInvalidArgument, "the body must be a JSON object", "body");
  }
  mesh::FractalParams& p = out.params;
  for (const auto& [key, value] : doc.items()) {
    core::Result<bool> applied = true;
    if (key == "seed") {
      if (!value.is_number_unsigned() &&
          !(value.is_number_integer() && value.get<long long>() >= 0)) {
        return FieldError("seed", "must be a non-negative integer");
      }
      p.seed = value.get<std::uint64_t>();
    } else if (key == "maps") {
      applied = ApplyMaps(value, p);
    } else if (key == "points") {
      auto n = Integer(value, "points", 100, config.max_fractal_points);
      if (!n.ok()) return n.error();
      p.num_points = static_cast<int>(n.value());
    } else if (key == "sigma") {
      auto x = Number(value, "sigma");
      if (!x.ok()) return x.error();
      if (x.value() < 0 || x.value() > 0.2) return FieldError("sigma", "must be in [0, 0.2]");
      p.sigma = x.value();
    } else if (key == "alpha") {
      auto x = Number(value, "alpha");
      if (!x.ok()) return x.error();
      if (x.value() <= 0 || x.value() > 1000) return FieldError("alpha", "must be in (0, 1000]");
      p.alpha = x.value();
    } else if (key == "scale") {
      applied = ApplyScale(value, p);
    } else if (key == "format") {
      auto f = ParseFormat(value, &out.stats_only);
      if (!f.ok()) return f.error();
      out.format = f.value();
    } else {
      return FieldError(key,
                        "is not a known key (seed, maps, points, sigma, alpha, scale, format)");
    }
    if (!applied.ok()) return applied.error();
  }
  if (auto invalid = mesh::ValidateFractalParams(p)) return *invalid;
  return out;
}

std::string FractalFileName(const FractalRequest& request) {
  char alpha[32];
  std::snprintf(alpha, sizeof alpha, "%g", request.params.alpha);
  return "fractal-seed" + std::to_string(request.params.seed) + "-alpha" + alpha + "." +
         mesh::MeshFileExtension(request.format);
}

}  // namespace softgrasp::rest
