#pragma once
/// Reads a POST /v1/meshes/grasps request: the mesh file (raw body, or the multipart part
/// "mesh") and the analysis options (query parameters or form fields). Errors name the field.

#include <optional>
#include <string>

#include "service/config/config.h"
#include "service/core/status.h"
#include "service/http/message.h"
#include "service/mesh_grasps/mesh_grasp_analysis.h"
#include "service/rest/form_fields.h"

namespace softgrasp::rest {

struct MeshGraspRequest {
  std::string mesh_bytes;
  /// Metres per file unit: "unit" = m (1, default) or mm (0.001).
  double unit_scale_m = 1.0;
  std::string unit = "m";
  /// "rescale_min_extent_mm": scale the mesh so its smallest principal extent is this (Dex-Net
  /// sets 40 mm so objects fit its gripper); unset keeps the size.
  std::optional<double> rescale_min_extent_m;
  /// Gripper (opening_stroke_mm, finger_width_mm, finger_thickness_mm, finger_length_mm from the
  /// configuration's gripper; fingertip_depth_mm, palm_thickness_mm), friction_coefficient,
  /// num_grasps, robust_samples, seed, min_pose_probability, approach_distance_mm,
  /// table_clearance_mm, max_approach_angle_deg.
  mesh::MeshGraspOptions analysis;
  OutputFormat output = OutputFormat::kJson;
  /// PNG answers: the stable pose drawn ("pose", default 0 = the most probable), how many of its
  /// usable grasps ("draw", default 10) and the image size ("size_px", default 480).
  int preview_pose = 0;
  int preview_grasps = 10;
  int preview_size_px = 480;
};

/// Also refuses (400, field robust_samples) num_grasps x max(1, robust_samples) above the
/// configuration's max_mesh_quality_evaluations; the triangle cap is applied when decoding.
core::Result<MeshGraspRequest> ParseMeshGraspRequest(const http::Request& request,
                                                     const config::ServiceConfig& config);

}  // namespace softgrasp::rest
