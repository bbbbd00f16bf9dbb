#include "sim/grasp/execute.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "service/mesh/mesh_check.h"
#include "tests/sim/test_scenes.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGravity = 9.81;

// ---- Test objects, built here so the tests depend on nothing but the scene model. ----

/// A closed box of size_m centred on its frame's origin, one stiffness everywhere.
std::shared_ptr<SimObject> Box(const Eigen::Vector3d& size_m, float stiffness, double mass_kg) {
  auto object = std::make_shared<SimObject>();
  object->category = "block";
  object->mesh_o = testing::CentredBoxMesh(size_m / 2.0);
  object->vertex_stiffness.assign(object->mesh_o.vertices.size(), stiffness);
  object->mass_kg = mass_kg;
  return object;
}

/// A closed vertical cylinder centred on its frame's origin. Rings of vertices sit at the given
/// heights (from -height/2 to +height/2) and carry the given stiffness; two rings 0.1 mm apart
/// make a sharp band border.
std::shared_ptr<SimObject> Cylinder(double radius_m, const std::vector<double>& ring_z_m,
                                    const std::vector<float>& ring_stiffness, double mass_kg) {
  constexpr int kSegments = 48;
  auto object = std::make_shared<SimObject>();
  object->category = "bottle";
  auto& mesh = object->mesh_o;
  const int rings = static_cast<int>(ring_z_m.size());
  for (int r = 0; r < rings; ++r) {
    for (int k = 0; k < kSegments; ++k) {
      const double theta = 2.0 * kPi * k / kSegments;
      mesh.vertices.push_back(
          {radius_m * std::cos(theta), radius_m * std::sin(theta), ring_z_m[r]});
      object->vertex_stiffness.push_back(ring_stiffness[r]);
    }
  }
  auto at = [&](int r, int k) { return r * kSegments + (k % kSegments); };
  for (int r = 0; r + 1 < rings; ++r) {
    for (int k = 0; k < kSegments; ++k) {
      mesh.faces.push_back({at(r, k), at(r, k + 1), at(r + 1, k + 1)});
      mesh.faces.push_back({at(r, k), at(r + 1, k + 1), at(r + 1, k)});
    }
  }
  const int bottom = static_cast<int>(mesh.vertices.size());
  mesh.vertices.push_back({0.0, 0.0, ring_z_m.front()});
  object->vertex_stiffness.push_back(ring_stiffness.front());
  const int top = bottom + 1;
  mesh.vertices.push_back({0.0, 0.0, ring_z_m.back()});
  object->vertex_stiffness.push_back(ring_stiffness.back());
  for (int k = 0; k < kSegments; ++k) {
    mesh.faces.push_back({bottom, at(0, k + 1), at(0, k)});
    mesh.faces.push_back({top, at(rings - 1, k), at(rings - 1, k + 1)});
  }
  object->mass_kg = mass_kg;
  return object;
}

/// A 100 mm tall, 40 mm wide cylinder: body of stiffness `body` below 80 mm, a hard band (1.0)
/// from 80 mm to the top.
std::shared_ptr<SimObject> BandedBottle(float body, double mass_kg = 0.1) {
  return Cylinder(0.02, {-0.05, 0.0299, 0.03, 0.05}, {body, body, 1.0f, 1.0f}, mass_kg);
}

/// A roof-shaped prism: triangular cross-section in x-z (base 2 * half_base_m on z = 0, apex at
/// height_m), extruded along y over length_m. Its sloped faces lean atan(half_base / height)
/// from vertical, i.e. their normals are atan(half_base / height) above horizontal.
std::shared_ptr<SimObject> Roof(double half_base_m, double height_m, double length_m) {
  auto object = std::make_shared<SimObject>();
  object->category = "user";
  for (double y : {-length_m / 2.0, length_m / 2.0}) {
    object->mesh_o.vertices.push_back({-half_base_m, y, 0.0});
    object->mesh_o.vertices.push_back({half_base_m, y, 0.0});
    object->mesh_o.vertices.push_back({0.0, y, height_m});
  }
  object->mesh_o.faces = {{0, 1, 2}, {3, 5, 4}, {0, 4, 1}, {0, 3, 4},
                          {1, 4, 5}, {1, 5, 2}, {0, 2, 5}, {0, 5, 3}};
  object->vertex_stiffness.assign(6, 1.0f);
  object->mass_kg = 0.05;
  return object;
}

