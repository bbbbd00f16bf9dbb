#include "service/mesh_grasps/antipodal.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

namespace softgrasp::mesh {
namespace {

using core::ErrorCode;
using core::MakeError;

constexpr double kPi = 3.14159265358979323846;
// Rays start this far past a surface point so they do not hit its own triangle.
constexpr double kSurfaceOffsetM = 1e-7;

Eigen::Vector3d Vertex(const TriangleMesh& mesh, int index) {
  const auto& v = mesh.vertices[static_cast<std::size_t>(index)];
  return {v[0], v[1], v[2]};
}

// A unit vector orthogonal to the unit vector n.
Eigen::Vector3d Orthogonal(const Eigen::Vector3d& n) {
  Eigen::Index least = 0;
  n.cwiseAbs().minCoeff(&least);
  return n.cross(Eigen::Vector3d::Unit(least)).normalized();
}

std::optional<core::Error> CheckParams(const AntipodalParams& p) {
  const auto bad = [](const char* field, const std::string& what) {
    return MakeError(ErrorCode::kInvalidArgument, std::string(field) + " " + what, field);
  };
  if (!(p.friction_coefficient >= 0.0) || !std::isfinite(p.friction_coefficient)) {
    return bad("friction_coefficient", "must be a finite number >= 0");
  }
  if (!(p.max_width_m > 0.0) || !std::isfinite(p.max_width_m)) {
    return bad("max_width_m", "must be a finite number > 0");
  }
  if (!(p.min_contact_distance_m >= 0.0) || !(p.min_contact_distance_m < p.max_width_m)) {
    return bad("min_contact_distance_m", "must be in [0, max_width_m)");
  }
  if (p.target_num_grasps < 1) return bad("target_num_grasps", "must be >= 1");
  if (p.max_surface_points < 1) return bad("max_surface_points", "must be >= 1");
  if (!(p.min_grasp_distance_m >= 0.0) || !std::isfinite(p.min_grasp_distance_m)) {
    return bad("min_grasp_distance_m", "must be a finite number >= 0");
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::pair<Contact, Contact>> CloseJaws(const raycast::MeshRaycaster& caster,
                                                     const Eigen::Vector3d& center_m,
                                                     const Eigen::Vector3d& axis,
                                                     double max_width_m) {
  const Eigen::Vector3d unit = axis.normalized();
  const double half = max_width_m / 2.0;
  // The jaw starting on the `side` of the centre, travelling towards it.
  const auto touch = [&](double side) -> std::optional<Contact> {
    const Eigen::Vector3d direction = -side * unit;
    const auto hit = caster.Cast(center_m - half * direction, direction, half);
    // A hit on the inside of a face: the jaw started inside the object.
    if (!hit || hit->normal_w.dot(direction) >= 0.0) return std::nullopt;
    return Contact{hit->point_w, -hit->normal_w};
  };
  auto a = touch(+1.0);
  if (!a) return std::nullopt;
  auto b = touch(-1.0);
  if (!b) return std::nullopt;
  return std::make_pair(*a, *b);
}

double GraspDistance(const JawGrasp& a, const JawGrasp& b) {
  const double cos_angle = std::min(1.0, std::abs(a.axis.dot(b.axis)));
  return (a.center_m - b.center_m).norm() + 0.05 * std::acos(cos_angle) / (kPi / 2.0);
}

core::Result<std::vector<JawGrasp>> SampleAntipodalGrasps(const TriangleMesh& mesh,
                                                          const raycast::MeshRaycaster& caster,
                                                          const AntipodalParams& params) {
  if (auto error = CheckParams(params)) return *error;
  // Triangles by area, for uniform surface points.
  std::vector<double> areas;
  areas.reserve(mesh.faces.size());
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d v0 = Vertex(mesh, f[0]);
    areas.push_back(0.5 * (Vertex(mesh, f[1]) - v0).cross(Vertex(mesh, f[2]) - v0).norm());
  }
  std::vector<JawGrasp> kept;
  if (areas.empty() || !(*std::max_element(areas.begin(), areas.end()) > 0.0)) return kept;
  std::mt19937_64 rng(params.seed);
  std::discrete_distribution<std::size_t> pick_face(areas.begin(), areas.end());
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double mu = params.friction_coefficient;

  for (int attempt = 0; attempt < params.max_surface_points &&
                        static_cast<int>(kept.size()) < params.target_num_grasps;
       ++attempt) {
    const auto& f = mesh.faces[pick_face(rng)];
    const Eigen::Vector3d v0 = Vertex(mesh, f[0]);
    const Eigen::Vector3d e1 = Vertex(mesh, f[1]) - v0;
    const Eigen::Vector3d e2 = Vertex(mesh, f[2]) - v0;
    double s = unit(rng), t = unit(rng);
    if (s + t > 1.0) {  // fold the square onto the triangle
      s = 1.0 - s;
      t = 1.0 - t;
    }
    const Eigen::Vector3d point = v0 + s * e1 + t * e2;
    const Eigen::Vector3d outward = e1.cross(e2).normalized();
    const double r = mu * unit(rng);
    const double theta = 2.0 * kPi * unit(rng);
    const Eigen::Vector3d t1 = Orthogonal(outward);
    const Eigen::Vector3d t2 = outward.cross(t1);
    const Eigen::Vector3d axis =
        (-outward + r * (std::cos(theta) * t1 + std::sin(theta) * t2)).normalized();
    if (!axis.allFinite()) continue;  // a degenerate triangle

    // The opposite surface along the axis, from inside: the grasp is centred between the two.
    const auto exit =
        caster.Cast(point, axis, params.max_width_m + kSurfaceOffsetM, kSurfaceOffsetM);
    if (!exit) continue;
    const Eigen::Vector3d center = 0.5 * (point + exit->point_w);
    const auto contacts = CloseJaws(caster, center, axis, params.max_width_m);
    if (!contacts) continue;
    JawGrasp g;
    g.a = contacts->first;
    g.b = contacts->second;
    g.width_m = (g.a.point_m - g.b.point_m).norm();
    if (g.width_m < params.min_contact_distance_m || g.width_m > params.max_width_m) continue;
    if (!ForceClosure(g.a, g.b, mu)) continue;
    g.center_m = 0.5 * (g.a.point_m + g.b.point_m);
    g.axis = (g.a.point_m - g.b.point_m).normalized();
    const bool covered = std::any_of(kept.begin(), kept.end(), [&](const JawGrasp& k) {
      return GraspDistance(g, k) < params.min_grasp_distance_m;
    });
    if (!covered) kept.push_back(g);
  }
  return kept;
}

}  // namespace softgrasp::mesh
