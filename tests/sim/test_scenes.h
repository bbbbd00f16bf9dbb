#pragma once
/// Analytic test geometry for the simulator tests: icospheres, SimObjects, poses and a table
/// (boxes: tests/support/box_mesh.h).

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "sim/scene/scene.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::sim::test_scenes {

/// An icosphere of radius r: the icosahedron, each face split in four `subdivisions` times, every
/// vertex pushed onto the sphere. Counter-clockwise seen from outside.
inline mesh::TriangleMesh IcosphereMesh(double radius_m, int subdivisions) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      const int index = static_cast<int>(v.size()) - 1;
      midpoint.emplace(key, index);
      return index;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& tri : f) {
      const int ab = mid(tri[0], tri[1]);
      const int bc = mid(tri[1], tri[2]);
      const int ca = mid(tri[2], tri[0]);
      next.push_back({tri[0], ab, ca});
      next.push_back({tri[1], bc, ab});
      next.push_back({tri[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    f = std::move(next);
  }
  mesh::TriangleMesh out;
  for (const auto& p : v)
    out.vertices.push_back({radius_m * p.x(), radius_m * p.y(), radius_m * p.z()});
  out.faces = f;
  return out;
}

inline std::shared_ptr<const SimObject> MakeObject(mesh::TriangleMesh mesh, float stiffness) {
  auto object = std::make_shared<SimObject>();
  object->category = "user";
  object->vertex_stiffness.assign(mesh.vertices.size(), stiffness);
  object->mesh_o = std::move(mesh);
  return object;
}

inline Eigen::Isometry3d Translation(double x, double y, double z) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(x, y, z);
  return pose;
}

/// A table larger than any test camera's view (so every pixel of an overhead view hits it).
inline Support BigTable(double size_m = 6.0) {
  Support support;
  support.kind = Support::Kind::kTable;
  support.inner_size_x_m = size_m;
  support.inner_size_y_m = size_m;
  support.ground_size_m = size_m;
  return support;
}

}  // namespace softgrasp::sim::test_scenes