PlacedObject Place(int id, std::shared_ptr<const SimObject> object, const Eigen::Vector3d& p_w,
                   double yaw_rad = 0.0) {
  PlacedObject placed;
  placed.instance_id = id;
  placed.object = std::move(object);
  placed.world_from_object.translation() = p_w;
  placed.world_from_object.linear() =
      Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return placed;
}

SimScene TableScene(std::vector<PlacedObject> objects) {
  SimScene scene;
  scene.support.kind = Support::Kind::kTable;
  scene.objects = std::move(objects);
  return scene;
}

SimGrasp GraspAt(double x_m, double y_m, double fingertip_height_m, double angle_rad = 0.0,
                 double opening_m = 0.05) {
  SimGrasp g;
  g.center_x_m = x_m;
  g.center_y_m = y_m;
  g.fingertip_height_m = fingertip_height_m;
  g.angle_rad = angle_rad;
  g.opening_m = opening_m;
  return g;
}

GraspExecution Execute(const SimScene& scene, const SimGrasp& grasp,
                       const core::Gripper& gripper = core::Gripper{}) {
  auto raycaster = SceneRaycaster::Build(scene);
  EXPECT_TRUE(raycaster.ok()) << (raycaster.ok() ? "" : raycaster.error().message);
  auto result = ExecuteGrasp(scene, raycaster.value(), grasp, gripper);
  EXPECT_TRUE(result.ok()) << (result.ok() ? "" : result.error().message);
  return result.value();
}

/// Indentation of one finger on a surface of this stiffness, metres (uncapped).
double DentM(float stiffness, double force_n) {
  return force_n / (1000.0 * ContactSpringRateNPerMm(stiffness));
}

// A 30 mm wide, 40 mm deep, 50 mm tall rigid block standing on the table.
const Eigen::Vector3d kBlockSize(0.03, 0.04, 0.05);

// ---- The stiffness -> spring-rate map. ----

TEST(ContactSpringRate, LogLinearBetweenSpongeAndRigidAnchors) {
  EXPECT_NEAR(ContactSpringRateNPerMm(0.1f), 0.2, 1e-6);
  EXPECT_NEAR(ContactSpringRateNPerMm(1.0f), 1000.0, 1e-3);
  // Half way in s is the geometric mean of the anchors.
  EXPECT_NEAR(ContactSpringRateNPerMm(0.55f), std::sqrt(0.2 * 1000.0), 1e-3);
  for (float s = 0.1f; s < 0.95f; s += 0.1f) {
    EXPECT_LT(ContactSpringRateNPerMm(s), ContactSpringRateNPerMm(s + 0.1f)) << s;
  }
  // Out-of-range scores clamp; NaN counts as the softest.
  EXPECT_DOUBLE_EQ(ContactSpringRateNPerMm(0.0f), ContactSpringRateNPerMm(0.1f));
  EXPECT_DOUBLE_EQ(ContactSpringRateNPerMm(3.0f), ContactSpringRateNPerMm(1.0f));
  EXPECT_DOUBLE_EQ(ContactSpringRateNPerMm(std::nanf("")), ContactSpringRateNPerMm(0.1f));
  // The design targets: a 10 N squeeze dents a rigid block by ~0.01 mm, a soft (0.3) bottle
  // body by millimetres.
  EXPECT_NEAR(DentM(1.0f, 10.0), 1e-5, 1e-9);
  EXPECT_GT(DentM(0.3f, 10.0), 0.002);
  EXPECT_LT(DentM(0.3f, 10.0), 0.02);
}

