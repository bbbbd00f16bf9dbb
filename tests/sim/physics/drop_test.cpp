#include "sim/physics/drop.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <numbers>

#include "service/mesh/mesh_check.h"
#include "tests/sim/test_scenes.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::sim {
namespace {

// Analytic test shapes: the mesh for the physics and the exact solid for inside tests.
struct TestShape {
  enum class Kind { kBox, kCylinder, kSphere };
  Kind kind = Kind::kBox;
  Eigen::Vector3d half_m = Eigen::Vector3d::Zero();  // box half extents; cylinder (r, r, h/2)
  int segments = 0;                                  // cylinder / sphere facets around
  std::shared_ptr<const SimObject> object;
};

constexpr double kDensity_kg_m3 = 600.0;

std::shared_ptr<SimObject> WithMass(mesh::TriangleMesh mesh, double volume_m3,
                                    const std::string& category) {
  auto object = std::make_shared<SimObject>();
  object->category = category;
  object->mesh_o = std::move(mesh);
  object->vertex_stiffness.assign(object->mesh_o.vertices.size(), 0.5f);
  object->mass_kg = volume_m3 * kDensity_kg_m3;
  return object;
}

TestShape Box(double sx_m, double sy_m, double sz_m) {
  const Eigen::Vector3d h(sx_m / 2, sy_m / 2, sz_m / 2);
  return {TestShape::Kind::kBox, h, 0,
          WithMass(testing::CentredBoxMesh(h), sx_m * sy_m * sz_m, "box")};
}

// A closed cylinder along z, `n` segments, with a centre vertex on each cap.
TestShape Cylinder(double radius_m, double height_m, int n) {
  mesh::TriangleMesh m;
  const double hz = height_m / 2;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    m.vertices.push_back({radius_m * std::cos(a), radius_m * std::sin(a), -hz});
    m.vertices.push_back({radius_m * std::cos(a), radius_m * std::sin(a), hz});
  }
  const int bottom = 2 * n;
  const int top = 2 * n + 1;
  m.vertices.push_back({0, 0, -hz});
  m.vertices.push_back({0, 0, hz});
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    m.faces.push_back({2 * i, 2 * j, 2 * j + 1});
    m.faces.push_back({2 * i, 2 * j + 1, 2 * i + 1});
    m.faces.push_back({bottom, 2 * j, 2 * i});
    m.faces.push_back({top, 2 * i + 1, 2 * j + 1});
  }
  const double volume = std::numbers::pi * radius_m * radius_m * height_m;
  return {TestShape::Kind::kCylinder,
          {radius_m, radius_m, hz},
          n,
          WithMass(std::move(m), volume, "can")};
}

// A UV sphere with `n` segments around and n / 2 rings.
TestShape Sphere(double radius_m, int n) {
  mesh::TriangleMesh m;
  const int rings = n / 2;
  m.vertices.push_back({0, 0, -radius_m});
  for (int r = 1; r < rings; ++r) {
    const double polar = std::numbers::pi * r / rings;
    for (int i = 0; i < n; ++i) {
      const double a = 2 * std::numbers::pi * i / n;
      m.vertices.push_back({radius_m * std::sin(polar) * std::cos(a),
                            radius_m * std::sin(polar) * std::sin(a), -radius_m * std::cos(polar)});
    }
  }
  m.vertices.push_back({0, 0, radius_m});
  const int last = static_cast<int>(m.vertices.size()) - 1;
  auto at = [&](int ring, int i) { return 1 + (ring - 1) * n + (i % n); };
  for (int i = 0; i < n; ++i) {
    m.faces.push_back({0, at(1, i + 1), at(1, i)});
    m.faces.push_back({last, at(rings - 1, i), at(rings - 1, i + 1)});
    for (int r = 1; r + 1 < rings; ++r) {
      m.faces.push_back({at(r, i), at(r, i + 1), at(r + 1, i + 1)});
      m.faces.push_back({at(r, i), at(r + 1, i + 1), at(r + 1, i)});
    }
  }
  const double volume = 4.0 / 3.0 * std::numbers::pi * std::pow(radius_m, 3);
  return {TestShape::Kind::kSphere, Eigen::Vector3d::Constant(radius_m), n,
          WithMass(std::move(m), volume, "sphere")};
}

