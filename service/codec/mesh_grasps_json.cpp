#include "service/codec/mesh_grasps_json.h"

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <numbers>

#include "service/codec/json_codec.h"

namespace softgrasp::codec {
namespace {

using nlohmann::json;

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

double Deg(double rad) { return rad * 180.0 / std::numbers::pi; }

Pose PoseOf(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
            const char* frame) {
  const Eigen::Quaterniond q(rotation);
  Pose pose;
  pose.frame = frame;
  pose.position_m = {translation.x(), translation.y(), translation.z()};
  // One sign for the double cover: w >= 0.
  const double s = q.w() < 0.0 ? -1.0 : 1.0;
  pose.orientation_wxyz = {s * q.w(), s * q.x(), s * q.y(), s * q.z()};
  return pose;
}

json ContactJson(const mesh::Contact& c) {
  return {{"point_m", Vec(c.point_m)}, {"inward_normal", Vec(c.inward_normal)}};
}

json GraspInPoseJson(const mesh::GraspInPose& p, std::size_t pose_index,
                     const mesh::StablePose& pose, const mesh::JawGrasp& grasp) {
  const Eigen::Isometry3d object_from_gripper = mesh::GripperPose(grasp, p.approach_o);
  const Eigen::Matrix3d rotation = pose.table_from_object_rotation * object_from_gripper.linear();
  const Eigen::Vector3d translation =
      pose.table_from_object_rotation * object_from_gripper.translation() +
      pose.table_from_object_translation;
  return {{"pose", pose_index},
          {"aligned", p.aligned},
          {"approach_table_angle_deg", Deg(p.approach_table_angle_rad)},
          {"collision_free", p.collision_free},
          {"approach_offset_deg",
           p.approach_offset_rad ? json(Deg(*p.approach_offset_rad)) : json(nullptr)},
          {"approach_o", Vec(p.approach_o)},
          {"table_from_gripper", ToJson(PoseOf(rotation, translation, "table"))}};
}

}  // namespace

json ToJsonWithoutTiming(const mesh::MeshGraspAnalysis& analysis) {
  json poses = json::array();
  for (std::size_t i = 0; i < analysis.poses.size(); ++i) {
    const mesh::StablePose& p = analysis.poses[i];
    poses.push_back(
        {{"index", i},
         {"probability", p.probability},
         {"table_from_object",
          ToJson(PoseOf(p.table_from_object_rotation, p.table_from_object_translation, "table"))},
         {"face_normal_o", Vec(p.face_normal_object)},
         {"com_height_m", p.com_height_m},
         {"num_face_vertices", p.face_vertex_indices.size()}});
  }
  json grasps = json::array();
  for (std::size_t rank = 0; rank < analysis.grasps.size(); ++rank) {
    const mesh::AnalysedGrasp& g = analysis.grasps[rank];
    json in_poses = json::array();
    for (std::size_t i = 0; i < g.poses.size() && i < analysis.poses.size(); ++i) {
      in_poses.push_back(GraspInPoseJson(g.poses[i], i, analysis.poses[i], g.grasp));
    }
    grasps.push_back({{"rank", rank},
                      {"sample_index", g.sample_index},
                      {"center_m", Vec(g.grasp.center_m)},
                      {"axis", Vec(g.grasp.axis)},
                      {"width_m", g.grasp.width_m},
                      {"contacts", json::array({ContactJson(g.grasp.a), ContactJson(g.grasp.b)})},
                      {"ferrari_canny", g.ferrari_canny},
                      {"robust_ferrari_canny",
                       g.robust_ferrari_canny ? json(*g.robust_ferrari_canny) : json(nullptr)},
                      {"poses", std::move(in_poses)}});
  }
  json no_grasp;  // null when some grasp is usable
  if (const auto& why = analysis.no_grasp) {
    no_grasp = {{"reason", mesh::NoGraspReasonName(why->reason)},
                {"message", why->message},
                {"narrowest_width_m", why->narrowest_width_m},
                {"needed_stroke_m", why->needed_stroke_m ? json(*why->needed_stroke_m) : json()}};
  }
  return {{"center_of_mass_m", Vec(analysis.center_of_mass_m)},
          {"stable_poses", std::move(poses)},
          {"grasps", std::move(grasps)},
          {"no_grasp", std::move(no_grasp)}};
}

json ToJson(const mesh::MeshGraspAnalysis& analysis) {
  json j = ToJsonWithoutTiming(analysis);
  const mesh::MeshGraspTiming& t = analysis.timing;
  j["timing_ms"] = {{"stable_poses", t.stable_poses_ms},
                    {"sampling", t.sampling_ms},
                    {"quality", t.quality_ms},
                    {"collisions", t.collisions_ms},
                    {"total", t.total_ms}};
  return j;
}

json ToJson(const mesh::MeshFileAnalysis& file) {
  json j = ToJson(file.analysis);
  const mesh::PreparedMesh& p = file.prepared;
  j["mesh"] = {{"format", mesh::MeshFormatName(file.format)},
               {"vertices", p.mesh.vertices.size()},
               {"triangles", p.mesh.faces.size()},
               {"unit_scale_m", p.unit_scale_m},
               {"rescale_factor", p.rescale_factor},
               {"scale_applied", p.scale_applied},
               {"extents_m", p.extents_m},
               {"volume_m3", p.volume_m3},
               {"repairs", p.repairs},
               {"warnings", p.warnings}};
  j["timing_ms"]["decode"] = file.decode_ms;
  j["timing_ms"]["prepare"] = file.prepare_ms;
  return j;
}

}  // namespace softgrasp::codec
