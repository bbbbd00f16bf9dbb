#include "service/mesh_grasps/gripper_collision.h"

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

namespace softgrasp::mesh {
namespace {

using core::ErrorCode;
using core::MakeError;

bool PositiveFinite(double x) { return std::isfinite(x) && x > 0.0; }

bool ValidBoxes(const GripperBoxes& g) {
  return PositiveFinite(g.opening_m) && PositiveFinite(g.finger_width_m) &&
         PositiveFinite(g.finger_thickness_m) && PositiveFinite(g.finger_length_m) &&
         std::isfinite(g.fingertip_depth_m) && g.fingertip_depth_m >= 0.0 &&
         g.fingertip_depth_m < g.finger_length_m && PositiveFinite(g.palm_thickness_m);
}

/// A unit vector perpendicular to unit `a`.
Eigen::Vector3d AnyPerpendicular(const Eigen::Vector3d& a) {
  Eigen::Index least = 0;
  a.cwiseAbs().minCoeff(&least);
  return a.cross(Eigen::Vector3d::Unit(least)).normalized();
}

/// A box whose z range is [z_back, z_front] and which is centred on (x, 0) across.
BoxInG ZRangeBox(double x_center, double x_half, double y_half, double z_back, double z_front) {
  BoxInG box;
  box.center_m = Eigen::Vector3d(x_center, 0.0, 0.5 * (z_back + z_front));
  box.half_extent_m = Eigen::Vector3d(x_half, y_half, 0.5 * (z_front - z_back));
  return box;
}

}  // namespace

GripperBoxes GripperBoxes::From(const core::Gripper& gripper) {
  GripperBoxes boxes;
  boxes.opening_m = gripper.opening_stroke_m;
  boxes.finger_width_m = gripper.finger_width_m;
  boxes.finger_thickness_m = gripper.finger_thickness_m;
  boxes.finger_length_m = gripper.finger_length_m;
  return boxes;
}

std::vector<BoxInG> SweptGripperBoxes(const GripperBoxes& g, double approach_distance_m) {
  if (!ValidBoxes(g) || !std::isfinite(approach_distance_m) || approach_distance_m < 0.0) {
    throw std::invalid_argument(
        "SweptGripperBoxes: sizes must be positive and finite (fingertip depth in [0, finger "
        "length)), the approach distance >= 0");
  }
  const double tip = g.fingertip_depth_m;
  const double palm_face = tip - g.finger_length_m;  // where the fingers meet the palm
  const double y_half = 0.5 * g.finger_width_m;
  const double jaw_x = 0.5 * g.opening_m + 0.5 * g.finger_thickness_m;
  const double jaw_half = 0.5 * g.finger_thickness_m;
  std::vector<BoxInG> boxes;
  boxes.push_back(ZRangeBox(+jaw_x, jaw_half, y_half, palm_face - approach_distance_m, tip));
  boxes.push_back(ZRangeBox(-jaw_x, jaw_half, y_half, palm_face - approach_distance_m, tip));
  boxes.push_back(ZRangeBox(0.0, 0.5 * g.opening_m + g.finger_thickness_m, y_half,
                            palm_face - g.palm_thickness_m - approach_distance_m, palm_face));
  return boxes;
}

TableInObject TableInObject::Under(const StablePose& pose, double clearance_m) {
  // Table frame: p_t = R p_o + t, the table is z_t < -clearance, i.e. -R.row(2) . p_o > t.z + c.
  TableInObject table;
  table.down_o = -pose.table_from_object_rotation.row(2).transpose();
  table.offset_m = pose.table_from_object_translation.z() + clearance_m;
  return table;
}

TopDownApproach ApproachFromAbove(const JawGrasp& grasp, const StablePose& pose) {
  const Eigen::Vector3d down_o = -pose.table_from_object_rotation.row(2).transpose();
  const Eigen::Vector3d axis = grasp.axis.normalized();
  const Eigen::Vector3d perpendicular = down_o - down_o.dot(axis) * axis;
  TopDownApproach out;
  if (perpendicular.norm() < 1e-9) {
    out.approach_o = AnyPerpendicular(axis);
    out.table_angle_rad = std::numbers::pi / 2.0;
    return out;
  }
  out.approach_o = perpendicular.normalized();
  out.table_angle_rad = std::acos(std::clamp(out.approach_o.dot(down_o), -1.0, 1.0));
  return out;
}

Eigen::Isometry3d GripperPose(const JawGrasp& grasp, const Eigen::Vector3d& approach_o) {
  const Eigen::Vector3d x = grasp.axis.normalized();
  Eigen::Vector3d z = approach_o - approach_o.dot(x) * x;
  z = z.norm() < 1e-12 ? AnyPerpendicular(x) : z.normalized();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = z.cross(x);
  pose.linear().col(2) = z;
  pose.translation() = grasp.center_m;
  return pose;
}

Eigen::Vector3d RotateApproach(const JawGrasp& grasp, const Eigen::Vector3d& approach_o,
                               double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, grasp.axis.normalized()) * approach_o;
}