TEST(GraspOutcomeName, NamesEveryOutcome) {
  EXPECT_STREQ(GraspOutcomeName(GraspOutcome::kSucceeded), "succeeded");
  EXPECT_STREQ(GraspOutcomeName(GraspOutcome::kCollision), "collision");
  EXPECT_STREQ(GraspOutcomeName(GraspOutcome::kEmpty), "empty");
  EXPECT_STREQ(GraspOutcomeName(GraspOutcome::kTooWide), "too_wide");
  EXPECT_STREQ(GraspOutcomeName(GraspOutcome::kMultipleObjects), "multiple_objects");
  EXPECT_STREQ(GraspOutcomeName(GraspOutcome::kSlipped), "slipped");
}

TEST(TestObjects, AreClosedOutwardSurfaces) {
  for (const auto& object :
       {Box(kBlockSize, 1.0f, 0.1), BandedBottle(0.3f), Roof(0.02, 0.02, 0.04)}) {
    const mesh::MeshReport report = mesh::CheckMesh(object->mesh_o);
    EXPECT_TRUE(report.ok()) << object->category << ": " << report.problems.size();
    EXPECT_EQ(object->vertex_stiffness.size(), object->mesh_o.vertices.size());
  }
}

// ---- Squeeze. ----

TEST(ExecuteGrasp, RigidBlockIsHeldAtItsWidthWithoutDeformation) {
  const SimScene scene = TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.0, 0.0, 0.025})});
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.02));
  ASSERT_TRUE(e.succeeded()) << e.reason;
  EXPECT_EQ(e.instance_id, 1);
  EXPECT_NEAR(e.contact_width_m, 0.030, 0.0005);
  EXPECT_FLOAT_EQ(e.stiffness_left, 1.0f);
  EXPECT_FLOAT_EQ(e.stiffness_right, 1.0f);
  // Each finger dents it by F / k(1.0) = 10 N / 1000 N/mm = 0.01 mm.
  EXPECT_NEAR(e.grasped_width_m, e.contact_width_m - 2.0 * DentM(1.0f, 10.0), 1e-12);
  EXPECT_LT(e.deformation_rate, 0.001);
  EXPECT_FALSE(e.damaged);
  EXPECT_NE(e.reason.find("object 1"), std::string::npos) << e.reason;
}

TEST(ExecuteGrasp, WidthFollowsTheClosingAxisForRotatedAndOffCentreGrasps) {
  // The block turned 30 degrees, grasped along its 40 mm side, 5 mm off its centre line.
  const double yaw = kPi / 6.0;
  const Eigen::Vector3d centre(0.05, -0.03, 0.025);
  const SimScene scene = TableScene({Place(7, Box(kBlockSize, 1.0f, 0.1), centre, yaw)});
  const Eigen::Vector3d lateral(-std::sin(yaw + kPi / 2), std::cos(yaw + kPi / 2), 0.0);
  const Eigen::Vector3d c = centre + 0.005 * lateral;
  const GraspExecution e = Execute(scene, GraspAt(c.x(), c.y(), 0.01, yaw + kPi / 2));
  ASSERT_TRUE(e.succeeded()) << e.reason;
  EXPECT_EQ(e.instance_id, 7);
  EXPECT_NEAR(e.contact_width_m, 0.040, 0.0005);
}

TEST(ExecuteGrasp, FingertipsRestingOnTheTableDoNotCollide) {
  const SimScene scene = TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.0, 0.0, 0.025})});
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.0));
  EXPECT_TRUE(e.succeeded()) << e.reason;
}