// A regular tetrahedron with edge `edge_m`, centred on its centroid (= centre of mass).
std::shared_ptr<SimObject> Tetrahedron(double edge_m) {
  const double s = edge_m / (2.0 * std::sqrt(2.0));  // corners of a cube of side edge / sqrt(2)
  mesh::TriangleMesh m;
  m.vertices = {{s, s, s}, {s, -s, -s}, {-s, s, -s}, {-s, -s, s}};
  m.faces = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  const double volume = std::pow(edge_m, 3) / (6.0 * std::sqrt(2.0));
  return WithMass(std::move(m), volume, "block");
}

// How deep a point (in the shape's frame O) lies inside the solid; negative outside. Uses the
// inscribed radius for faceted shapes, so it never overstates a penetration.
double DepthInside(const TestShape& shape, const Eigen::Vector3d& p_o) {
  const Eigen::Vector3d& h = shape.half_m;
  switch (shape.kind) {
    case TestShape::Kind::kBox:
      return (h - p_o.cwiseAbs()).minCoeff();
    case TestShape::Kind::kCylinder: {
      const double r_in = h.x() * std::cos(std::numbers::pi / shape.segments);
      return std::min(r_in - p_o.head<2>().norm(), h.z() - std::abs(p_o.z()));
    }
    case TestShape::Kind::kSphere:
      return h.x() * std::cos(2 * std::numbers::pi / shape.segments) - p_o.norm();
  }
  return 0.0;
}

// Surface sample points of a mesh in its frame: vertices and face centroids.
std::vector<Eigen::Vector3d> SurfacePoints(const mesh::TriangleMesh& m) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& v : m.vertices) out.emplace_back(v[0], v[1], v[2]);
  for (const auto& f : m.faces) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k : f) c += Eigen::Vector3d(m.vertices[k][0], m.vertices[k][1], m.vertices[k][2]);
    out.push_back(c / 3.0);
  }
  return out;
}

std::vector<Eigen::Vector3d> WorldVertices(const PlacedObject& placed) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& v : placed.object->mesh_o.vertices) {
    out.push_back(placed.world_from_object * Eigen::Vector3d(v[0], v[1], v[2]));
  }
  return out;
}

double LowestZ(const PlacedObject& placed) {
  double z = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : WorldVertices(placed)) z = std::min(z, p.z());
  return z;
}

std::vector<std::shared_ptr<const SimObject>> Objects(const std::vector<TestShape>& shapes) {
  std::vector<std::shared_ptr<const SimObject>> out;
  for (const TestShape& s : shapes) out.push_back(s.object);
  return out;
}

Support Table() {
  Support table;
  table.kind = Support::Kind::kTable;
  return table;
}

TEST(TestShapes, AreValidClosedMeshes) {
  for (const TestShape& s : {Box(0.04, 0.06, 0.02), Cylinder(0.03, 0.1, 24), Sphere(0.05, 64)}) {
    const mesh::MeshReport report = mesh::CheckMesh(s.object->mesh_o);
    EXPECT_TRUE(report.ok()) << s.object->category << ": " << report.problems.front();
  }
  const mesh::MeshReport tetrahedron = mesh::CheckMesh(Tetrahedron(0.04)->mesh_o);
  EXPECT_TRUE(tetrahedron.ok()) << tetrahedron.problems.front();
}

TEST(DropObjects, BoxComesToRestOnAFaceOfTheTable) {
  const TestShape box = Box(0.04, 0.06, 0.02);
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const auto result = DropObjects(Table(), {box.object}, seed);
    ASSERT_TRUE(result.ok()) << result.error().message;
    const DropResult& drop = result.value();
    EXPECT_TRUE(drop.report.settled);
    EXPECT_LT(drop.report.steps, DropOptions{}.max_steps);
    EXPECT_TRUE(drop.report.lost_instance_ids.empty());
    ASSERT_EQ(drop.scene.objects.size(), 1u);
    const PlacedObject& placed = drop.scene.objects[0];
    EXPECT_EQ(placed.instance_id, 1);
    EXPECT_EQ(drop.scene.seed, seed);
    EXPECT_NEAR(LowestZ(placed), 0.0, 1e-3) << "seed " << seed;
    // Resting on a face: one box axis is vertical and the centre is that half extent up.
    const Eigen::Matrix3d r = placed.world_from_object.linear();
    int up_axis = -1;
    for (int k = 0; k < 3; ++k) {
      if (std::abs(r(2, k)) > 0.999) up_axis = k;
    }
    ASSERT_GE(up_axis, 0) << "not resting on a face, seed " << seed << "\n" << r;
    EXPECT_NEAR(placed.world_from_object.translation().z(), box.half_m[up_axis], 1e-3);
  }
}

