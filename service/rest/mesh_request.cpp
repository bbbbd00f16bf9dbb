#include "service/rest/mesh_request.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <utility>

namespace softgrasp::rest {
namespace {

using core::ErrorCode;
using core::MakeError;

struct MeshOption {
  double min, max;
  bool integer;
  std::function<void(MeshGraspRequest&, double)> apply;
};

// A gripper size in millimetres with the configuration setting's limits.
MeshOption GripperMm(const char* key, double mesh::GripperBoxes::*box_m) {
  const config::Setting s = config::SettingOf("gripper", key);
  return {s.min, s.max, false, [box_m](MeshGraspRequest& r, double v) {
            r.analysis.gripper.*box_m = core::MetresFromMm(v);
          }};
}

MeshOption Mm(double min_mm, double max_mm, double mesh::GripperBoxes::*box_m) {
  return {min_mm, max_mm, false,
          [box_m](MeshGraspRequest& r, double v) { r.analysis.gripper.*box_m = v * 1e-3; }};
}

const std::map<std::string, MeshOption>& Options() {
  using G = mesh::GripperBoxes;
  static const std::map<std::string, MeshOption> options = {
      {"opening_stroke_mm", GripperMm("opening_stroke_mm", &G::opening_m)},
      {"finger_width_mm", GripperMm("finger_width_mm", &G::finger_width_m)},
      {"finger_thickness_mm", GripperMm("finger_thickness_mm", &G::finger_thickness_m)},
      {"finger_length_mm", GripperMm("finger_length_mm", &G::finger_length_m)},
      {"fingertip_depth_mm", Mm(0, 100, &G::fingertip_depth_m)},
      {"palm_thickness_mm", Mm(0.1, 200, &G::palm_thickness_m)},
      {"friction_coefficient",
       {0, 5, false, [](MeshGraspRequest& r, double v) { r.analysis.friction_coefficient = v; }}},
      {"num_grasps",
       {1, 1000, true,
        [](MeshGraspRequest& r, double v) { r.analysis.num_grasps = static_cast<int>(v); }}},
      {"robust_samples",
       {0, 200, true,
        [](MeshGraspRequest& r, double v) { r.analysis.robust_samples = static_cast<int>(v); }}},
      {"seed",
       {0, 4294967295.0, true,
        [](MeshGraspRequest& r, double v) { r.analysis.seed = static_cast<std::uint64_t>(v); }}},
      {"min_pose_probability",
       {0, 0.999, false,
        [](MeshGraspRequest& r, double v) { r.analysis.min_pose_probability = v; }}},
      {"approach_distance_mm",
       {0, 1000, false,
        [](MeshGraspRequest& r, double v) { r.analysis.approach_distance_m = v * 1e-3; }}},
      {"table_clearance_mm",
       {0, 100, false,
        [](MeshGraspRequest& r, double v) { r.analysis.table_clearance_m = v * 1e-3; }}},
      {"max_approach_angle_deg",
       {0, 90, false,
        [](MeshGraspRequest& r, double v) {
          r.analysis.max_approach_table_angle_rad = v * std::numbers::pi / 180.0;
        }}},
      {"rescale_min_extent_mm",
       {0.1, 10000, false,
        [](MeshGraspRequest& r, double v) { r.rescale_min_extent_m = v * 1e-3; }}},
      {"pose",
       {0, 1000, true,
        [](MeshGraspRequest& r, double v) { r.preview_pose = static_cast<int>(v); }}},
      {"draw",
       {0, 100, true,
        [](MeshGraspRequest& r, double v) { r.preview_grasps = static_cast<int>(v); }}},
      {"size_px",
       {16, 4096, true,
        [](MeshGraspRequest& r, double v) { r.preview_size_px = static_cast<int>(v); }}},
  };
  return options;
}

// Query parameters and form fields merged (form fields win); the mesh bytes. Any other body is
// the file itself whatever its Content-Type says (curl --data-binary labels it a url-encoded
// form): the format is sniffed from the bytes.
core::Result<std::pair<FieldValues, std::string>> Collect(const http::Request& request) {
  FieldValues values;
  for (const auto& [key, value] : request.query) values[key] = value;
  const std::string content_type(request.header("Content-Type").value_or(""));
  std::optional<std::string> mesh;
  if (content_type.rfind("multipart/form-data", 0) == 0) {
    http::MultipartResult form = http::ParseMultipart(content_type, request.body);
    if (!form.ok()) return MakeError(ErrorCode::kInvalidArgument, form.error, "body");
    for (auto& part : form.parts) {
      if (part.name == "mesh") {
        mesh = std::move(part.data);
      } else {
        values[part.name] = std::move(part.data);
      }
    }
  } else if (content_type.rfind("application/json", 0) == 0) {
    return MakeError(ErrorCode::kUnsupportedFormat,
                     "send the mesh file (OBJ, PLY or STL) as the raw body or as the "
                     "multipart/form-data part 'mesh'; got '" +
                         content_type + "'",
                     "Content-Type");
  } else {
    mesh = request.body;
  }
  if (!mesh || mesh->empty()) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "a mesh file (OBJ, PLY or STL) is required: the raw body or the multipart "
                     "part 'mesh'",
                     "mesh");
  }
  return std::make_pair(std::move(values), std::move(*mesh));
}

}  // namespace

core::Result<MeshGraspRequest> ParseMeshGraspRequest(const http::Request& request,
                                                     const config::ServiceConfig& config) {
  auto collected = Collect(request);
  if (!collected.ok()) return collected.error();
  auto& [fields, bytes] = collected.value();
  MeshGraspRequest out;
  out.mesh_bytes = std::move(bytes);
  out.analysis.gripper = mesh::GripperBoxes::From(config.default_gripper);
  out.analysis.friction_coefficient = config.default_gripper.friction_coefficient;

  for (const auto& [key, text] : fields) {
    if (key == "unit" || key == "format") continue;
    const auto option = Options().find(key);
    if (option == Options().end()) {
      return MakeError(ErrorCode::kInvalidArgument, "unknown field '" + key + "'", key);
    }
    auto v = ParseNumber(key, text, option->second.min, option->second.max);
    if (!v.ok()) return v.error();
    if (option->second.integer && v.value() != std::floor(v.value())) {
      return MakeError(ErrorCode::kInvalidArgument, key + " must be an integer, got " + text, key);
    }
    option->second.apply(out, v.value());
  }
  auto unit = ParseChoice<double, 2>(fields, "unit", 1.0, {"m", "mm"}, {1.0, 0.001});
  if (!unit.ok()) return unit.error();
  out.unit_scale_m = unit.value();
  out.unit = out.unit_scale_m == 1.0 ? "m" : "mm";
  const mesh::GripperBoxes& g = out.analysis.gripper;
  if (g.fingertip_depth_m >= g.finger_length_m) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "fingertip_depth_mm must be less than finger_length_mm", "fingertip_depth_mm");
  }
  const long long evaluations =
      static_cast<long long>(out.analysis.num_grasps) * std::max(1, out.analysis.robust_samples);
  if (evaluations > config.max_mesh_quality_evaluations) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "num_grasps x robust_samples is " + std::to_string(evaluations) +
                         ", more than this server's max_mesh_quality_evaluations (" +
                         std::to_string(config.max_mesh_quality_evaluations) + ")",
                     "robust_samples");
  }
  auto output = ResolveOutput(request, fields);
  if (!output.ok()) return output.error();
  out.output = output.value();
  return out;
}

}  // namespace softgrasp::rest
