// Antipodal grasp sampling on analytic meshes: every grasp is in force closure and fits the
// stroke, a plate wider than the stroke is only grasped across its thickness, a sphere's grasps
// are chords within the friction cone, and a seed fixes the grasps.
#include "service/mesh_grasps/antipodal.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "tests/support/box_mesh.h"

namespace softgrasp::mesh {
namespace {

constexpr double kPi = 3.14159265358979323846;

raycast::MeshRaycaster CasterFor(const TriangleMesh& mesh) {
  const std::vector<raycast::Surface> surfaces{{1, &mesh, Eigen::Isometry3d::Identity()}};
  auto caster = raycast::MeshRaycaster::Build(surfaces);
  if (!caster.ok()) throw std::runtime_error(caster.error().message);
  return std::move(caster).value();
}

std::vector<JawGrasp> Sample(const TriangleMesh& mesh, const AntipodalParams& params) {
  const raycast::MeshRaycaster caster = CasterFor(mesh);
  auto grasps = SampleAntipodalGrasps(mesh, caster, params);
  EXPECT_TRUE(grasps.ok()) << grasps.error().message;
  return grasps.ok() ? grasps.value() : std::vector<JawGrasp>{};
}

// A UV sphere of radius r: `rings` latitude bands, `segments` longitudes, outward faces.
TriangleMesh Sphere(double r, int rings, int segments) {
  TriangleMesh m;
  m.vertices.push_back({0, 0, r});
  for (int i = 1; i < rings; ++i) {
    const double polar = kPi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double azimuth = 2 * kPi * j / segments;
      m.vertices.push_back({r * std::sin(polar) * std::cos(azimuth),
                            r * std::sin(polar) * std::sin(azimuth), r * std::cos(polar)});
    }
  }
  m.vertices.push_back({0, 0, -r});
  const int south = static_cast<int>(m.vertices.size()) - 1;
  const auto at = [&](int ring, int j) { return 1 + (ring - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) m.faces.push_back({0, at(1, j), at(1, j + 1)});
  for (int i = 1; i < rings - 1; ++i) {
    for (int j = 0; j < segments; ++j) {
      m.faces.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.faces.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  for (int j = 0; j < segments; ++j)
    m.faces.push_back({south, at(rings - 1, j + 1), at(rings - 1, j)});
  return m;
}

TEST(AntipodalGrasps, OnACubeEveryGraspJoinsOppositeFacesInsideTheFrictionCone) {
  const TriangleMesh cube = testing::CentredBoxMesh({0.02, 0.02, 0.02});
  AntipodalParams params;
  params.seed = 5;
  const std::vector<JawGrasp> grasps = Sample(cube, params);
  ASSERT_EQ(static_cast<int>(grasps.size()), params.target_num_grasps);
  const double cone = std::atan(params.friction_coefficient);
  for (const JawGrasp& g : grasps) {
    EXPECT_TRUE(ForceClosure(g.a, g.b, params.friction_coefficient));
    // Opposite faces: the contacts lie on the planes +-0.02 of one axis, 0.04 m apart along it,
    // and the axis is within the cone of that axis, so the width is 0.04 / cos(angle).
    Eigen::Index face_axis = 0;
    g.axis.cwiseAbs().maxCoeff(&face_axis);
    EXPECT_NEAR(std::abs(g.a.point_m[face_axis]), 0.02, 1e-9);
    EXPECT_NEAR(std::abs(g.b.point_m[face_axis]), 0.02, 1e-9);
    const double angle = std::acos(std::abs(g.axis[face_axis]));
    EXPECT_LE(angle, cone + 1e-9);
    EXPECT_NEAR(g.width_m, 0.04 / std::cos(angle), 1e-9);
    EXPECT_NEAR((g.center_m - 0.5 * (g.a.point_m + g.b.point_m)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(g.axis.norm(), 1.0, 1e-12);
  }
  // Coverage: no two kept grasps closer than the threshold.
  for (std::size_t i = 0; i < grasps.size(); ++i) {
    for (std::size_t j = i + 1; j < grasps.size(); ++j) {
      EXPECT_GE(GraspDistance(grasps[i], grasps[j]), params.min_grasp_distance_m);
    }
  }
}

TEST(AntipodalGrasps, APlateWiderThanTheStrokeIsGraspedOnlyAcrossItsThickness) {
  // 100 x 80 x 6 mm: only the 6 mm thickness fits a 50 mm stroke.
  const TriangleMesh plate = testing::CentredBoxMesh({0.05, 0.04, 0.003});
  AntipodalParams params;
  params.seed = 1;
  const std::vector<JawGrasp> grasps = Sample(plate, params);
  ASSERT_FALSE(grasps.empty());
  for (const JawGrasp& g : grasps) {
    EXPECT_LE(g.width_m, params.max_width_m);
    EXPECT_GT(std::abs(g.axis.z()), std::cos(std::atan(params.friction_coefficient)) - 1e-9);
    EXPECT_NEAR(std::abs(g.a.point_m.z()), 0.003, 1e-9);
  }
  // Jaws that would have to start inside the plate find no grasp.
  const raycast::MeshRaycaster caster = CasterFor(plate);
  EXPECT_FALSE(CloseJaws(caster, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.05));
  EXPECT_TRUE(CloseJaws(caster, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.12));
}

TEST(AntipodalGrasps, ASpheresGraspsAreChordsWithinTheFrictionCone) {
  // On a sphere of radius R a chord at distance d from the centre meets both surface normals at
  // asin(d / R): it is in force closure up to d = R sin(atan mu), and its length is
  // 2 sqrt(R^2 - d^2). The polygonal sphere's facets move both by less than 1 mm here.
  const double radius = 0.02;
  const TriangleMesh sphere = Sphere(radius, 24, 48);
  AntipodalParams params;
  params.seed = 3;
  params.target_num_grasps = 40;
  const std::vector<JawGrasp> grasps = Sample(sphere, params);
  ASSERT_EQ(grasps.size(), 40u);
  const double max_offset = radius * std::sin(std::atan(params.friction_coefficient));
  double largest_offset = 0;
  for (const JawGrasp& g : grasps) {
    const Eigen::Vector3d off_axis = g.center_m - g.center_m.dot(g.axis) * g.axis;
    const double d = off_axis.norm();
    largest_offset = std::max(largest_offset, d);
    EXPECT_LT(d, max_offset + 0.001);
    EXPECT_NEAR(g.width_m, 2 * std::sqrt(radius * radius - std::min(d * d, radius * radius)),
                0.001);
  }
  // The cone is sampled, not just its axis: some chords are well off the centre.
  EXPECT_GT(largest_offset, 0.5 * max_offset);
}

TEST(AntipodalGrasps, TheSeedFixesTheGrasps) {
  const TriangleMesh box = testing::CentredBoxMesh({0.015, 0.02, 0.01});
  AntipodalParams params;
  params.seed = 9;
  const auto first = Sample(box, params);
  const auto again = Sample(box, params);
  ASSERT_EQ(first.size(), again.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(first[i].center_m, again[i].center_m);
    EXPECT_EQ(first[i].axis, again[i].axis);
  }
  params.seed = 10;
  const auto other = Sample(box, params);
  ASSERT_FALSE(other.empty());
  EXPECT_NE(other.front().center_m, first.front().center_m);
}

TEST(AntipodalGrasps, RefusesParametersOutOfRange) {
  const TriangleMesh cube = testing::CentredBoxMesh({0.02, 0.02, 0.02});
  const raycast::MeshRaycaster caster = CasterFor(cube);
  const auto field = [&](AntipodalParams p) {
    auto r = SampleAntipodalGrasps(cube, caster, p);
    EXPECT_FALSE(r.ok());
    return r.ok() ? std::string() : r.error().field;
  };
  AntipodalParams p;
  p.friction_coefficient = -0.1;
  EXPECT_EQ(field(p), "friction_coefficient");
  p = {};
  p.max_width_m = 0;
  EXPECT_EQ(field(p), "max_width_m");
  p = {};
  p.min_contact_distance_m = 0.06;
  EXPECT_EQ(field(p), "min_contact_distance_m");
  p = {};
  p.target_num_grasps = 0;
  EXPECT_EQ(field(p), "target_num_grasps");
}

}  // namespace
}  // namespace softgrasp::mesh
