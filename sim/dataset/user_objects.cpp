#include "sim/dataset/user_objects.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "service/mesh/mesh_io.h"
#include "sim/catalogue/catalogue.h"

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;

core::Result<std::string> ReadFile(const std::filesystem::path& path, const std::string& field) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return MakeError(ErrorCode::kInvalidArgument, "cannot read " + path.string(), field);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

core::Result<UserObjectSpec> ParseUserObjectArg(const std::string& arg) {
  UserObjectSpec spec;
  const auto colon = arg.rfind(':');
  if (colon == std::string::npos) {
    spec.mesh_path = arg;
  } else {
    spec.mesh_path = arg.substr(0, colon);
    const std::string tail = arg.substr(colon + 1);
    char* end = nullptr;
    const double k = std::strtod(tail.c_str(), &end);
    if (!tail.empty() && end == tail.c_str() + tail.size()) {
      if (!(k >= kMinStiffness && k <= kMaxStiffness)) {
        return MakeError(ErrorCode::kInvalidArgument, "stiffness must be in [0.1, 1]", "stiffness");
      }
      spec.stiffness = static_cast<float>(k);
    } else {
      spec.stiffness_path = tail;
    }
  }
  if (spec.mesh_path.empty())
    return MakeError(ErrorCode::kInvalidArgument, "empty mesh path", "mesh_path");
  return spec;
}

core::Result<SimObject> LoadUserObject(const UserObjectSpec& spec) {
  auto bytes = ReadFile(spec.mesh_path, "mesh_path");
  if (!bytes.ok()) return bytes.error();
  auto mesh = mesh::ReadMesh(bytes.value());
  if (!mesh.ok()) {
    core::Error e = mesh.error();
    e.message = spec.mesh_path.string() + ": " + e.message;
    e.field = "mesh_path";
    return e;
  }
  std::vector<float> vertex_stiffness;
  nlohmann::json shape = {{"file", spec.mesh_path.filename().string()}};
  if (!spec.stiffness_path.empty()) {
    auto text = ReadFile(spec.stiffness_path, "stiffness_path");
    if (!text.ok()) return text.error();
    const nlohmann::json j =
        nlohmann::json::parse(text.value(), nullptr, /*allow_exceptions=*/false);
    if (!j.is_object() || !j.contains("vertex_stiffness") || !j["vertex_stiffness"].is_array()) {
      return MakeError(
          ErrorCode::kInvalidArgument,
          spec.stiffness_path.string() + ": expected {\"vertex_stiffness\": [numbers]}",
          "stiffness_path");
    }
    for (const auto& s : j["vertex_stiffness"]) {
      if (!s.is_number()) {
        return MakeError(ErrorCode::kInvalidArgument,
                         spec.stiffness_path.string() + ": vertex_stiffness holds a non-number",
                         "stiffness_path");
      }
      vertex_stiffness.push_back(s.get<float>());
    }
    shape["stiffness_file"] = spec.stiffness_path.filename().string();
  } else {
    shape["stiffness"] = spec.stiffness;
  }
  return MakeMeshObject(std::move(mesh).value(), std::move(vertex_stiffness), spec.stiffness,
                        spec.density_kg_m3, "user", shape);
}

}  // namespace softgrasp::sim