TEST(ExecuteGrasp, SoftBodyDeformsMoreThanTheHardBand) {
  const SimScene scene = TableScene({Place(1, BandedBottle(0.3f), {0.0, 0.0, 0.05})});
  core::Gripper gripper;
  gripper.closing_force_n = 2.0;
  // Fingers over 20..60 mm: the body only. Over 75..115 mm: the band carries the load.
  const GraspExecution body = Execute(scene, GraspAt(0.0, 0.0, 0.02), gripper);
  const GraspExecution band = Execute(scene, GraspAt(0.0, 0.0, 0.075), gripper);
  ASSERT_TRUE(body.succeeded()) << body.reason;
  ASSERT_TRUE(band.succeeded()) << band.reason;
  EXPECT_FLOAT_EQ(body.stiffness_left, 0.3f);
  EXPECT_FLOAT_EQ(body.stiffness_right, 0.3f);
  EXPECT_FLOAT_EQ(band.stiffness_left, 1.0f);
  EXPECT_FLOAT_EQ(band.stiffness_right, 1.0f);
  EXPECT_NEAR(body.contact_width_m, 0.040, 0.0005);
  EXPECT_NEAR(band.contact_width_m, 0.040, 0.0005);
  EXPECT_NEAR(body.deformation_rate, 2.0 * DentM(0.3f, 2.0) / body.contact_width_m, 1e-9);
  EXPECT_NEAR(band.deformation_rate, 2.0 * DentM(1.0f, 2.0) / band.contact_width_m, 1e-9);
  EXPECT_GT(body.deformation_rate, 100.0 * band.deformation_rate);
  EXPECT_FALSE(body.damaged);  // ~7.5 %
}

TEST(ExecuteGrasp, SoftBodyUnderAStrongSqueezeIsDamaged) {
  const SimScene scene = TableScene({Place(1, BandedBottle(0.4f), {0.0, 0.0, 0.05})});
  core::Gripper gripper;
  gripper.closing_force_n = 20.0;
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.02), gripper);
  ASSERT_TRUE(e.succeeded()) << e.reason;
  EXPECT_NEAR(e.deformation_rate, 2.0 * DentM(0.4f, 20.0) / e.contact_width_m, 1e-9);
  EXPECT_GT(e.deformation_rate, 0.2);
  EXPECT_TRUE(e.damaged);
  EXPECT_NE(e.reason.find("damaged"), std::string::npos) << e.reason;
}

TEST(ExecuteGrasp, SqueezeStopsAtHalfTheContactWidth) {
  const SimScene scene = TableScene({Place(1, BandedBottle(0.1f), {0.0, 0.0, 0.05})});
  core::Gripper gripper;
  gripper.closing_force_n = 20.0;  // 100 mm per finger uncapped
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.02), gripper);
  ASSERT_TRUE(e.succeeded()) << e.reason;
  EXPECT_NEAR(e.grasped_width_m, e.contact_width_m / 2.0, 1e-12);
  EXPECT_NEAR(e.deformation_rate, 0.5, 1e-9);
  EXPECT_TRUE(e.damaged);
}

// ---- Descent. ----

TEST(ExecuteGrasp, FingerLandingOnANeighbourIsACollisionNamingIt) {
  // The neighbour (id 2) spans x = 26..46 mm, under the right finger (25..33 mm).
  const SimScene scene =
      TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.0, 0.0, 0.025}),
                  Place(2, Box({0.02, 0.04, 0.03}, 0.5f, 0.1), {0.036, 0.0, 0.015})});
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.02));
  EXPECT_EQ(e.outcome, GraspOutcome::kCollision) << e.reason;
  EXPECT_EQ(e.instance_id, 2);
  EXPECT_NE(e.reason.find("right finger hits object 2"), std::string::npos) << e.reason;
  EXPECT_NE(e.reason.find("30.00 mm"), std::string::npos) << e.reason;  // its top

  // Turned half a turn, the same neighbour is under the left finger.
  const GraspExecution turned = Execute(scene, GraspAt(0.0, 0.0, 0.02, kPi));
  EXPECT_EQ(turned.outcome, GraspOutcome::kCollision) << turned.reason;
  EXPECT_NE(turned.reason.find("left finger hits object 2"), std::string::npos) << turned.reason;
}

TEST(ExecuteGrasp, FingerLoweredIntoTheTableIsACollisionOnTheSupport) {
  const SimScene scene = TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.0, 0.0, 0.025})});
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, -0.005));
  EXPECT_EQ(e.outcome, GraspOutcome::kCollision) << e.reason;
  EXPECT_EQ(e.instance_id, 0);
  EXPECT_NE(e.reason.find("the support (table)"), std::string::npos) << e.reason;
}

