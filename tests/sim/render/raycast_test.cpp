#include "sim/render/raycast.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <thread>
#include <vector>

#include "service/mesh/mesh_check.h"
#include "tests/sim/test_scenes.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::sim {
namespace {

using softgrasp::testing::CentredBoxMesh;
using test_scenes::BigTable;
using test_scenes::IcosphereMesh;
using test_scenes::MakeObject;
using test_scenes::Translation;

constexpr double kInf = std::numeric_limits<double>::infinity();

// A rotated box floating above a big table, so it can be seen from all six sides.
struct FloatingBox {
  Eigen::Vector3d half_m{0.05, 0.04, 0.03};
  Eigen::Isometry3d world_from_box = Eigen::Isometry3d::Identity();
  SimScene scene;

  FloatingBox() {
    world_from_box = Translation(0.02, -0.03, 0.30) *
                     Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 2, 3).normalized());
    scene.support = BigTable();
    scene.objects.push_back({7, MakeObject(CentredBoxMesh(half_m), 0.7f), world_from_box});
  }
};

TEST(SceneRaycaster, BoxFromSixDirectionsGivesDistanceNormalInstanceAndStiffness) {
  const FloatingBox box;
  ASSERT_TRUE(mesh::CheckMesh(CentredBoxMesh(box.half_m)).ok());
  auto raycaster = SceneRaycaster::Build(box.scene);
  ASSERT_TRUE(raycaster.ok()) << raycaster.error().message;
  const Eigen::Vector3d centre_w = box.world_from_box.translation();
  for (int axis = 0; axis < 3; ++axis) {
    for (double sign : {-1.0, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "axis " << axis << " sign " << sign);
      const Eigen::Vector3d outward_w = sign * box.world_from_box.linear().col(axis);
      // Aim off the face centre (not through a triangle's diagonal) with a non-unit direction.
      const Eigen::Vector3d offset_w =
          0.3 * box.half_m((axis + 1) % 3) * box.world_from_box.linear().col((axis + 1) % 3);
      const Eigen::Vector3d origin_w = centre_w + offset_w + 0.2 * outward_w;
      const auto hit = raycaster.value().Cast(origin_w, -2.5 * outward_w, 1.0);
      ASSERT_TRUE(hit.has_value());
      EXPECT_NEAR(hit->distance_m, 0.2 - box.half_m(axis), 1e-12);
      EXPECT_TRUE(hit->point_w.isApprox(centre_w + offset_w + box.half_m(axis) * outward_w, 1e-12));
      EXPECT_NEAR((hit->normal_w - outward_w).norm(), 0.0, 1e-12);
      EXPECT_EQ(hit->instance_id, 7);
      EXPECT_EQ(hit->stiffness, 0.7f);
    }
  }
}

