#include "sim/render/render.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>

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

double DegToRad(double deg) { return deg * std::numbers::pi / 180.0; }

/// The camera-frame ray through pixel (u, v)'s centre, on the z = 1 plane.
Eigen::Vector3d RayC(const core::Camera& camera, int u, int v) {
  return {(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0};
}

SceneRaycaster BuildOrDie(const SimScene& scene) {
  auto built = SceneRaycaster::Build(scene);
  if (!built.ok()) throw std::runtime_error(built.error().message);
  return std::move(built).value();
}

bool SameBytes(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && a.isContinuous() && b.isContinuous() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

/// A camera looking down at `height_m`, then pitched about its own x axis and yawed about its y.
Eigen::Isometry3d TiltedPose(const Eigen::Vector3d& position_w, double pitch_deg, double yaw_deg) {
  Eigen::Isometry3d pose = OverheadCameraPose(0.0);
  pose.linear() = pose.linear() * Eigen::AngleAxisd(DegToRad(pitch_deg), Eigen::Vector3d::UnitX()) *
                  Eigen::AngleAxisd(DegToRad(yaw_deg), Eigen::Vector3d::UnitY());
  pose.translation() = position_w;
  return pose;
}

TEST(Sr305Camera, MatchesTheDepthFieldOfViewWithThePrincipalPointAtTheCentre) {
  const core::Camera c = Sr305Camera();
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_DOUBLE_EQ(c.cx, 319.5);
  EXPECT_DOUBLE_EQ(c.cy, 239.5);
  // Outer pixel edges (u = -0.5, u = 639.5) subtend the field of view.
  EXPECT_NEAR(2.0 * std::atan(320.0 / c.fx) * 180.0 / std::numbers::pi, 69.0, 1e-9);
  EXPECT_NEAR(2.0 * std::atan(240.0 / c.fy) * 180.0 / std::numbers::pi, 54.0, 1e-9);
}

TEST(OverheadCameraPose, LooksDownWithImageRightAlongXAndImageDownAlongMinusY) {
  const Eigen::Isometry3d pose = OverheadCameraPose(0.7);
  EXPECT_TRUE(pose.translation().isApprox(Eigen::Vector3d(0, 0, 0.7)));
  EXPECT_TRUE((pose.linear() * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE((pose.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitX()));
  EXPECT_TRUE((pose.linear() * Eigen::Vector3d::UnitY()).isApprox(-Eigen::Vector3d::UnitY()));
  EXPECT_NEAR(pose.linear().determinant(), 1.0, 1e-15);
}

TEST(Render, TableOnlyFromOverheadIsTheCameraHeightEverywhere) {
  SimScene scene;
  scene.support = BigTable();
  const SceneRaycaster raycaster = BuildOrDie(scene);
  RenderOptions options;
  options.world_from_camera = OverheadCameraPose(0.55);
  const RenderedViews views = Render(raycaster, options);
  ASSERT_EQ(views.depth.width(), 640);
  ASSERT_EQ(views.depth.height(), 480);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      ASSERT_EQ(views.depth.depth_m(v, u), 0.55f) << u << "," << v;
      ASSERT_EQ(views.labels(v, u), 0);
      ASSERT_EQ(views.stiffness(v, u), 0.0f);
      ASSERT_EQ(views.deformability(v, u), 0.0f);
    }
  }
}

TEST(Render, TiltedCameraOverAPlaneMatchesTheClosedFormIntersection) {
  SimScene scene;
  scene.support = BigTable();
  const SceneRaycaster raycaster = BuildOrDie(scene);
  RenderOptions options;
  options.world_from_camera = TiltedPose({0.05, -0.1, 0.6}, 25.0, 10.0);
  const RenderedViews views = Render(raycaster, options);
  const Eigen::Matrix3d rotation = options.world_from_camera.linear();
  const double height_m = options.world_from_camera.translation().z();
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      // origin + depth * (R ray_c) meets z = 0: depth = -h / (R ray_c).z.
      const double ray_w_z = (rotation * RayC(options.camera, u, v)).z();
      ASSERT_LT(ray_w_z, 0.0);
      const double expected_m = -height_m / ray_w_z;
      ASSERT_NEAR(views.depth.depth_m(v, u), expected_m, 2e-7 * expected_m) << u << "," << v;
    }
  }
}