TEST(ExecuteGrasp, BinWallUnderAFingerIsACollisionOnTheSupport) {
  SimScene scene;  // default: a bin with inner floor 0.40 x 0.30 m and 10 cm walls
  scene.objects = {Place(1, Box(kBlockSize, 1.0f, 0.1), {0.178, 0.0, 0.025})};
  // The right finger (x = 0.203..0.211) sits over the +x wall (0.200..0.210).
  const GraspExecution e = Execute(scene, GraspAt(0.178, 0.0, 0.02));
  EXPECT_EQ(e.outcome, GraspOutcome::kCollision) << e.reason;
  EXPECT_EQ(e.instance_id, 0);
  EXPECT_NE(e.reason.find("the support (bin)"), std::string::npos) << e.reason;
}

TEST(ExecuteGrasp, ThinWallBetweenVerticalRaysIsCaughtByHorizontalRays) {
  // A 0.6 mm thick, 10 mm long, 60 mm tall wall inside the right finger's column at
  // x = 29.2..29.8 mm: thinner than the ray grid along x, so only rays across the column find it.
  const SimScene scene =
      TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.0, 0.0, 0.025}),
                  Place(2, Box({0.0006, 0.01, 0.06}, 1.0f, 0.01), {0.0295, 0.0, 0.03})});
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.02));
  EXPECT_EQ(e.outcome, GraspOutcome::kCollision) << e.reason;
  EXPECT_EQ(e.instance_id, 2);
}

TEST(ExecuteGrasp, ObjectWiderThanTheOpeningIsTooWide) {
  const SimScene scene =
      TableScene({Place(3, Box({0.06, 0.04, 0.05}, 1.0f, 0.1), {0.0, 0.0, 0.025})});
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.02));
  EXPECT_EQ(e.outcome, GraspOutcome::kTooWide) << e.reason;
  EXPECT_EQ(e.instance_id, 3);
  EXPECT_NE(e.reason.find("wider than the 50.00 mm opening"), std::string::npos) << e.reason;
}

// ---- Closing. ----

TEST(ExecuteGrasp, NothingBetweenTheFingersIsEmpty) {
  const SimScene scene = TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.0, 0.0, 0.025})});
  const GraspExecution e = Execute(scene, GraspAt(0.12, 0.1, 0.01));
  EXPECT_EQ(e.outcome, GraspOutcome::kEmpty) << e.reason;
  EXPECT_EQ(e.instance_id, 0);
  // Above the block's top the fingers close on air too.
  EXPECT_EQ(Execute(scene, GraspAt(0.0, 0.0, 0.06)).outcome, GraspOutcome::kEmpty);
}

TEST(ExecuteGrasp, TwoTouchingBlocksAreMultipleObjects) {
  const auto half = Box({0.015, 0.04, 0.05}, 1.0f, 0.1);
  const SimScene scene =
      TableScene({Place(4, half, {-0.0075, 0.0, 0.025}), Place(5, half, {0.0075, 0.0, 0.025})});
  const GraspExecution e = Execute(scene, GraspAt(0.0, 0.0, 0.02));
  EXPECT_EQ(e.outcome, GraspOutcome::kMultipleObjects) << e.reason;
  EXPECT_NE(e.reason.find("4, 5"), std::string::npos) << e.reason;
  // Across the seam (along y) both fingers touch both blocks: still two objects.
  const GraspExecution across = Execute(scene, GraspAt(0.0, 0.0, 0.02, kPi / 2));
  EXPECT_EQ(across.outcome, GraspOutcome::kMultipleObjects) << across.reason;
}

// ---- Lift. ----

