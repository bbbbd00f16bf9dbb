#include "sim/dataset/user_objects.h"

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "service/cli/args.h"
#include "service/cli/files.h"
#include "service/mesh/mesh_io.h"
#include "sim/catalogue/catalogue.h"

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;

/// The whole file; a failure is an invalid argument naming `field` (the path came from the user).
core::Result<std::string> ReadUserFile(const std::filesystem::path& path,
                                       const std::string& field) {
  auto bytes = cli::ReadFile(path);
  if (!bytes.ok()) return MakeError(ErrorCode::kInvalidArgument, bytes.error().message, field);
  return bytes;
}

// Welds vertices with exactly equal coordinates (meshes exported as triangle soups, one vertex
// per face corner), keeping the first occurrence and its stiffness. Returns the old -> new map.
std::vector<int> WeldExactDuplicates(mesh::TriangleMesh* mesh) {
  std::map<std::array<double, 3>, int> first;
  std::vector<int> remap(mesh->vertices.size());
  std::vector<std::array<double, 3>> kept;
  for (std::size_t i = 0; i < mesh->vertices.size(); ++i) {
    const auto [it, inserted] = first.emplace(mesh->vertices[i], static_cast<int>(kept.size()));
    if (inserted) kept.push_back(mesh->vertices[i]);
    remap[i] = it->second;
  }
  for (auto& face : mesh->faces) {
    for (int& index : face) index = remap[static_cast<std::size_t>(index)];
  }
  mesh->vertices = std::move(kept);
  return remap;
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
    double k = 0;
    if (cli::ParseNumber(tail, &k)) {
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
  auto bytes = ReadUserFile(spec.mesh_path, "mesh_path");
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
    auto text = ReadUserFile(spec.stiffness_path, "stiffness_path");
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
  mesh::TriangleMesh welded = std::move(mesh).value();
  const std::size_t file_vertices = welded.vertices.size();
  const std::vector<int> remap = WeldExactDuplicates(&welded);
  if (!vertex_stiffness.empty()) {
    if (vertex_stiffness.size() != file_vertices) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "vertex_stiffness has " + std::to_string(vertex_stiffness.size()) +
                           " scores for " + std::to_string(file_vertices) + " vertices",
                       "vertex_stiffness");
    }
    std::vector<float> welded_stiffness(welded.vertices.size(), -1.0f);
    for (std::size_t i = 0; i < remap.size(); ++i) {
      float& s = welded_stiffness[static_cast<std::size_t>(remap[i])];
      if (s < 0.0f) s = vertex_stiffness[i];
    }
    vertex_stiffness = std::move(welded_stiffness);
  }
  if (welded.vertices.size() != file_vertices) {
    shape["welded_vertices"] = file_vertices - welded.vertices.size();
  }
  return MakeMeshObject(std::move(welded), std::move(vertex_stiffness), spec.stiffness,
                        spec.density_kg_m3, "user", shape);
}

}  // namespace softgrasp::sim