TEST(Render, SphereMatchesTheAnalyticSurfaceAndSilhouette) {
  const double radius_m = 0.05;
  const mesh::TriangleMesh sphere = IcosphereMesh(radius_m, 4);
  ASSERT_TRUE(mesh::CheckMesh(sphere).ok());
  // The tessellation lies between the inscribed radius (closest face plane) and the sphere.
  double inscribed_m = radius_m;
  for (const auto& f : sphere.faces) {
    const Eigen::Vector3d a(sphere.vertices[f[0]].data());
    const Eigen::Vector3d b(sphere.vertices[f[1]].data());
    const Eigen::Vector3d c(sphere.vertices[f[2]].data());
    inscribed_m = std::min(inscribed_m, std::abs((b - a).cross(c - a).normalized().dot(a)));
  }
  const double chord_error_m = radius_m - inscribed_m;
  ASSERT_LT(chord_error_m, 1e-4);

  const Eigen::Vector3d centre_w(0.02, -0.03, radius_m);  // resting on the table
  SimScene scene;
  scene.support = BigTable();
  scene.objects.push_back({3, MakeObject(sphere, 0.4f), Translation(0.02, -0.03, radius_m)});
  const SceneRaycaster raycaster = BuildOrDie(scene);
  RenderOptions options;
  options.world_from_camera = OverheadCameraPose(0.55);
  const RenderedViews views = Render(raycaster, options);

  const core::Camera& camera = options.camera;
  const Eigen::Vector3d origin_w = options.world_from_camera.translation();
  const Eigen::Matrix3d rotation = options.world_from_camera.linear();
  // One pixel, as a distance between a ray and the centre, at the sphere.
  const double pixel_m = (centre_w - origin_w).norm() / std::min(camera.fx, camera.fy);
  int inside = 0;
  int depth_checked = 0;
  int outside = 0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector3d ray_c = RayC(camera, u, v);
      const Eigen::Vector3d d_w = (rotation * ray_c).normalized();
      const Eigen::Vector3d to_centre = centre_w - origin_w;
      const double along = to_centre.dot(d_w);
      const double miss_m = std::sqrt(std::max(0.0, to_centre.squaredNorm() - along * along));
      if (miss_m < inscribed_m - pixel_m) {
        ++inside;
        ASSERT_EQ(views.labels(v, u), 3) << u << "," << v;
        ASSERT_EQ(views.stiffness(v, u), 0.4f);
        ASSERT_EQ(views.deformability(v, u), 1.0f - 0.4f);
        const double t = along - std::sqrt(radius_m * radius_m - miss_m * miss_m);
        const Eigen::Vector3d normal = (origin_w + t * d_w - centre_w) / radius_m;
        const double cos_incidence = -normal.dot(d_w);
        if (cos_incidence > 0.5) {
          ++depth_checked;
          // The facet is behind the sphere along the ray by at most chord error / cos.
          const double analytic_m = t / ray_c.norm();
          const double depth_m = views.depth.depth_m(v, u);
          ASSERT_GE(depth_m, analytic_m - 1e-6) << u << "," << v;
          ASSERT_LE(depth_m, analytic_m + chord_error_m / cos_incidence + 1e-6) << u << "," << v;
        }
      } else if (miss_m > radius_m + pixel_m) {
        ++outside;
        ASSERT_EQ(views.labels(v, u), 0) << u << "," << v;
        ASSERT_EQ(views.stiffness(v, u), 0.0f);
        ASSERT_EQ(views.deformability(v, u), 0.0f);
      }
    }
  }
  // About pi (r / 0.5 m * f)^2 ~ 6900 pixels on the sphere.
  EXPECT_GT(inside, 5000);
  EXPECT_GT(depth_checked, 4000);
  EXPECT_GT(outside, 290000);
}

