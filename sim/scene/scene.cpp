#include "sim/scene/scene.h"

#include <algorithm>
#include <cmath>

namespace softgrasp::sim {
namespace {

// Appends an axis-aligned box [lo, hi] as 12 outward triangles.
void AppendBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, mesh::TriangleMesh* out) {
  const int base = static_cast<int>(out->vertices.size());
  for (int i = 0; i < 8; ++i) {
    out->vertices.push_back(
        {(i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z()});
  }
  // Corner index = x + 2y + 4z; each quad listed counter-clockwise seen from outside.
  constexpr int kQuads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : kQuads) {
    out->faces.push_back({base + q[0], base + q[1], base + q[2]});
    out->faces.push_back({base + q[0], base + q[2], base + q[3]});
  }
}

}  // namespace

float QuantizeStiffness(float score) {
  if (std::isnan(score)) return kMinStiffness;
  const float clamped = std::clamp(score, kMinStiffness, kMaxStiffness);
  return std::round(clamped * 10.0f) / 10.0f;
}

const char* SupportKindName(Support::Kind kind) {
  return kind == Support::Kind::kTable ? "table" : "bin";
}

std::vector<SupportBox> SupportBoxes(const Support& s) {
  const double hx = s.inner_size_x_m / 2.0;
  const double hy = s.inner_size_y_m / 2.0;
  const double hg = s.ground_size_m / 2.0;
  if (s.kind == Support::Kind::kTable) {
    return {{{-hg, -hg, -s.thickness_m}, {hg, hg, 0.0}}};
  }
  const double t = s.wall_thickness_m;
  const double z0 = -s.thickness_m;
  const double z1 = s.wall_height_m;
  return {
      {{-hg, -hg, z0 - s.thickness_m}, {hg, hg, z0}},  // the table the bin stands on
      {{-hx, -hy, z0}, {hx, hy, 0.0}},                 // bin floor
      {{-hx - t, -hy - t, z0}, {-hx, hy + t, z1}},     // -x wall, full depth
      {{hx, -hy - t, z0}, {hx + t, hy + t, z1}},       // +x wall, full depth
      {{-hx, -hy - t, z0}, {hx, -hy, z1}},             // -y wall, between the others
      {{-hx, hy, z0}, {hx, hy + t, z1}},               // +y wall
  };
}

mesh::TriangleMesh SupportMesh(const Support& s) {
  mesh::TriangleMesh out;
  for (const SupportBox& box : SupportBoxes(s)) AppendBox(box.min_w, box.max_w, &out);
  return out;
}

const PlacedObject* SimScene::Find(int instance_id) const {
  for (const PlacedObject& p : objects) {
    if (p.instance_id == instance_id) return &p;
  }
  return nullptr;
}

bool SimScene::Remove(int instance_id) {
  const auto it = std::find_if(objects.begin(), objects.end(),
                               [&](const PlacedObject& p) { return p.instance_id == instance_id; });
  if (it == objects.end()) return false;
  objects.erase(it);
  return true;
}

nlohmann::json TransformToJson(const Eigen::Isometry3d& transform) {
  const Eigen::Vector3d t = transform.translation();
  const Eigen::Quaterniond q(transform.rotation());
  return {{"position_m", {t.x(), t.y(), t.z()}}, {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}};
}

nlohmann::json PlacedObjectToJson(const PlacedObject& placed) {
  nlohmann::json j = TransformToJson(placed.world_from_object);
  j["instance_id"] = placed.instance_id;
  j["category"] = placed.object ? placed.object->category : "";
  j["shape"] = placed.object ? placed.object->shape : nlohmann::json::object();
  j["mass_kg"] = placed.object ? placed.object->mass_kg : 0.0;
  return j;
}

nlohmann::json SupportToJson(const Support& s) {
  return {
      {"kind", SupportKindName(s.kind)},  {"inner_size_m", {s.inner_size_x_m, s.inner_size_y_m}},
      {"wall_height_m", s.wall_height_m}, {"wall_thickness_m", s.wall_thickness_m},
      {"thickness_m", s.thickness_m},     {"ground_size_m", s.ground_size_m}};
}

}  // namespace softgrasp::sim