std::vector<TestShape> EightMixedObjects() {
  return {Box(0.04, 0.06, 0.02),    Cylinder(0.03, 0.10, 24), Box(0.05, 0.05, 0.05),
          Cylinder(0.02, 0.06, 20), Box(0.08, 0.03, 0.03),    Cylinder(0.035, 0.04, 24),
          Box(0.06, 0.04, 0.04),    Cylinder(0.025, 0.12, 24)};
}

// Checks a settled bin scene: every survivor inside the inner walls and above the floor (1 mm
// tolerance), no surface point of one object more than 3 mm inside another.
void ExpectTidyBin(const Support& bin, const std::vector<TestShape>& shapes,
                   const DropResult& drop) {
  const double hx = bin.inner_size_x_m / 2 + 1e-3;
  const double hy = bin.inner_size_y_m / 2 + 1e-3;
  for (std::size_t i = 0; i < drop.scene.objects.size(); ++i) {
    const PlacedObject& placed = drop.scene.objects[i];
    for (const Eigen::Vector3d& p : WorldVertices(placed)) {
      EXPECT_LE(std::abs(p.x()), hx) << "object " << placed.instance_id;
      EXPECT_LE(std::abs(p.y()), hy) << "object " << placed.instance_id;
      EXPECT_GE(p.z(), -1e-3) << "object " << placed.instance_id;
    }
  }
  double deepest_m = 0.0;
  for (const PlacedObject& a : drop.scene.objects) {
    for (const PlacedObject& b : drop.scene.objects) {
      if (a.instance_id == b.instance_id) continue;
      const Eigen::Isometry3d b_from_a = b.world_from_object.inverse() * a.world_from_object;
      const TestShape& shape_b = shapes[static_cast<std::size_t>(b.instance_id - 1)];
      for (const Eigen::Vector3d& p_a : SurfacePoints(a.object->mesh_o)) {
        const double depth = DepthInside(shape_b, b_from_a * p_a);
        deepest_m = std::max(deepest_m, depth);
        EXPECT_LT(depth, 3e-3) << "object " << a.instance_id << " inside " << b.instance_id;
      }
    }
  }
  std::printf("  deepest interpenetration %.2f mm\n", deepest_m * 1e3);
}

TEST(DropObjects, EightObjectsSettleInsideTheBinWithoutInterpenetrating) {
  const std::vector<TestShape> shapes = EightMixedObjects();
  const Support bin;  // default: 0.40 x 0.30 inner floor, 0.10 m walls
  for (std::uint64_t seed : {42u, 43u, 44u}) {
    const std::clock_t cpu_start = std::clock();
    const auto result = DropObjects(bin, Objects(shapes), seed);
    const double cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    ASSERT_TRUE(result.ok()) << result.error().message;
    const DropResult& drop = result.value();
    std::printf(
        "seed %d: 8 objects into a bin settled after %d steps (%.2f s simulated), %.3f s CPU\n",
        static_cast<int>(seed), drop.report.steps, drop.report.steps * DropOptions{}.time_step_s,
        cpu_s);
    EXPECT_TRUE(drop.report.settled) << "seed " << seed;
    EXPECT_TRUE(drop.report.lost_instance_ids.empty()) << "seed " << seed;
    ASSERT_EQ(drop.scene.objects.size(), shapes.size()) << "seed " << seed;
    for (std::size_t i = 0; i < shapes.size(); ++i) {
      EXPECT_EQ(drop.scene.objects[i].instance_id, static_cast<int>(i) + 1);
      EXPECT_EQ(drop.scene.objects[i].object, shapes[i].object);
    }
    ExpectTidyBin(bin, shapes, drop);
  }
}