TEST(Render, LabelsAndStiffnessAgreePixelByPixelForSeveralObjects) {
  SimScene scene;
  scene.support = BigTable();
  scene.objects.push_back(
      {5, MakeObject(CentredBoxMesh({0.04, 0.03, 0.02}), 0.3f), Translation(-0.12, 0.05, 0.02)});
  scene.objects.push_back(
      {9, MakeObject(IcosphereMesh(0.04, 3), 0.8f), Translation(0.1, 0.06, 0.04)});
  // A box whose stiffness ramps along its own x axis: 0.2 at x = -hx, 1.0 at x = +hx.
  const Eigen::Vector3d ramp_half_m(0.06, 0.04, 0.025);
  auto ramp = std::make_shared<SimObject>();
  ramp->mesh_o = CentredBoxMesh(ramp_half_m);
  for (const auto& p : ramp->mesh_o.vertices)
    ramp->vertex_stiffness.push_back(p[0] > 0 ? 1.0f : 0.2f);
  const Eigen::Isometry3d world_from_ramp =
      Translation(0.0, -0.08, ramp_half_m.z()) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  scene.objects.push_back({12, ramp, world_from_ramp});

  const SceneRaycaster raycaster = BuildOrDie(scene);
  RenderOptions options;
  options.world_from_camera = OverheadCameraPose(0.5);
  const RenderedViews views = Render(raycaster, options);

  const core::Camera& camera = options.camera;
  const Eigen::Vector3d origin_w = options.world_from_camera.translation();
  const Eigen::Matrix3d rotation = options.world_from_camera.linear();
  std::map<int, int> counts;
  int ramp_top_checked = 0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const int label = views.labels(v, u);
      const float stiffness = views.stiffness(v, u);
      ++counts[label];
      ASSERT_TRUE(label == 0 || label == 5 || label == 9 || label == 12) << label;
      if (label == 0) {
        ASSERT_EQ(stiffness, 0.0f);
        ASSERT_EQ(views.deformability(v, u), 0.0f);
        continue;
      }
      ASSERT_EQ(views.deformability(v, u), 1.0f - stiffness);
      if (label == 5) {
        ASSERT_EQ(stiffness, 0.3f);
      }
      if (label == 9) {
        ASSERT_EQ(stiffness, 0.8f);
      }
      if (label == 12) {
        ASSERT_TRUE(stiffness >= 0.2f && stiffness <= 1.0f) << stiffness;
      }

      // Where the ray meets the ramp's top face (well inside its border), the label is the
      // ramp's and the stiffness is the quantised linear ramp at that point.
      const Eigen::Vector3d ray_c = RayC(camera, u, v);
      const Eigen::Vector3d ray_w = rotation * ray_c;
      const double top_z = 2.0 * ramp_half_m.z();
      const double depth_to_top = (top_z - origin_w.z()) / ray_w.z();  // ray_c has z = 1
      const Eigen::Vector3d p_o = world_from_ramp.inverse() * (origin_w + depth_to_top * ray_w);
      if (std::abs(p_o.x()) > ramp_half_m.x() - 1e-3 ||
          std::abs(p_o.y()) > ramp_half_m.y() - 1e-3) {
        continue;
      }
      ASSERT_EQ(label, 12) << u << "," << v;
      ASSERT_NEAR(views.depth.depth_m(v, u), depth_to_top, 1e-6);
      const double raw = 0.2 + 0.8 * (p_o.x() + ramp_half_m.x()) / (2.0 * ramp_half_m.x());
      const double level_position = raw * 10.0 - std::floor(raw * 10.0);
      if (std::abs(level_position - 0.5) < 1e-3) continue;  // on a rounding boundary
      ++ramp_top_checked;
      ASSERT_EQ(stiffness, QuantizeStiffness(static_cast<float>(raw))) << u << "," << v;
    }
  }
  EXPECT_GT(counts[5], 1000);
  EXPECT_GT(counts[9], 1000);
  EXPECT_GT(counts[12], 2000);
  EXPECT_GT(ramp_top_checked, 2000);
}

// ---- Noise ----