TEST(SceneRaycaster, SupportIsInstanceZeroWithZeroStiffnessAndUpwardNormal) {
  SimScene scene;
  scene.support = BigTable(1.0);
  auto raycaster = SceneRaycaster::Build(scene);
  ASSERT_TRUE(raycaster.ok()) << raycaster.error().message;
  const auto hit = raycaster.value().Cast({0.1, 0.2, 0.8}, {0, 0, -1}, kInf);
  ASSERT_TRUE(hit.has_value());
  EXPECT_DOUBLE_EQ(hit->distance_m, 0.8);
  EXPECT_EQ(hit->instance_id, 0);
  EXPECT_EQ(hit->stiffness, 0.0f);
  EXPECT_NEAR((hit->normal_w - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-15);
  // Beside the table: nothing.
  EXPECT_FALSE(raycaster.value().Cast({0.8, 0.0, 0.8}, {0, 0, -1}, kInf).has_value());
  EXPECT_FALSE(raycaster.value().Occluded({0.8, 0.0, 0.8}, {0, 0, -1}, kInf));
}

TEST(SceneRaycaster, MinAndMaxDistanceSelectWhichSurfaceIsHit) {
  // An axis-aligned box, top at z = 0.33, bottom at 0.27, over a table at z = 0.
  SimScene scene;
  scene.support = BigTable();
  scene.objects.push_back(
      {3, MakeObject(CentredBoxMesh({0.05, 0.04, 0.03}), 0.5f), Translation(0, 0, 0.3)});
  auto built = SceneRaycaster::Build(scene);
  ASSERT_TRUE(built.ok()) << built.error().message;
  const SceneRaycaster& raycaster = built.value();
  const Eigen::Vector3d origin_w(0.011, 0.007, 1.0);
  const Eigen::Vector3d down_w(0, 0, -1);

  const auto top = raycaster.Cast(origin_w, down_w, kInf);
  ASSERT_TRUE(top.has_value());
  EXPECT_NEAR(top->distance_m, 0.67, 1e-12);
  EXPECT_NEAR(top->normal_w.z(), 1.0, 1e-12);
  // Starting inside the box: the bottom face from inside, whose outward normal points down.
  const auto bottom = raycaster.Cast(origin_w, down_w, kInf, 0.70);
  ASSERT_TRUE(bottom.has_value());
  EXPECT_NEAR(bottom->distance_m, 0.73, 1e-12);
  EXPECT_NEAR(bottom->normal_w.z(), -1.0, 1e-12);
  EXPECT_EQ(bottom->instance_id, 3);
  // Past the box: the table.
  const auto table = raycaster.Cast(origin_w, down_w, kInf, 0.75);
  ASSERT_TRUE(table.has_value());
  EXPECT_NEAR(table->distance_m, 1.0, 1e-12);
  EXPECT_EQ(table->instance_id, 0);
  EXPECT_FALSE(raycaster.Cast(origin_w, down_w, 0.66).has_value());
  EXPECT_FALSE(raycaster.Cast(origin_w, down_w, 0.95, 0.75).has_value());

  EXPECT_FALSE(raycaster.Occluded(origin_w, down_w, 0.66));
  EXPECT_TRUE(raycaster.Occluded(origin_w, down_w, 0.68));
  EXPECT_TRUE(raycaster.Occluded(origin_w, 5.0 * down_w, 0.68));  // direction is normalised
  EXPECT_FALSE(raycaster.Occluded(origin_w, down_w, 0.95, 0.75));
  EXPECT_TRUE(raycaster.Occluded(origin_w, down_w, 1.05, 0.75));
}

TEST(SceneRaycaster, StiffnessIsTheQuantisedBarycentricInterpolationOfVertexScores) {
  // Bottom vertices 0.2, top vertices 0.9: the side faces ramp linearly in z.
  auto object = std::make_shared<SimObject>();
  object->mesh_o = CentredBoxMesh({0.05, 0.05, 0.05});
  for (const auto& v : object->mesh_o.vertices) {
    object->vertex_stiffness.push_back(v[2] > 0 ? 0.9f : 0.2f);
  }
  SimScene scene;
  scene.support = BigTable();
  scene.objects.push_back({2, object, Translation(0, 0, 0.05)});
  auto raycaster = SceneRaycaster::Build(scene);
  ASSERT_TRUE(raycaster.ok()) << raycaster.error().message;
  // From +x at height fraction h of the side: 0.2 + 0.7 h.
  for (const auto& [fraction, expected] : std::vector<std::pair<double, float>>{
           {0.25, 0.4f}, {0.75, 0.7f}, {0.05, 0.2f}, {0.95, 0.9f}}) {
    const auto hit = raycaster.value().Cast({0.5, 0.013, 0.1 * fraction}, {-1, 0, 0}, kInf);
    ASSERT_TRUE(hit.has_value());
    EXPECT_EQ(hit->instance_id, 2);
    EXPECT_EQ(hit->stiffness, expected) << "height fraction " << fraction;
  }
  const auto top = raycaster.value().Cast({0.01, 0.02, 1.0}, {0, 0, -1}, kInf);
  ASSERT_TRUE(top.has_value());
  EXPECT_EQ(top->stiffness, 0.9f);
}

TEST(SceneRaycaster, SphereHitsAgreeWithTheAnalyticSphereWithinTheChordError) {
  const double radius_m = 0.05;
  const mesh::TriangleMesh sphere = IcosphereMesh(radius_m, 3);
  ASSERT_TRUE(mesh::CheckMesh(sphere).ok());
  SimScene scene;
  scene.support = BigTable();
  const Eigen::Vector3d centre_w(0.01, 0.02, radius_m);
  scene.objects.push_back({1, MakeObject(sphere, 0.4f), Translation(0.01, 0.02, radius_m)});
  auto raycaster = SceneRaycaster::Build(scene);
  ASSERT_TRUE(raycaster.ok()) << raycaster.error().message;
  // Rays from far away straight at the centre: the hit is between the inscribed and the
  // circumscribed radius, and the normal is close to radial.
  for (int i = 0; i < 50; ++i) {
    const double theta = 0.1 + 1.3 * i / 50.0;  // polar angle from +z, staying above the table
    const double phi = 0.7 * i;
    const Eigen::Vector3d radial(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                 std::cos(theta));
    const auto hit = raycaster.value().Cast(centre_w + 0.5 * radial, -radial, kInf);
    ASSERT_TRUE(hit.has_value());
    EXPECT_EQ(hit->instance_id, 1);
    const double r = (hit->point_w - centre_w).norm();
    EXPECT_LE(r, radius_m + 1e-12);
    EXPECT_GE(r, radius_m * 0.99);  // 3 subdivisions: edge angle ~0.16 rad, sagitta < 0.4 %
    EXPECT_GT(hit->normal_w.dot(radial), 0.98);
  }
}

core::Result<SceneRaycaster> BuildWith(std::shared_ptr<SimObject> object, int instance_id = 1) {
  SimScene scene;
  scene.objects.push_back({instance_id, std::move(object), Eigen::Isometry3d::Identity()});
  return SceneRaycaster::Build(scene);
}

std::shared_ptr<SimObject> ValidBox() {
  return std::const_pointer_cast<SimObject>(MakeObject(CentredBoxMesh({0.1, 0.1, 0.1}), 0.5f));
}

void ExpectInvalid(const core::Result<SceneRaycaster>& result, const std::string& field_part) {
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, core::ErrorCode::kInvalidArgument);
  EXPECT_NE(result.error().field.find(field_part), std::string::npos) << result.error().field;
  EXPECT_FALSE(result.error().message.empty());
}