TEST(ExecuteGrasp, HeavyObjectWithLowFrictionSlipsAndALighterOneIsHeld) {
  core::Gripper gripper;
  gripper.friction_coefficient = 0.2;  // 2 * 0.2 * 10 N = 4 N of friction
  const SimScene heavy = TableScene({Place(1, Box(kBlockSize, 1.0f, 2.0), {0.0, 0.0, 0.025})});
  const GraspExecution slipped = Execute(heavy, GraspAt(0.0, 0.0, 0.02), gripper);
  EXPECT_EQ(slipped.outcome, GraspOutcome::kSlipped) << slipped.reason;
  EXPECT_EQ(slipped.instance_id, 1);
  EXPECT_NE(slipped.reason.find("weight"), std::string::npos) << slipped.reason;
  EXPECT_NEAR(slipped.contact_width_m, 0.030, 0.0005);  // the squeeze happened before the lift

  const double holdable_kg = 2.0 * 0.2 * 10.0 / kGravity;  // 0.408 kg
  const SimScene light =
      TableScene({Place(1, Box(kBlockSize, 1.0f, 0.95 * holdable_kg), {0.0, 0.0, 0.025})});
  EXPECT_TRUE(Execute(light, GraspAt(0.0, 0.0, 0.02), gripper).succeeded());
  const SimScene just_too_heavy =
      TableScene({Place(1, Box(kBlockSize, 1.0f, 1.05 * holdable_kg), {0.0, 0.0, 0.025})});
  EXPECT_EQ(Execute(just_too_heavy, GraspAt(0.0, 0.0, 0.02), gripper).outcome,
            GraspOutcome::kSlipped);
}

TEST(ExecuteGrasp, SlopedContactsOutsideTheFrictionConeSlip) {
  // A roof whose faces' normals are 45 degrees above horizontal: outside the cone for mu = 0.5
  // (26.6 degrees), inside for mu = 1.2 (50.2 degrees).
  const SimScene scene = TableScene({Place(1, Roof(0.02, 0.02, 0.04), {0.0, 0.0, 0.0})});
  const SimGrasp grasp = GraspAt(0.0, 0.0, 0.005);
  const GraspExecution slipped = Execute(scene, grasp);
  EXPECT_EQ(slipped.outcome, GraspOutcome::kSlipped) << slipped.reason;
  EXPECT_NE(slipped.reason.find("45.0 deg"), std::string::npos) << slipped.reason;
  EXPECT_NE(slipped.reason.find("friction cone of 26.6 deg"), std::string::npos) << slipped.reason;
  // First contact on the lowest face row, 0.1 mm above the fingertips: half-width 14.9 mm.
  EXPECT_NEAR(slipped.contact_width_m, 2.0 * 0.0149, 0.0002);

  core::Gripper grippy;
  grippy.friction_coefficient = 1.2;
  EXPECT_TRUE(Execute(scene, grasp, grippy).succeeded());

  // A steep roof (normals 14 degrees above horizontal) is held with mu = 0.5.
  const SimScene steep = TableScene({Place(1, Roof(0.02, 0.08, 0.04), {0.0, 0.0, 0.0})});
  EXPECT_TRUE(Execute(steep, grasp).succeeded());
}

// ---- Camera-frame grasps. ----

/// R_WC of a camera looking straight down with image +u along W +x and +v along W -y.
Eigen::Matrix3d LookingDown() { return Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal(); }

TEST(SimGraspFromCamera, OverheadCameraMapsCentreHeightAndAngle) {
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = LookingDown();
  world_from_camera.translation() = Eigen::Vector3d(0.0, 0.0, 0.55);
  core::Grasp g;
  g.p_CG_m = {0.05, 0.02, 0.5};
  // Closing axis 30 degrees from +u towards +v in the image.
  const double half = kPi / 12.0;
  g.q_CG_wxyz = {std::cos(half), 0.0, 0.0, std::sin(half)};
  g.opening_m = 0.042;
  const SimGrasp s = SimGraspFromCamera(g, world_from_camera);
  EXPECT_NEAR(s.center_x_m, 0.05, 1e-12);
  EXPECT_NEAR(s.center_y_m, -0.02, 1e-12);
  EXPECT_NEAR(s.fingertip_height_m, 0.05, 1e-12);
  // +v is -y in W, so the axis is at -30 degrees = 150 degrees as a line.
  EXPECT_NEAR(s.angle_rad, 5.0 * kPi / 6.0, 1e-12);
  EXPECT_DOUBLE_EQ(s.opening_m, 0.042);
}