struct NoiseScene {
  SimScene scene;
  NoiseScene() {
    scene.support = BigTable();
    scene.objects.push_back(
        {1, MakeObject(CentredBoxMesh({0.05, 0.04, 0.03}), 0.5f), Translation(0.02, 0.01, 0.03)});
    scene.objects.push_back(
        {2, MakeObject(IcosphereMesh(0.035, 3), 0.2f), Translation(-0.1, -0.05, 0.035)});
  }
};

TEST(RenderNoise, DeterministicPerSeedAndDifferentAcrossSeeds) {
  const NoiseScene s;
  const SceneRaycaster raycaster = BuildOrDie(s.scene);
  RenderOptions options;
  options.noise.enabled = true;
  options.noise.seed = 42;
  const RenderedViews a = Render(raycaster, options);
  const RenderedViews b = Render(raycaster, options);
  EXPECT_TRUE(SameBytes(a.depth.depth_m, b.depth.depth_m));
  options.noise.seed = 43;
  const RenderedViews c = Render(raycaster, options);
  int differ = 0;
  int finite = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const float za = a.depth.depth_m(v, u);
      const float zc = c.depth.depth_m(v, u);
      if (std::isfinite(za) && std::isfinite(zc)) {
        ++finite;
        differ += za != zc;
      }
    }
  }
  EXPECT_GT(finite, 250000);
  EXPECT_GT(differ, 0.99 * finite);
  // Noise touches depth only.
  EXPECT_TRUE(SameBytes(a.labels, c.labels));
  EXPECT_TRUE(SameBytes(a.stiffness, c.stiffness));
  EXPECT_TRUE(SameBytes(a.deformability, c.deformability));
}

TEST(RenderNoise, DisabledNoiseIsExactlyTheNoiseFreeDepth) {
  const NoiseScene s;
  const SceneRaycaster raycaster = BuildOrDie(s.scene);
  const RenderedViews clean = Render(raycaster, RenderOptions{});
  RenderOptions options;
  options.noise.enabled = false;
  options.noise.seed = 7;
  options.noise.sigma_base_m = 0.01;
  EXPECT_TRUE(SameBytes(Render(raycaster, options).depth.depth_m, clean.depth.depth_m));
}

TEST(RenderNoise, GrazingSurfacesDropOutAtTheConfiguredAngle) {
  SimScene scene;
  scene.support = BigTable(20.0);
  const SceneRaycaster raycaster = BuildOrDie(scene);
  RenderOptions options;
  // Optical axis 70 degrees off the downward vertical: incidence angles span ~43 to ~97 degrees.
  options.world_from_camera = TiltedPose({0, 0, 0.3}, 70.0, 0.0);
  const RenderedViews clean = Render(raycaster, options);
  options.noise.enabled = true;
  options.noise.grazing_angle_deg = 78.0;
  options.noise.edge_dropout_probability = 0.0;
  options.noise.sigma_base_m = 0.0;
  options.noise.sigma_quadratic_per_m = 0.0;
  const RenderedViews noisy = Render(raycaster, options);
  int dropped = 0;
  int kept = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const float z_clean = clean.depth.depth_m(v, u);
      const float z = noisy.depth.depth_m(v, u);
      if (std::isnan(z_clean)) {
        ASSERT_TRUE(std::isnan(z));
        continue;
      }
      const Eigen::Vector3d ray_w = options.world_from_camera.linear() * RayC(options.camera, u, v);
      const double incidence_deg = std::acos(-ray_w.normalized().z()) * 180.0 / std::numbers::pi;
      if (incidence_deg > 78.01) {
        ++dropped;
        ASSERT_TRUE(std::isnan(z)) << u << "," << v << " at " << incidence_deg << " deg";
      } else if (incidence_deg < 77.99) {
        ++kept;
        ASSERT_EQ(z, z_clean) << u << "," << v;
      }
    }
  }
  EXPECT_GT(dropped, 10000);
  EXPECT_GT(kept, 10000);
}

/// Pixels with a 4-neighbour that is missing or more than jump_m away, from the clean depth.
cv::Mat1b DepthJumps(const cv::Mat1f& depth, double jump_m) {
  cv::Mat1b out(depth.size(), std::uint8_t{0});
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      if (std::isnan(depth(v, u))) continue;
      for (const auto& [dv, du] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
        const int vv = v + dv;
        const int uu = u + du;
        if (vv < 0 || uu < 0 || vv >= depth.rows || uu >= depth.cols) continue;
        if (std::isnan(depth(vv, uu)) || std::abs(depth(vv, uu) - depth(v, u)) > jump_m)
          out(v, u) = 1;
      }
    }
  }
  return out;
}