TEST(SceneRaycaster, InvalidScenesAreInvalidArgument) {
  ASSERT_TRUE(BuildWith(ValidBox()).ok());

  auto empty = ValidBox();
  empty->mesh_o = {};
  empty->vertex_stiffness.clear();
  ExpectInvalid(BuildWith(empty), "objects[0].mesh_o");

  auto nan_vertex = ValidBox();
  nan_vertex->mesh_o.vertices[3][1] = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalid(BuildWith(nan_vertex), "mesh_o");

  auto inf_vertex = ValidBox();
  inf_vertex->mesh_o.vertices[0][0] = std::numeric_limits<double>::infinity();
  ExpectInvalid(BuildWith(inf_vertex), "mesh_o");

  auto bad_index = ValidBox();
  bad_index->mesh_o.faces[5][2] = 8;
  ExpectInvalid(BuildWith(bad_index), "mesh_o");
  bad_index->mesh_o.faces[5][2] = -1;
  ExpectInvalid(BuildWith(bad_index), "mesh_o");

  auto short_stiffness = ValidBox();
  short_stiffness->vertex_stiffness.pop_back();
  ExpectInvalid(BuildWith(short_stiffness), "vertex_stiffness");

  auto nan_stiffness = ValidBox();
  nan_stiffness->vertex_stiffness[0] = std::nanf("");
  ExpectInvalid(BuildWith(nan_stiffness), "vertex_stiffness");

  ExpectInvalid(BuildWith(nullptr), "object");
  ExpectInvalid(BuildWith(ValidBox(), 0), "instance_id");
  ExpectInvalid(BuildWith(ValidBox(), 70000), "instance_id");

  SimScene twice;
  twice.objects.push_back({4, ValidBox(), Eigen::Isometry3d::Identity()});
  twice.objects.push_back({4, ValidBox(), Translation(1, 0, 0)});
  ExpectInvalid(SceneRaycaster::Build(twice), "objects[1].instance_id");

  SimScene bad_pose;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  bad_pose.objects.push_back({1, ValidBox(), pose});
  ExpectInvalid(SceneRaycaster::Build(bad_pose), "world_from_object");

  SimScene bad_support;
  bad_support.support.inner_size_x_m = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalid(SceneRaycaster::Build(bad_support), "support");
}

TEST(SceneRaycaster, BrokenRayPreconditionsThrow) {
  auto raycaster = SceneRaycaster::Build(SimScene{});
  ASSERT_TRUE(raycaster.ok());
  const SceneRaycaster& r = raycaster.value();
  const Eigen::Vector3d o(0, 0, 1);
  EXPECT_THROW(r.Cast(o, Eigen::Vector3d::Zero(), 1.0), std::invalid_argument);
  EXPECT_THROW(r.Cast(o, {0, 0, std::nan("")}, 1.0), std::invalid_argument);
  EXPECT_THROW(r.Cast({0, std::nan(""), 0}, {0, 0, -1}, 1.0), std::invalid_argument);
  EXPECT_THROW(r.Cast(o, {0, 0, -1}, 1.0, 2.0), std::invalid_argument);
  EXPECT_THROW(r.Cast(o, {0, 0, -1}, 1.0, -0.1), std::invalid_argument);
  EXPECT_THROW(r.Occluded(o, {0, 0, -1}, std::nan("")), std::invalid_argument);
  EXPECT_NO_THROW(r.Cast(o, {0, 0, -1}, kInf));
}

