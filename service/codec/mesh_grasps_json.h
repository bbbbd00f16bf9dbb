#pragma once
/// The JSON form of a mesh grasp analysis (mesh::MeshGraspAnalysis): what POST /v1/meshes/grasps
/// answers and `softgrasp-sim mesh-grasps` writes, one form for both (docs/mesh-grasps.md).
///
/// {"center_of_mass_m": [x, y, z],
///  "stable_poses": [{"index", "probability", "table_from_object": Pose, "face_normal_o",
///                    "com_height_m", "num_face_vertices"}],
///  "grasps": [{"rank", "sample_index", "center_m", "axis", "width_m",
///              "contacts": [{"point_m", "inward_normal"} x 2], "ferrari_canny",
///              "robust_ferrari_canny" (null when not computed),
///              "poses": [{"pose", "aligned", "approach_table_angle_deg", "collision_free",
///                         "approach_offset_deg" (null when none is free), "approach_o",
///                         "table_from_gripper": Pose}]}],
///  "timing_ms": {"stable_poses", "sampling", "quality", "collisions", "total"}}
/// Vectors in the mesh frame O unless named otherwise; Pose is codec::ToJson(Pose). The gripper
/// frame G has x = closing axis, z = approach (core::Grasp's convention).

#include <nlohmann/json.hpp>

#include "service/mesh_grasps/mesh_grasp_analysis.h"

namespace softgrasp::codec {

nlohmann::json ToJson(const mesh::MeshGraspAnalysis& analysis);

/// The same without "timing_ms": equal for equal inputs and seeds (what determinism tests and
/// golden comparisons use).
nlohmann::json ToJsonWithoutTiming(const mesh::MeshGraspAnalysis& analysis);

/// An analysed file: ToJson(analysis) plus "mesh": {"format", "vertices", "triangles",
/// "unit_scale_m", "rescale_factor", "scale_applied" (prepared = file coordinates x this),
/// "extents_m", "volume_m3", "repairs", "warnings"} and "timing_ms" gaining "decode" and "prepare".
nlohmann::json ToJson(const mesh::MeshFileAnalysis& file);

}  // namespace softgrasp::codec