TEST(RenderNoise, EdgeDropoutHappensOnlyNextToDepthJumps) {
  const NoiseScene s;
  const SceneRaycaster raycaster = BuildOrDie(s.scene);
  RenderOptions options;
  const RenderedViews clean = Render(raycaster, options);
  const cv::Mat1b jumps = DepthJumps(clean.depth.depth_m, options.noise.edge_jump_m);
  ASSERT_GT(cv::countNonZero(jumps), 500);

  options.noise.enabled = true;
  options.noise.grazing_angle_deg = 90.0;  // box sides are steep: keep grazing out of this test
  options.noise.sigma_base_m = 0.0;
  options.noise.sigma_quadratic_per_m = 0.0;
  for (double probability : {1.0, 0.5}) {
    SCOPED_TRACE(::testing::Message() << "p = " << probability);
    options.noise.edge_dropout_probability = probability;
    const RenderedViews noisy = Render(raycaster, options);
    int edge_pixels = 0;
    int edge_dropped = 0;
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        const float z = noisy.depth.depth_m(v, u);
        if (jumps(v, u) == 0) {
          ASSERT_TRUE(SameBytes(cv::Mat1f(1, 1, z), cv::Mat1f(1, 1, clean.depth.depth_m(v, u))))
              << u << "," << v;
          continue;
        }
        ++edge_pixels;
        edge_dropped += std::isnan(z);
      }
    }
    const double fraction = static_cast<double>(edge_dropped) / edge_pixels;
    // Binomial: 5 standard deviations.
    EXPECT_NEAR(fraction, probability,
                5.0 * std::sqrt(probability * (1 - probability) / edge_pixels) + 1e-12);
  }
}

TEST(RenderNoise, MeasuredDepthNoiseMatchesTheModelSigma) {
  SimScene scene;
  scene.support = BigTable();
  const SceneRaycaster raycaster = BuildOrDie(scene);
  for (double height_m : {0.55, 1.0}) {
    SCOPED_TRACE(::testing::Message() << "height " << height_m);
    RenderOptions options;
    options.world_from_camera = OverheadCameraPose(height_m);
    options.noise.enabled = true;
    options.noise.seed = 2024;
    const RenderedViews noisy = Render(raycaster, options);
    const double z = static_cast<float>(height_m);
    double sum = 0.0;
    double sum_sq = 0.0;
    int n = 0;
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        const float zn = noisy.depth.depth_m(v, u);
        ASSERT_TRUE(std::isfinite(zn));  // a flat table seen head-on: no dropout
        sum += zn - z;
        sum_sq += (zn - z) * (zn - z);
        ++n;
      }
    }
    const double sigma_model =
        options.noise.sigma_base_m + options.noise.sigma_quadratic_per_m * z * z;
    const double mean = sum / n;
    const double sigma_measured = std::sqrt(sum_sq / n - mean * mean);
    EXPECT_NEAR(sigma_measured, sigma_model, 0.03 * sigma_model);
    EXPECT_LT(std::abs(mean), 5.0 * sigma_model / std::sqrt(n));
  }
}

TEST(Render, BadOptionsThrow) {
  const SceneRaycaster raycaster = BuildOrDie(SimScene{});
  RenderOptions options;
  options.camera.fx = 0.0;
  EXPECT_THROW(Render(raycaster, options), std::invalid_argument);
  options = RenderOptions{};
  options.camera.width = 0;
  EXPECT_THROW(Render(raycaster, options), std::invalid_argument);
  options = RenderOptions{};
  options.world_from_camera.translation().x() = std::nan("");
  EXPECT_THROW(Render(raycaster, options), std::invalid_argument);
  options = RenderOptions{};
  options.noise.enabled = true;
  options.noise.edge_dropout_probability = 1.5;
  EXPECT_THROW(Render(raycaster, options), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::sim