TEST(DropObjects, SameSeedGivesBitIdenticalPosesAnotherSeedDiffers) {
  const std::vector<TestShape> shapes = EightMixedObjects();
  const auto first = DropObjects(Support{}, Objects(shapes), 7);
  const auto second = DropObjects(Support{}, Objects(shapes), 7);
  const auto other = DropObjects(Support{}, Objects(shapes), 8);
  ASSERT_TRUE(first.ok() && second.ok() && other.ok());
  const SimScene& a = first.value().scene;
  const SimScene& b = second.value().scene;
  const SimScene& c = other.value().scene;
  EXPECT_EQ(first.value().report.steps, second.value().report.steps);
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (std::size_t i = 0; i < a.objects.size(); ++i) {
    EXPECT_EQ(a.objects[i].instance_id, b.objects[i].instance_id);
    EXPECT_TRUE(a.objects[i].world_from_object.matrix() == b.objects[i].world_from_object.matrix())
        << "object " << i + 1;
  }
  // Hex floats, to compare runs across processes and machines by eye.
  const Eigen::Vector3d t = a.objects[0].world_from_object.translation();
  std::printf("seed 7, object 1 at (%a, %a, %a)\n", t.x(), t.y(), t.z());
  ASSERT_FALSE(c.objects.empty());
  EXPECT_FALSE(a.objects[0].world_from_object.matrix() == c.objects[0].world_from_object.matrix());
}

TEST(DropObjects, DenseMeshIsReducedAndStillRestsOnItsSurface) {
  const TestShape sphere = Sphere(0.04, 96);  // 4,418 vertices: more than the hull point budget
  ASSERT_GT(sphere.object->mesh_o.vertices.size(), 1000u);
  const auto result = DropObjects(Table(), {sphere.object}, 5);
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_EQ(result.value().scene.objects.size(), 1u);
  const PlacedObject& placed = result.value().scene.objects[0];
  EXPECT_TRUE(result.value().report.settled);
  // Reduced hull points lie on the sphere, so the centre rests at about one radius.
  EXPECT_NEAR(placed.world_from_object.translation().z(), 0.04, 2e-3);
  EXPECT_NEAR(LowestZ(placed), 0.0, 2e-3);
}

TEST(DropObjects, BallsDroppedBesideAPedestalFallOffAndAreReportedLost) {
  // A 2 mm pedestal and spawn points up to 2 cm off it: a 10 cm ball's centre is never over the
  // pedestal when it lands, so it rolls off and falls.
  Support pedestal = Table();
  pedestal.ground_size_m = 0.002;
  pedestal.inner_size_x_m = 0.04;
  pedestal.inner_size_y_m = 0.04;
  DropOptions options;
  options.margin_m = 0.0;
  const TestShape ball = Sphere(0.05, 24);
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const auto result =
        DropObjects(pedestal, {ball.object, ball.object, ball.object}, seed, options);
    ASSERT_TRUE(result.ok()) << result.error().message;
    EXPECT_TRUE(result.value().scene.objects.empty()) << "seed " << seed;
    EXPECT_EQ(result.value().report.lost_instance_ids, (std::vector<int>{1, 2, 3}))
        << "seed " << seed;
    EXPECT_TRUE(result.value().report.settled);  // nothing left to move
    EXPECT_LT(result.value().report.steps, DropOptions{}.max_steps);
  }
}

TEST(DropObjects, LostObjectsAreOmittedAndSurvivorsKeepTheirIds) {
  // A heavy tetrahedron stays on a 6 cm table. A light 10 cm ball dropped onto it cannot rest on
  // its steep faces, and resting on the table beside it would put the ball's centre more than
  // 3 cm out: the ball is lost, the tetrahedron keeps id 1 and the ball's id 2 is reported.
  Support small = Table();
  small.ground_size_m = 0.06;
  small.inner_size_x_m = 0.02;
  small.inner_size_y_m = 0.02;
  auto tetrahedron = Tetrahedron(0.04);
  tetrahedron->mass_kg = 1.0;
  auto ball = std::make_shared<SimObject>(*Sphere(0.05, 24).object);
  ball->mass_kg = 0.05;
  DropOptions options;
  options.margin_m = 0.0;
  options.drop_height_min_m = 0.0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const auto result = DropObjects(small, {tetrahedron, ball}, seed, options);
    ASSERT_TRUE(result.ok()) << result.error().message;
    const DropResult& drop = result.value();
    ASSERT_EQ(drop.scene.objects.size(), 1u) << "seed " << seed;
    EXPECT_EQ(drop.scene.objects[0].instance_id, 1);
    EXPECT_EQ(drop.scene.objects[0].object, tetrahedron);
    EXPECT_EQ(drop.report.lost_instance_ids, std::vector<int>{2});
    EXPECT_NEAR(LowestZ(drop.scene.objects[0]), 0.0, 1e-3);
  }
}