TEST(SimGraspFromCamera, YawedAndShiftedCamera) {
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() =
      Eigen::AngleAxisd(kPi / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * LookingDown();
  world_from_camera.translation() = Eigen::Vector3d(0.1, 0.2, 0.6);
  core::Grasp g;
  g.p_CG_m = {0.01, 0.0, 0.4};
  g.q_CG_wxyz = {1.0, 0.0, 0.0, 0.0};  // closing axis = image +u = W +y after the yaw
  g.opening_m = 0.03;
  const SimGrasp s = SimGraspFromCamera(g, world_from_camera);
  EXPECT_NEAR(s.center_x_m, 0.1, 1e-12);
  EXPECT_NEAR(s.center_y_m, 0.21, 1e-12);
  EXPECT_NEAR(s.fingertip_height_m, 0.2, 1e-12);
  EXPECT_NEAR(s.angle_rad, kPi / 2.0, 1e-12);
}

TEST(SimGraspFromCamera, CameraGraspExecutesOnTheBlockBelow) {
  // The block at W (0.05, -0.02); the overhead camera sees its centre at C (0.05, 0.02, 0.53).
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = LookingDown();
  world_from_camera.translation() = Eigen::Vector3d(0.0, 0.0, 0.55);
  core::Grasp g;
  g.p_CG_m = {0.05, 0.02, 0.53};
  g.opening_m = 0.045;
  const SimScene scene = TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.05, -0.02, 0.025})});
  const GraspExecution e = Execute(scene, SimGraspFromCamera(g, world_from_camera));
  ASSERT_TRUE(e.succeeded()) << e.reason;
  EXPECT_NEAR(e.contact_width_m, 0.030, 0.0005);
}

// ---- Picking. ----

TEST(ExecuteAndRemove, RemovesExactlyTheHeldObjectOnSuccess) {
  SimScene scene = TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {-0.08, 0.0, 0.025}),
                               Place(2, Box(kBlockSize, 1.0f, 0.1), {0.08, 0.0, 0.025})});
  auto first = ExecuteAndRemove(&scene, GraspAt(0.08, 0.0, 0.02), core::Gripper{});
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_TRUE(first.value().succeeded()) << first.value().reason;
  EXPECT_EQ(first.value().instance_id, 2);
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(scene.objects[0].instance_id, 1);

  // The same grasp again closes on nothing, and nothing is removed.
  auto again = ExecuteAndRemove(&scene, GraspAt(0.08, 0.0, 0.02), core::Gripper{});
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.value().outcome, GraspOutcome::kEmpty);
  EXPECT_EQ(scene.objects.size(), 1u);

  // A collision removes nothing either.
  auto collided = ExecuteAndRemove(&scene, GraspAt(-0.08, 0.0, -0.01), core::Gripper{});
  ASSERT_TRUE(collided.ok());
  EXPECT_EQ(collided.value().outcome, GraspOutcome::kCollision);
  EXPECT_EQ(scene.objects.size(), 1u);

  // The last one clears the table.
  auto last = ExecuteAndRemove(&scene, GraspAt(-0.08, 0.0, 0.02), core::Gripper{});
  ASSERT_TRUE(last.ok());
  EXPECT_TRUE(last.value().succeeded()) << last.value().reason;
  EXPECT_TRUE(scene.objects.empty());
}

TEST(ExecuteAndRemove, RejectsANullSceneAndAnUnbuildableOne) {
  auto null_scene = ExecuteAndRemove(nullptr, GraspAt(0.0, 0.0, 0.02), core::Gripper{});
  ASSERT_FALSE(null_scene.ok());
  EXPECT_EQ(null_scene.error().code, core::ErrorCode::kInvalidArgument);

  auto broken = std::make_shared<SimObject>(*Box(kBlockSize, 1.0f, 0.1));
  broken->vertex_stiffness.pop_back();
  SimScene scene = TableScene({Place(1, broken, {0.0, 0.0, 0.025})});
  auto result = ExecuteAndRemove(&scene, GraspAt(0.0, 0.0, 0.02), core::Gripper{});
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, core::ErrorCode::kInvalidArgument);
  EXPECT_EQ(scene.objects.size(), 1u);
}