struct GripperCollisionChecker::Impl {
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> mesh;
  std::vector<BoxInG> boxes_g;
  std::vector<fcl::Boxd> fcl_boxes;
};

core::Result<GripperCollisionChecker> GripperCollisionChecker::Build(const TriangleMesh& mesh_o,
                                                                     const GripperBoxes& gripper,
                                                                     double approach_distance_m) {
  if (mesh_o.vertices.empty() || mesh_o.faces.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, "the mesh has no vertices or no faces", "mesh");
  }
  if (!ValidBoxes(gripper) || !std::isfinite(approach_distance_m) || approach_distance_m < 0.0) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "gripper sizes must be positive and finite, the fingertip depth in [0, "
                     "finger length), the approach distance >= 0",
                     "gripper");
  }
  std::vector<fcl::Vector3d> points;
  points.reserve(mesh_o.vertices.size());
  for (const auto& v : mesh_o.vertices) {
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
      return MakeError(ErrorCode::kInvalidArgument, "a vertex is not finite", "mesh");
    }
    points.emplace_back(v[0], v[1], v[2]);
  }
  const auto num_vertices = static_cast<long long>(points.size());
  std::vector<fcl::Triangle> triangles;
  triangles.reserve(mesh_o.faces.size());
  for (const auto& f : mesh_o.faces) {
    for (const int i : f) {
      if (i < 0 || i >= num_vertices) {
        return MakeError(ErrorCode::kInvalidArgument,
                         "face index " + std::to_string(i) + " is out of range", "mesh");
      }
    }
    triangles.emplace_back(f[0], f[1], f[2]);
  }
  auto impl = std::make_unique<Impl>();
  impl->mesh = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  if (impl->mesh->beginModel(static_cast<int>(triangles.size()), static_cast<int>(points.size())) !=
          fcl::BVH_OK ||
      impl->mesh->addSubModel(points, triangles) != fcl::BVH_OK ||
      impl->mesh->endModel() != fcl::BVH_OK) {
    return MakeError(ErrorCode::kInternal, "FCL could not build the mesh hierarchy", "mesh");
  }
  impl->boxes_g = SweptGripperBoxes(gripper, approach_distance_m);
  for (const BoxInG& box : impl->boxes_g) impl->fcl_boxes.emplace_back(2.0 * box.half_extent_m);
  return GripperCollisionChecker(std::move(impl));
}

GripperCollisionChecker::GripperCollisionChecker(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)) {}
GripperCollisionChecker::GripperCollisionChecker(GripperCollisionChecker&&) noexcept = default;
GripperCollisionChecker& GripperCollisionChecker::operator=(GripperCollisionChecker&&) noexcept =
    default;
GripperCollisionChecker::~GripperCollisionChecker() = default;

bool GripperCollisionChecker::Collides(const Eigen::Isometry3d& object_from_gripper,
                                       const TableInObject* table) const {
  if (!impl_) throw std::logic_error("GripperCollisionChecker::Collides on a moved-from checker");
  const Eigen::Matrix3d& rotation = object_from_gripper.linear();
  // The table first: a box enters the half-space when its deepest corner does, and a corner's
  // depth along `down` is the centre's plus the half extents projected on |down| in G.
  if (table != nullptr) {
    const Eigen::Vector3d down_g = rotation.transpose() * table->down_o;
    for (const BoxInG& box : impl_->boxes_g) {
      const Eigen::Vector3d center_o = object_from_gripper * box.center_m;
      const double reach = box.half_extent_m.dot(down_g.cwiseAbs());
      if (table->down_o.dot(center_o) + reach > table->offset_m) return true;
    }
  }
  const fcl::Transform3d identity = fcl::Transform3d::Identity();
  fcl::CollisionRequestd request;  // one contact is enough: stop at the first overlap
  for (std::size_t i = 0; i < impl_->boxes_g.size(); ++i) {
    fcl::Transform3d object_from_box = fcl::Transform3d::Identity();
    object_from_box.linear() = rotation;
    object_from_box.translation() = object_from_gripper * impl_->boxes_g[i].center_m;
    fcl::CollisionResultd result;
    if (fcl::collide(&impl_->fcl_boxes[i], object_from_box, impl_->mesh.get(), identity, request,
                     result) > 0) {
      return true;
    }
  }
  return false;
}

}  // namespace softgrasp::mesh
