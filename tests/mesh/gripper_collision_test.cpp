// Gripper collision checks on analytic scenes: the swept boxes' geometry, a 4 cm cube between
// open jaws (free with a 5 cm stroke, hit with a 3.8 cm one), the palm meeting the cube's top,
// fingertips reaching into the table exactly at the clearance, an obstacle above the grasp met
// only by a long enough approach path, and the top-down approach angle of tilted axes.
#include "service/mesh_grasps/gripper_collision.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "tests/support/box_mesh.h"

namespace softgrasp::mesh {
namespace {

using testing::BoxMesh;
using testing::CentredBoxMesh;

// Two meshes as one (the second's indices shifted).
TriangleMesh Join(const TriangleMesh& a, const TriangleMesh& b) {
  TriangleMesh out = a;
  const int offset = static_cast<int>(a.vertices.size());
  out.vertices.insert(out.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (const auto& f : b.faces) out.faces.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
  return out;
}

// A grasp across x through `center`, contacts on the cube's +-x sides.
JawGrasp XGrasp(const Eigen::Vector3d& center, double half_width) {
  JawGrasp g;
  g.center_m = center;
  g.axis = Eigen::Vector3d::UnitX();
  g.width_m = 2 * half_width;
  g.a.point_m = center + half_width * Eigen::Vector3d::UnitX();
  g.b.point_m = center - half_width * Eigen::Vector3d::UnitX();
  return g;
}

// The cube resting on its -z face: the table is z < -0.02 in O (pose rotation = identity).
StablePose RestingOnBottom() {
  StablePose pose;
  pose.table_from_object_translation = Eigen::Vector3d(0, 0, 0.02);
  pose.face_normal_object = -Eigen::Vector3d::UnitZ();
  return pose;
}

GripperCollisionChecker Checker(const TriangleMesh& mesh, const GripperBoxes& gripper,
                                double approach_m) {
  auto checker = GripperCollisionChecker::Build(mesh, gripper, approach_m);
  EXPECT_TRUE(checker.ok()) << checker.error().message;
  return std::move(checker).value();
}

const Eigen::Vector3d kDown = -Eigen::Vector3d::UnitZ();

TEST(GripperCollisionTest, SweptBoxesHaveTheGripperGeometry) {
  const GripperBoxes g;  // stroke 50, width 15, thickness 8, length 40, tip 5, palm 20 (mm)
  const std::vector<BoxInG> boxes = SweptGripperBoxes(g, 0.1);
  ASSERT_EQ(boxes.size(), 3u);
  // Jaws: x in [25, 33] mm and mirrored, y +-7.5 mm, z from 5 mm down to 5 - 40 - 100 mm.
  EXPECT_NEAR(boxes[0].center_m.x(), 0.029, 1e-12);
  EXPECT_NEAR(boxes[1].center_m.x(), -0.029, 1e-12);
  EXPECT_NEAR(boxes[0].half_extent_m.x(), 0.004, 1e-12);
  EXPECT_NEAR(boxes[0].half_extent_m.y(), 0.0075, 1e-12);
  EXPECT_NEAR(boxes[0].center_m.z() + boxes[0].half_extent_m.z(), 0.005, 1e-12);
  EXPECT_NEAR(boxes[0].center_m.z() - boxes[0].half_extent_m.z(), -0.135, 1e-12);
  // Palm: spans both jaws (x +-33 mm), from the fingers' root (-35 mm) back 20 + 100 mm.
  EXPECT_NEAR(boxes[2].half_extent_m.x(), 0.033, 1e-12);
  EXPECT_NEAR(boxes[2].center_m.z() + boxes[2].half_extent_m.z(), -0.035, 1e-12);
  EXPECT_NEAR(boxes[2].center_m.z() - boxes[2].half_extent_m.z(), -0.155, 1e-12);
  EXPECT_THROW(SweptGripperBoxes(g, -0.01), std::invalid_argument);
  GripperBoxes bad = g;
  bad.fingertip_depth_m = bad.finger_length_m;
  EXPECT_THROW(SweptGripperBoxes(bad, 0.1), std::invalid_argument);
}

TEST(GripperCollisionTest, OpenJawsPassACubeNarrowerThanTheStroke) {
  const TriangleMesh cube = CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  const JawGrasp grasp = XGrasp(Eigen::Vector3d::Zero(), 0.02);
  GripperBoxes g;
  EXPECT_FALSE(Checker(cube, g, 0.1).Collides(GripperPose(grasp, kDown)));
  g.opening_m = 0.038;  // the jaws start inside the 40 mm cube
  EXPECT_TRUE(Checker(cube, g, 0.1).Collides(GripperPose(grasp, kDown)));
  // Approaching along the axis is no approach: the pose is re-orthogonalised, never degenerate.
  const Eigen::Isometry3d pose = GripperPose(grasp, Eigen::Vector3d::UnitX());
  EXPECT_NEAR(pose.linear().determinant(), 1.0, 1e-12);
}

TEST(GripperCollisionTest, ThePalmMeetsTheTopOfTheCubeWhenTheFingersAreShort) {
  const TriangleMesh cube = CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  const JawGrasp grasp = XGrasp(Eigen::Vector3d::Zero(), 0.02);
  GripperBoxes g;
  // Tip 5 mm below the centre: the palm starts 30 mm above it with 35 mm fingers (free), 10 mm
  // above it with 15 mm fingers, inside the cube (its top is at 20 mm).
  g.finger_length_m = 0.035;
  EXPECT_FALSE(Checker(cube, g, 0.1).Collides(GripperPose(grasp, kDown)));
  g.finger_length_m = 0.015;
  EXPECT_TRUE(Checker(cube, g, 0.1).Collides(GripperPose(grasp, kDown)));
}

TEST(GripperCollisionTest, FingertipsEnterTheTableBeyondTheClearance) {
  const TriangleMesh cube = CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  GripperBoxes g;
  g.finger_length_m = 0.06;  // the palm stays 55 mm above the grasp centre, clear of the cube
  const GripperCollisionChecker checker = Checker(cube, g, 0.1);
  const TableInObject table = TableInObject::Under(RestingOnBottom(), 0.005);
  EXPECT_NEAR(table.down_o.z(), -1.0, 1e-12);
  EXPECT_NEAR(table.offset_m, 0.025, 1e-12);  // inside the table below z = -0.025
  // Fingertips 5 mm below the grasp centre: centre at -19.9 mm -> tips at -24.9 mm (free);
  // centre at -20.1 mm -> tips at -25.1 mm (in the table).
  EXPECT_FALSE(checker.Collides(GripperPose(XGrasp({0, 0, -0.0199}, 0.02), kDown), &table));
  EXPECT_TRUE(checker.Collides(GripperPose(XGrasp({0, 0, -0.0201}, 0.02), kDown), &table));
  // Without the table the same pose is free.
  EXPECT_FALSE(checker.Collides(GripperPose(XGrasp({0, 0, -0.0201}, 0.02), kDown)));
}

TEST(GripperCollisionTest, AnObstacleAboveIsMetOnlyByALongEnoughApproach) {
  // A lid 100-110 mm above the cube's centre, wider than the gripper.
  const TriangleMesh scene =
      Join(CentredBoxMesh(Eigen::Vector3d::Constant(0.02)),
           BoxMesh(Eigen::Vector3d(-0.1, -0.1, 0.1), Eigen::Vector3d(0.1, 0.1, 0.11)));
  const JawGrasp grasp = XGrasp(Eigen::Vector3d::Zero(), 0.02);
  const GripperBoxes g;
  // The palm's back face is 55 mm + the approach distance above the centre.
  EXPECT_FALSE(Checker(scene, g, 0.04).Collides(GripperPose(grasp, kDown)));
  EXPECT_TRUE(Checker(scene, g, 0.06).Collides(GripperPose(grasp, kDown)));
  // From below (approach +z) the lid is behind the object, out of the way.
  EXPECT_FALSE(Checker(scene, g, 0.1).Collides(GripperPose(grasp, Eigen::Vector3d::UnitZ())));
}

TEST(GripperCollisionTest, TopDownApproachAngleIsTheAxisTiltFromTheTable) {
  const StablePose pose = RestingOnBottom();
  for (const double tilt_deg : {0.0, 4.0, 30.0, 60.0}) {
    const double tilt = tilt_deg * std::numbers::pi / 180.0;
    JawGrasp g = XGrasp(Eigen::Vector3d::Zero(), 0.02);
    g.axis = Eigen::Vector3d(std::cos(tilt), 0.0, std::sin(tilt));
    const TopDownApproach approach = ApproachFromAbove(g, pose);
    EXPECT_NEAR(approach.table_angle_rad, tilt, 1e-12) << tilt_deg;
    EXPECT_NEAR(approach.approach_o.dot(g.axis), 0.0, 1e-12);
    EXPECT_NEAR(approach.approach_o.norm(), 1.0, 1e-12);
  }
  JawGrasp vertical = XGrasp(Eigen::Vector3d::Zero(), 0.02);
  vertical.axis = Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(ApproachFromAbove(vertical, pose).table_angle_rad, std::numbers::pi / 2, 1e-12);
  // An offset turns the approach about the axis.
  const JawGrasp g = XGrasp(Eigen::Vector3d::Zero(), 0.02);
  const Eigen::Vector3d turned = RotateApproach(g, kDown, std::numbers::pi / 2);
  EXPECT_NEAR(std::abs(turned.y()), 1.0, 1e-12);
}

TEST(GripperCollisionTest, BuildRefusesBadMeshesAndSizes) {
  TriangleMesh empty;
  EXPECT_EQ(GripperCollisionChecker::Build(empty, {}, 0.1).error().code,
            core::ErrorCode::kInvalidArgument);
  TriangleMesh bad_index = CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  bad_index.faces[0][1] = 99;
  EXPECT_EQ(GripperCollisionChecker::Build(bad_index, {}, 0.1).error().field, "mesh");
  TriangleMesh nan = CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  nan.vertices[0][0] = std::nan("");
  EXPECT_EQ(GripperCollisionChecker::Build(nan, {}, 0.1).error().field, "mesh");
  GripperBoxes zero;
  zero.finger_width_m = 0.0;
  EXPECT_EQ(
      GripperCollisionChecker::Build(CentredBoxMesh(Eigen::Vector3d::Constant(0.02)), zero, 0.1)
          .error()
          .field,
      "gripper");
}

}  // namespace
}  // namespace softgrasp::mesh