// ---- Bad input. ----

TEST(ExecuteGrasp, RejectsBadGraspsAndGrippers) {
  const SimScene scene = TableScene({Place(1, Box(kBlockSize, 1.0f, 0.1), {0.0, 0.0, 0.025})});
  auto raycaster = SceneRaycaster::Build(scene);
  ASSERT_TRUE(raycaster.ok());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto expect_invalid = [&](const SimGrasp& g, const core::Gripper& p, const char* field) {
    auto result = ExecuteGrasp(scene, raycaster.value(), g, p);
    ASSERT_FALSE(result.ok()) << field;
    EXPECT_EQ(result.error().code, core::ErrorCode::kInvalidArgument) << field;
    EXPECT_EQ(result.error().field, field);
    EXPECT_FALSE(result.error().message.empty());
  };
  const SimGrasp ok_grasp = GraspAt(0.0, 0.0, 0.02);
  const core::Gripper ok_gripper;
  {
    SimGrasp g = ok_grasp;
    g.center_x_m = nan;
    expect_invalid(g, ok_gripper, "center_x_m");
    g = ok_grasp;
    g.fingertip_height_m = inf;
    expect_invalid(g, ok_gripper, "fingertip_height_m");
    g = ok_grasp;
    g.center_y_m = 1e300;  // finite, but no scene is that large (and Embree traces in float)
    expect_invalid(g, ok_gripper, "center_y_m");
    g = ok_grasp;
    g.angle_rad = nan;
    expect_invalid(g, ok_gripper, "angle_rad");
    g = ok_grasp;
    g.opening_m = 0.0;
    expect_invalid(g, ok_gripper, "opening_m");
    g.opening_m = -0.01;
    expect_invalid(g, ok_gripper, "opening_m");
    g.opening_m = ok_gripper.opening_stroke_m + 1e-6;
    expect_invalid(g, ok_gripper, "opening_m");
  }
  {
    core::Gripper p = ok_gripper;
    p.finger_width_m = 0.0;
    expect_invalid(ok_grasp, p, "finger_width_m");
    p = ok_gripper;
    p.max_press_force_n = -1.0;
    expect_invalid(ok_grasp, p, "max_press_force_n");
    p.max_press_force_n = nan;
    expect_invalid(ok_grasp, p, "max_press_force_n");
    p = ok_gripper;
    p.finger_thickness_m = -0.008;
    expect_invalid(ok_grasp, p, "finger_thickness_m");
    p = ok_gripper;
    p.finger_length_m = 0.0;
    expect_invalid(ok_grasp, p, "finger_length_m");
    p = ok_gripper;
    p.finger_length_m = 1e6;  // not a gripper, and millions of rays
    expect_invalid(ok_grasp, p, "finger_length_m");
    p = ok_gripper;
    p.opening_stroke_m = nan;
    expect_invalid(ok_grasp, p, "opening_stroke_m");
    p = ok_gripper;
    p.closing_force_n = 0.0;
    expect_invalid(ok_grasp, p, "closing_force_n");
    p = ok_gripper;
    p.friction_coefficient = -0.1;
    expect_invalid(ok_grasp, p, "friction_coefficient");
  }
  // A camera grasp with a NaN pose becomes a NaN SimGrasp, which is rejected, not executed.
  core::Grasp camera_grasp;
  camera_grasp.p_CG_m = {nan, 0.0, 0.5};
  camera_grasp.opening_m = 0.03;
  expect_invalid(SimGraspFromCamera(camera_grasp, Eigen::Isometry3d::Identity()), ok_gripper,
                 "center_x_m");
  // An opening equal to the stroke is allowed.
  SimGrasp widest = ok_grasp;
  widest.opening_m = ok_gripper.opening_stroke_m;
  EXPECT_TRUE(ExecuteGrasp(scene, raycaster.value(), widest, ok_gripper).ok());
}

}  // namespace
}  // namespace softgrasp::sim
