#include "service/core/finger_clearance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "service/core/fge_geometry.h"
#include "tests/support/synthetic_scene.h"

namespace softgrasp::core {
namespace {

using testing::Box;
using testing::RenderScene;
using testing::SceneSpec;

// A bin wall seen towards the image border: its inner face at x = 0.15 m, 10 mm thick,
// 100 mm tall, and a low box (20 mm) at the other side of the image.
constexpr double kWallInnerXm = 0.15;
constexpr double kWallHeightM = 0.10;

SceneSpec WallScene() {
  SceneSpec spec;
  spec.boxes.push_back(Box{kWallInnerXm + 0.005, 0.0, 0.01, 0.30, kWallHeightM, 0.0, 1});
  spec.boxes.push_back(Box{-0.10, 0.0, 0.06, 0.06, 0.02, 0.0, 2});
  return spec;
}

struct Prepared {
  SceneSpec spec;
  Scene scene;
  Camera camera;
};

Prepared Make() {
  Prepared p{WallScene(), {}, {}};
  const auto synth = RenderScene(p.spec);
  auto scene = Preprocess(synth.depth, synth.camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  p.scene = std::move(scene).value();
  p.camera = synth.camera;
  return p;
}

// A grasp closing along table x, centred at (x, 0), fingertips tip_height_m above the table.
Grasp GraspAt(const Prepared& p, double x_m, double tip_height_m, double opening_m) {
  Grasp g;
  const cv::Point3d c = testing::TableToCamera(p.spec, x_m, 0.0, tip_height_m);
  g.p_CG_m = {c.x, c.y, c.z};
  g.angle_rad = 0;
  g.q_CG_wxyz = fge_detail::QuaternionAboutZ(0);
  g.opening_m = opening_m;
  g.grasp_height_m = tip_height_m;
  const cv::Point2d px = testing::ProjectTablePoint(p.spec, x_m, 0.0, tip_height_m);
  g.center_u_px = px.x;
  g.center_v_px = px.y;
  return g;
}

// An 85 mm grasp, fingertips 50 mm up, whose right finger's outer face lies `past_wall_m` beyond
// the wall's inner face (negative: short of it).
Grasp BesideTheWall(const Prepared& p, const Gripper& gripper, double past_wall_m) {
  const double opening = 0.085;
  return GraspAt(p, kWallInnerXm + past_wall_m - opening / 2 - gripper.finger_thickness_m, 0.05,
                 opening);
}

TEST(FingerClearanceTest, AFingerOverlappingTheWallTopByTwoMillimetresIsBlocked) {
  const Prepared p = Make();
  Gripper gripper;  // 15 mm wide, 8 mm thick fingers
  // The wall's top (100 mm) stands in the right finger's column.
  const Grasp g = BesideTheWall(p, gripper, 0.002);
  const FingerClearance clearance(p.scene, p.camera);
  // The wall top seen by the pixels of a 2 x 15 mm strip at 0.5 m (0.95 mm per pixel): about 2 x
  // 16 points, plus the inner face's points above the fingertips.
  EXPECT_GE(clearance.PointsInFingers(g, gripper), 20);
  EXPECT_FALSE(clearance.Clear(g, gripper));
}

TEST(FingerClearanceTest, TwoMillimetresFromTheWallIsClearHalfAMillimetreIsNot) {
  // The finger box is grown by FingerClearance::kMarginM (1 mm) on every side.
  const Prepared p = Make();
  Gripper gripper;
  const FingerClearance clearance(p.scene, p.camera);
  const Grasp clear = BesideTheWall(p, gripper, -0.002);
  EXPECT_EQ(clearance.PointsInFingers(clear, gripper), 0);
  EXPECT_TRUE(clearance.Clear(clear, gripper));
  EXPECT_FALSE(clearance.Clear(BesideTheWall(p, gripper, -0.0005), gripper));
}

TEST(FingerClearanceTest, SurfacesBelowTheFingertipsAreNotInTheWay) {
  const Prepared p = Make();
  Gripper gripper;
  // Both fingers over the 20 mm box (60 mm wide; opening 30 mm, so each finger stands on it).
  const FingerClearance clearance(p.scene, p.camera);
  EXPECT_EQ(clearance.PointsInFingers(GraspAt(p, -0.10, 0.025, 0.03), gripper), 0);
  // Fingertips at 10 mm: the box top (20 mm, 0.58 m from the camera) fills each finger's 8 x
  // 15 mm footprint grown by the 1 mm margin, seen with pixels 0.58 / 525 m apart: about 139
  // points.
  const double pitch_m = 0.58 / p.camera.fx;
  const double m = 2 * FingerClearance::kMarginM;
  const double expected =
      (gripper.finger_thickness_m + m) * (gripper.finger_width_m + m) / (pitch_m * pitch_m);
  EXPECT_NEAR(clearance.PointsInFingers(GraspAt(p, -0.10, 0.010, 0.03), gripper), expected, 12);
}

TEST(FingerClearanceTest, HeightsOfTheSceneDecideWhatStandsAboveTheFingertips) {
  // A planner's view lowers the surfaces a finger may press into: the same finger then passes.
  Prepared p = Make();
  Gripper gripper;
  const Grasp g = BesideTheWall(p, gripper, 0.002);
  p.scene.height_m = cv::min(p.scene.height_m, 0.04f);
  const FingerClearance clearance(p.scene, p.camera);
  EXPECT_EQ(clearance.PointsInFingers(g, gripper), 0);
}

TEST(FingerClearanceTest, ASurfaceAlmostAtTheCameraStillGivesABoundedSearch) {
  // One pixel 1 um from the camera: the finger columns' image then spans far beyond the frame;
  // the search stays inside it and still finds the wall.
  Prepared p = Make();
  p.scene.depth_filled_m(0, 0) = 1e-6f;
  Gripper gripper;
  const FingerClearance clearance(p.scene, p.camera);
  EXPECT_GE(clearance.PointsInFingers(BesideTheWall(p, gripper, 0.002), gripper), 20);
  EXPECT_EQ(clearance.PointsInFingers(BesideTheWall(p, gripper, -0.002), gripper), 0);
}

TEST(FingerClearanceTest, AnEmptySceneOrAGraspBehindTheCameraBlocksNothing) {
  Prepared p = Make();
  Gripper gripper;
  Grasp g = GraspAt(p, 0.0, 0.05, 0.085);
  g.p_CG_m[2] = -0.1;
  EXPECT_EQ(FingerClearance(p.scene, p.camera).PointsInFingers(g, gripper), 0);
  g = GraspAt(p, 0.0, 0.05, 0.085);
  g.p_CG_m[0] = std::nan("");
  EXPECT_EQ(FingerClearance(p.scene, p.camera).PointsInFingers(g, gripper), 0);
  Scene empty;
  EXPECT_EQ(FingerClearance(empty, p.camera).PointsInFingers(GraspAt(p, 0.0, 0.05, 0.085), gripper),
            0);
}

}  // namespace
}  // namespace softgrasp::core
