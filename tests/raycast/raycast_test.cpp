#include "service/raycast/raycast.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "tests/support/box_mesh.h"

namespace softgrasp::raycast {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A 40 x 60 x 20 mm box, turned 30 degrees about z and moved to (0.1, -0.2, 0.5) m.
struct PlacedBox {
  mesh::TriangleMesh mesh = testing::CentredBoxMesh({0.02, 0.03, 0.01});
  Eigen::Isometry3d world_from_box = [] {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translate(Eigen::Vector3d(0.1, -0.2, 0.5));
    t.rotate(Eigen::AngleAxisd(kPi / 6, Eigen::Vector3d::UnitZ()));
    return t;
  }();
};

TEST(MeshRaycaster, HitsTheBoxWhereGeometrySaysWithExactDistanceAndBarycentrics) {
  const PlacedBox box;
  const std::vector<Surface> surfaces{{7, &box.mesh, box.world_from_box}};
  auto caster = MeshRaycaster::Build(surfaces);
  ASSERT_TRUE(caster.ok()) << caster.error().message;

  // Straight down onto the top face (z = 0.51 m) from 1 m above a point inside its footprint.
  const Eigen::Vector3d target_w = box.world_from_box * Eigen::Vector3d(0.005, -0.012, 0.01);
  const Eigen::Vector3d origin_w = target_w + Eigen::Vector3d(0, 0, 1.0);
  const auto hit = caster.value().Cast(origin_w, Eigen::Vector3d(0, 0, -3.0), 2.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->distance_m, 1.0, 1e-12);
  EXPECT_NEAR((hit->point_w - target_w).norm(), 0.0, 1e-12);
  EXPECT_NEAR((hit->normal_w - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
  EXPECT_EQ(hit->surface, 0);
  EXPECT_EQ(hit->surface_id, 7);
  // The top face is triangle 2 or 3 (BoxMesh's order: -z, +z, ...); its barycentrics rebuild the
  // point from the placed vertices.
  EXPECT_TRUE(hit->face == 2 || hit->face == 3) << hit->face;
  const auto& face = box.mesh.faces[static_cast<std::size_t>(hit->face)];
  Eigen::Vector3d rebuilt = Eigen::Vector3d::Zero();
  double weight_sum = 0;
  for (int k = 0; k < 3; ++k) {
    const auto& v = box.mesh.vertices[static_cast<std::size_t>(face[k])];
    rebuilt += hit->barycentric[k] * (box.world_from_box * Eigen::Vector3d(v[0], v[1], v[2]));
    EXPECT_GE(hit->barycentric[k], 0.0);
    weight_sum += hit->barycentric[k];
  }
  EXPECT_NEAR(weight_sum, 1.0, 1e-15);
  EXPECT_NEAR((rebuilt - target_w).norm(), 0.0, 1e-12);

  // Too short, or starting beyond the box: nothing; the same ray through the box is occluded.
  EXPECT_FALSE(caster.value().Cast(origin_w, -Eigen::Vector3d::UnitZ(), 0.9).has_value());
  EXPECT_FALSE(caster.value().Cast(origin_w, -Eigen::Vector3d::UnitZ(), 2.0, 1.1).has_value());
  EXPECT_TRUE(caster.value().Occluded(origin_w, -Eigen::Vector3d::UnitZ(), 2.0));
  EXPECT_FALSE(caster.value().Occluded(origin_w, Eigen::Vector3d::UnitZ(), 2.0));
}

TEST(MeshRaycaster, TheNearerOfTwoSurfacesAnswersAndStreamsAgreeWithSingleRays) {
  const mesh::TriangleMesh low = testing::BoxMesh({-0.1, -0.1, 0.0}, {0.1, 0.1, 0.02});
  const mesh::TriangleMesh high = testing::BoxMesh({-0.02, -0.02, 0.02}, {0.02, 0.02, 0.06});
  const std::vector<Surface> surfaces{{1, &low, Eigen::Isometry3d::Identity()},
                                      {2, &high, Eigen::Isometry3d::Identity()}};
  auto caster = MeshRaycaster::Build(surfaces);
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  const Eigen::Vector3d camera_w(0.0, 0.0, 0.5);
  std::vector<Eigen::Vector3d> directions;
  for (int i = 0; i < 150; ++i) {
    const double x = -0.15 + 0.3 * i / 149.0;
    directions.emplace_back(x, 0.3 * x, -0.5);
  }
  std::vector<std::optional<Hit>> streamed(directions.size());
  caster.value().CastMany(camera_w, directions, 2.0, streamed);
  int on_high = 0, on_low = 0, missed = 0;
  for (std::size_t i = 0; i < directions.size(); ++i) {
    const auto single = caster.value().Cast(camera_w, directions[i], 2.0);
    ASSERT_EQ(single.has_value(), streamed[i].has_value()) << i;
    if (!single) {
      ++missed;
      continue;
    }
    EXPECT_EQ(single->distance_m, streamed[i]->distance_m);
    EXPECT_EQ(single->surface_id, streamed[i]->surface_id);
    // Heights say which box answered: the tall one's top at 0.06 m, the flat one's at 0.02 m.
    const double expected_z = single->surface_id == 2 ? 0.06 : 0.02;
    EXPECT_NEAR(single->point_w.z(), expected_z, 1e-12);
    (single->surface_id == 2 ? on_high : on_low) += 1;
  }
  EXPECT_GT(on_high, 0);
  EXPECT_GT(on_low, 0);
  EXPECT_GT(missed, 0);
}

TEST(MeshRaycaster, RefusesMeshesItCannotCastAgainst) {
  const auto field_of = [](const std::vector<Surface>& surfaces) {
    auto caster = MeshRaycaster::Build(surfaces);
    EXPECT_FALSE(caster.ok());
    return caster.ok() ? std::string() : caster.error().field;
  };
  const mesh::TriangleMesh good = testing::CentredBoxMesh({0.01, 0.01, 0.01});
  mesh::TriangleMesh bad_index = good;
  bad_index.faces[3][1] = 8;
  mesh::TriangleMesh not_finite = good;
  not_finite.vertices[5][2] = std::numeric_limits<double>::quiet_NaN();
  const mesh::TriangleMesh empty;
  Eigen::Isometry3d broken_pose = Eigen::Isometry3d::Identity();
  broken_pose.translation().x() = std::numeric_limits<double>::infinity();
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();

  EXPECT_EQ(field_of({{1, &good, identity}, {2, &bad_index, identity}}), "surfaces[1]");
  EXPECT_EQ(field_of({{1, &not_finite, identity}}), "surfaces[0]");
  EXPECT_EQ(field_of({{1, &empty, identity}}), "surfaces[0]");
  EXPECT_EQ(field_of({{1, nullptr, identity}}), "surfaces[0]");
  EXPECT_EQ(field_of({{1, &good, broken_pose}}), "surfaces[0]");

  // Rays the caller got wrong are a precondition failure, not a silent miss.
  const std::vector<Surface> one{{1, &good, identity}};
  auto caster = MeshRaycaster::Build(one);
  ASSERT_TRUE(caster.ok());
  EXPECT_THROW(caster.value().Cast(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1.0),
               std::invalid_argument);
  EXPECT_THROW(caster.value().Cast(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1.0, 2.0),
               std::invalid_argument);
}

// A camera 0.5 m above a 40 x 60 x 20 mm box (top at z = 0.02 m) looking straight down sees
// the top at depth 0.48 m exactly, over the pixels whose centres project inside the top face;
// just outside it a ray may still meet a side wall, lower down, and beyond that nothing.
// CastPixelRays reports the same pixels; on the top face the cosine of the ray with the face's
// normal (the optical axis) is 1 / |ray|.
TEST(CameraRays, RenderDepthSeesTheBoxTopAtItsExactDepthAndFootprint) {
  const mesh::TriangleMesh box = testing::BoxMesh({-0.02, -0.03, 0.0}, {0.02, 0.03, 0.02});
  const std::vector<Surface> surfaces{{1, &box, Eigen::Isometry3d::Identity()}};
  auto caster = MeshRaycaster::Build(surfaces);
  ASSERT_TRUE(caster.ok());
  core::Camera camera;
  camera.width = 64;
  camera.height = 48;
  camera.fx = camera.fy = 300.0;
  camera.cx = 31.5;
  camera.cy = 23.5;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // optical axis -z, image y = -y
  world_from_camera.translation() = Eigen::Vector3d(0, 0, 0.5);
  const core::DepthImage depth = RenderDepth(caster.value(), camera, world_from_camera);
  ASSERT_EQ(depth.width(), 64);
  ASSERT_EQ(depth.height(), 48);
  int expected_hits = 0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      // The pixel centre's ray meets z = 0.02 (0.48 m from the camera) at this point of W.
      const double x = (u - camera.cx) / camera.fx * 0.48;
      const double y = -(v - camera.cy) / camera.fy * 0.48;
      const bool inside = std::abs(x) < 0.02 && std::abs(y) < 0.03;
      const bool clear = std::abs(std::abs(x) - 0.02) > 1e-9 && std::abs(std::abs(y) - 0.03) > 1e-9;
      if (!clear) continue;  // a ray grazing an edge: either answer is right
      if (inside) {
        ++expected_hits;
        EXPECT_NEAR(depth.depth_m(v, u), 0.48f, 1e-6) << u << "," << v;
      } else if (std::abs(x) > 0.021 * 0.5 / 0.48 || std::abs(y) > 0.031 * 0.5 / 0.48) {
        EXPECT_TRUE(std::isnan(depth.depth_m(v, u))) << u << "," << v;  // past the base too
      } else if (!std::isnan(depth.depth_m(v, u))) {
        EXPECT_GT(depth.depth_m(v, u), 0.48f) << u << "," << v;  // a side wall
      }
    }
  }
  EXPECT_GT(expected_hits, 800);  // about 25 x 37.5 px
  int reported = 0;
  CastPixelRays(caster.value(), camera, world_from_camera, [&](const PixelHit& pixel) {
    ++reported;
    if (pixel.hit->normal_w.z() < 0.5) return;  // a side wall
    const double ray_norm =
        Eigen::Vector3d((pixel.u - camera.cx) / camera.fx, (pixel.v - camera.cy) / camera.fy, 1.0)
            .norm();
    EXPECT_NEAR(pixel.cos_incidence, 1.0 / ray_norm, 1e-12);
    EXPECT_NEAR(pixel.depth_m, 0.48, 1e-12);
    EXPECT_NEAR(pixel.hit->distance_m, 0.48 * ray_norm, 1e-12);
  });
  EXPECT_EQ(reported, cv::countNonZero(depth.depth_m == depth.depth_m));
  core::Camera broken = camera;
  broken.fx = 0.0;
  EXPECT_THROW(RenderDepth(caster.value(), broken, world_from_camera), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::raycast