void ExpectInvalid(const core::Result<DropResult>& result, const std::string& field) {
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, core::ErrorCode::kInvalidArgument);
  EXPECT_EQ(result.error().field, field) << result.error().message;
  EXPECT_FALSE(result.error().message.empty());
}

TEST(DropObjects, RejectsBadObjects) {
  const TestShape box = Box(0.04, 0.06, 0.02);
  ExpectInvalid(DropObjects(Support{}, {}, 1), "objects");
  ExpectInvalid(DropObjects(Support{}, {box.object, nullptr}, 1), "objects[1]");

  auto empty = std::make_shared<SimObject>(*box.object);
  empty->mesh_o = {};
  ExpectInvalid(DropObjects(Support{}, {empty}, 1), "objects[0].mesh_o");

  auto nan = std::make_shared<SimObject>(*box.object);
  nan->mesh_o.vertices[3][1] = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalid(DropObjects(Support{}, {box.object, nan}, 1), "objects[1].mesh_o");

  auto flat = std::make_shared<SimObject>(*box.object);
  for (auto& v : flat->mesh_o.vertices) v[2] = 0.0;
  ExpectInvalid(DropObjects(Support{}, {flat}, 1), "objects[0].mesh_o");

  for (double mass : {0.0, -1.0, std::numeric_limits<double>::infinity()}) {
    auto massless = std::make_shared<SimObject>(*box.object);
    massless->mass_kg = mass;
    ExpectInvalid(DropObjects(Support{}, {box.object, box.object, massless}, 1),
                  "objects[2].mass_kg");
  }
}

TEST(DropObjects, RejectsBadOptionsAndSupports) {
  const std::vector<std::shared_ptr<const SimObject>> one = {Box(0.04, 0.06, 0.02).object};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto with = [&](auto edit) {
    DropOptions o;
    edit(o);
    return DropObjects(Support{}, one, 1, o);
  };
  ExpectInvalid(with([](DropOptions& o) { o.time_step_s = 0; }), "options.time_step_s");
  ExpectInvalid(with([&](DropOptions& o) { o.time_step_s = nan; }), "options.time_step_s");
  ExpectInvalid(with([](DropOptions& o) { o.time_step_s = 1.0; }), "options.time_step_s");
  ExpectInvalid(with([](DropOptions& o) { o.max_steps = 0; }), "options.max_steps");
  ExpectInvalid(with([](DropOptions& o) { o.margin_m = -0.01; }), "options.margin_m");
  ExpectInvalid(with([&](DropOptions& o) { o.drop_height_min_m = nan; }),
                "options.drop_height_min_m");
  ExpectInvalid(with([](DropOptions& o) { o.spawn_gap_m = -1; }), "options.spawn_gap_m");
  ExpectInvalid(with([](DropOptions& o) { o.friction = -0.1; }), "options.friction");
  ExpectInvalid(with([](DropOptions& o) { o.restitution = 1.5; }), "options.restitution");
  ExpectInvalid(with([](DropOptions& o) { o.sleep_linear_m_s = 0; }), "options.sleep_linear_m_s");
  ExpectInvalid(with([&](DropOptions& o) { o.sleep_angular_rad_s = nan; }),
                "options.sleep_angular_rad_s");

  Support bad;
  bad.inner_size_x_m = -0.4;
  ExpectInvalid(DropObjects(bad, one, 1), "support.inner_size_x_m");
  bad = Support{};
  bad.wall_thickness_m = nan;
  ExpectInvalid(DropObjects(bad, one, 1), "support.wall_thickness_m");
  bad = Support{};
  bad.ground_size_m = 0;
  ExpectInvalid(DropObjects(bad, one, 1), "support.ground_size_m");
}

TEST(DropObjects, MaxStepsCapsTheRunAndReportsUnsettled) {
  DropOptions options;
  options.max_steps = 10;  // the box is still falling after 10 steps
  const auto result = DropObjects(Table(), {Box(0.04, 0.06, 0.02).object}, 1, options);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.value().report.steps, 10);
  EXPECT_FALSE(result.value().report.settled);
}

}  // namespace
}  // namespace softgrasp::sim