TEST(SceneRaycaster, MovedRaycasterKeepsWorking) {
  const FloatingBox box;
  auto built = SceneRaycaster::Build(box.scene);
  ASSERT_TRUE(built.ok());
  SceneRaycaster moved = std::move(built).value();
  SceneRaycaster assigned = std::move(moved);
  EXPECT_TRUE(assigned.Occluded({0.02, -0.03, 1.0}, {0, 0, -1}, kInf));
  EXPECT_THROW(moved.Cast({0, 0, 1}, {0, 0, -1}, 1.0),
               std::logic_error);  // NOLINT(bugprone-use-after-move)
}

TEST(SceneRaycaster, CastManyGivesExactlyWhatCastGives) {
  SimScene scene;
  scene.support = BigTable(1.0);
  auto object = std::make_shared<SimObject>();
  object->mesh_o = IcosphereMesh(0.05, 3);
  for (const auto& v : object->mesh_o.vertices)
    object->vertex_stiffness.push_back(v[2] > 0 ? 0.9f : 0.3f);
  scene.objects.push_back({4, object, Translation(0.02, 0.0, 0.05)});
  auto raycaster = SceneRaycaster::Build(scene);
  ASSERT_TRUE(raycaster.ok()) << raycaster.error().message;
  const Eigen::Vector3d origin_w(0.01, -0.02, 0.5);
  std::vector<Eigen::Vector3d> directions_w;
  for (int i = 0; i < 1000; ++i) {  // 1000: not a multiple of the block size
    directions_w.emplace_back(0.9 * std::sin(0.37 * i), 0.9 * std::cos(0.23 * i), -1.0 - 0.001 * i);
  }
  std::vector<std::optional<RayHit>> many(directions_w.size());
  raycaster.value().CastMany(origin_w, directions_w, 0.6, many, 0.05);
  int hits = 0;
  for (std::size_t i = 0; i < directions_w.size(); ++i) {
    const auto one = raycaster.value().Cast(origin_w, directions_w[i], 0.6, 0.05);
    ASSERT_EQ(one.has_value(), many[i].has_value()) << i;
    if (!one) continue;
    ++hits;
    EXPECT_EQ(one->distance_m, many[i]->distance_m);
    EXPECT_EQ(one->point_w, many[i]->point_w);
    EXPECT_EQ(one->normal_w, many[i]->normal_w);
    EXPECT_EQ(one->instance_id, many[i]->instance_id);
    EXPECT_EQ(one->stiffness, many[i]->stiffness);
  }
  EXPECT_GT(hits, 500);
  EXPECT_LT(hits, 1000);  // max distance 0.6 leaves the far table corners out
  std::vector<std::optional<RayHit>> too_few(3);
  EXPECT_THROW(raycaster.value().CastMany(origin_w, directions_w, 1.0, too_few),
               std::invalid_argument);
}

// All hits on a fan of rays, as raw bytes, so equality is bitwise.
std::vector<double> HitFan(const SceneRaycaster& raycaster) {
  std::vector<double> out;
  for (int i = 0; i < 4000; ++i) {
    const double a = 0.37 * i;
    const Eigen::Vector3d direction(0.3 * std::cos(a) * (i % 97) / 97.0,
                                    0.3 * std::sin(a) * (i % 89) / 89.0, -1.0);
    const auto hit = raycaster.Cast({0.0, 0.0, 0.6}, direction, kInf);
    if (!hit) {
      out.push_back(-1.0);
      continue;
    }
    out.insert(out.end(), {hit->distance_m, hit->normal_w.x(), hit->normal_w.y(), hit->normal_w.z(),
                           static_cast<double>(hit->instance_id), hit->stiffness});
  }
  return out;
}

TEST(SceneRaycaster, HitsAreIdenticalAcrossBuildsAndThreads) {
  SimScene scene;
  scene.support = BigTable(1.0);
  for (int k = 0; k < 6; ++k) {
    scene.objects.push_back({k + 1, MakeObject(IcosphereMesh(0.03, 3), 0.1f * (k + 2)),
                             Translation(-0.15 + 0.06 * k, 0.02 * (k % 3), 0.03)});
  }
  auto first = SceneRaycaster::Build(scene);
  auto second = SceneRaycaster::Build(scene);
  ASSERT_TRUE(first.ok() && second.ok());
  const std::vector<double> reference = HitFan(first.value());
  std::vector<double> from_thread;
  std::thread worker([&] { from_thread = HitFan(first.value()); });
  const std::vector<double> rebuilt = HitFan(second.value());
  worker.join();
  ASSERT_EQ(rebuilt.size(), reference.size());
  ASSERT_EQ(from_thread.size(), reference.size());
  EXPECT_EQ(std::memcmp(rebuilt.data(), reference.data(), reference.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(from_thread.data(), reference.data(), reference.size() * sizeof(double)),
            0);
}

}  // namespace
}  // namespace softgrasp::sim
