// gqcnn::MeasureClearance and ClearanceRule on analytic depth images: a camera looking straight
// down at a table 0.70 m away, blocks standing on it, grasps whose boxes are known in pixels.
#include "service/gqcnn/clearance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace softgrasp::gqcnn {
namespace {

constexpr double kTableZ = 0.70;
constexpr double kFx = 700.0;  // 1 mm per pixel at the table: 1.4 px per mm at 0.5 m
constexpr int kSize = 200;

struct Scene {
  cv::Mat1f depth_m = cv::Mat1f(kSize, kSize, static_cast<float>(kTableZ));
  cv::Mat1f height_m = cv::Mat1f(kSize, kSize, 0.0F);

  // A block whose top is `height` above the table over pixels [u0, u1) x [v0, v1).
  void Block(int u0, int u1, int v0, int v1, double height) {
    for (int v = v0; v < v1; ++v) {
      for (int u = u0; u < u1; ++u) {
        depth_m(v, u) = static_cast<float>(kTableZ - height);
        height_m(v, u) = static_cast<float>(height);
      }
    }
  }
};

// A grasp at pixel (100, 100) along +u at `depth`: at 0.68 m the 5 cm stroke is 51.5 px, the
// 8 mm fingers 8.2 px, the 15 mm finger width 15.4 px.
GraspImagePose Pose(double depth, double angle = 0.0) {
  GraspImagePose pose;
  pose.center_u_px = 100.0;
  pose.center_v_px = 100.0;
  pose.angle_rad = angle;
  pose.depth_m = depth;
  pose.width_px = 0.05 * kFx / depth;
  return pose;
}

TEST(GqcnnClearanceTest, NothingAboveTheFloorLeavesTheGripperClear) {
  Scene scene;
  const GripperClearance c =
      MeasureClearance(scene.depth_m, scene.height_m, Pose(0.69), kFx, core::Gripper{}, 0.008);
  EXPECT_EQ(c.jaws_m, kNothingUnderGripperM);
  EXPECT_EQ(c.palm_m, kNothingUnderGripperM);
  EXPECT_NEAR(c.floor_m, kTableZ - 0.69, 1e-6);
  EXPECT_TRUE(ClearanceRule{}.Admits(c, core::Gripper{}));
}

// The fingertips may come down onto the floor, into its noise, but not below it: a grasp
// centre under the table (a floor plane fitted a few millimetres off) is refused.
TEST(GqcnnClearanceTest, FingersMayComeDownToTheFloorButNotBelowIt) {
  Scene scene;
  const GripperClearance above = MeasureClearance(
      scene.depth_m, scene.height_m, Pose(kTableZ - 0.002), kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(above.floor_m, 0.002, 1e-6);
  EXPECT_TRUE(ClearanceRule{}.Admits(above, core::Gripper{}));
  // Every third table pixel reads 3 mm nearer (noise): the nearest is 1 mm above the grasp
  // centre, within the noise allowed.
  Scene noisy;
  for (int v = 0; v < kSize; ++v) {
    for (int u = 0; u < kSize; ++u) {
      if ((u + v) % 3 == 0) noisy.depth_m(v, u) = static_cast<float>(kTableZ - 0.003);
    }
  }
  const GripperClearance noise = MeasureClearance(
      noisy.depth_m, noisy.height_m, Pose(kTableZ - 0.002), kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(noise.floor_m, -0.001, 1e-6);
  EXPECT_TRUE(ClearanceRule{}.Admits(noise, core::Gripper{}));
  const GripperClearance below = MeasureClearance(
      scene.depth_m, scene.height_m, Pose(kTableZ + 0.004), kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(below.floor_m, -0.004, 1e-6);
  EXPECT_EQ(below.jaws_m, kNothingUnderGripperM);
  EXPECT_FALSE(ClearanceRule{}.Admits(below, core::Gripper{}));
  // A flat object 5 mm high (floor by height) under a finger, 4 mm above the fingertips.
  Scene flat;
  flat.Block(126, 134, 90, 110, 0.005);
  const GripperClearance on_flat = MeasureClearance(
      flat.depth_m, flat.height_m, Pose(kTableZ - 0.001), kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(on_flat.floor_m, -0.004, 1e-6);
  EXPECT_FALSE(ClearanceRule{}.Admits(on_flat, core::Gripper{}));
}

TEST(GqcnnClearanceTest, TheObjectBetweenTheJawsMeetsOnlyThePalm) {
  Scene scene;
  scene.Block(90, 110, 80, 120, 0.04);  // 2 cm wide along the axis, top at 0.66 m
  const double grasp_depth = 0.68;      // 2 cm below the top
  const GripperClearance c = MeasureClearance(scene.depth_m, scene.height_m, Pose(grasp_depth), kFx,
                                              core::Gripper{}, 0.008);
  EXPECT_EQ(c.jaws_m, kNothingUnderGripperM);
  EXPECT_NEAR(c.palm_m, 0.66 - grasp_depth, 1e-6);
  EXPECT_TRUE(ClearanceRule{}.Admits(c, core::Gripper{}));
  // 4 cm below the top the palm's face (3 mm - 40 mm = 3.7 cm above the grasp centre) hits it.
  const GripperClearance deep =
      MeasureClearance(scene.depth_m, scene.height_m, Pose(0.70), kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(deep.palm_m, -0.04, 1e-6);
  EXPECT_FALSE(ClearanceRule{}.Admits(deep, core::Gripper{}));
}

TEST(GqcnnClearanceTest, ANeighbourUnderAFingerBlocksIt) {
  // A neighbour 3 cm tall 28-33 px right of the grasp centre, inside the +u finger's box (26-34
  // px at 0.68 m), and one 40-50 px right, beyond it.
  Scene scene;
  scene.Block(128, 133, 90, 110, 0.03);
  scene.Block(140, 150, 90, 110, 0.06);
  const GripperClearance c =
      MeasureClearance(scene.depth_m, scene.height_m, Pose(0.68), kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(c.jaws_m, 0.67 - 0.68, 1e-6);
  EXPECT_NEAR(c.palm_m, 0.67 - 0.68, 1e-6);
  EXPECT_FALSE(ClearanceRule{}.Admits(c, core::Gripper{}));
  // The same grasp turned by 90 degrees puts its fingers above and below the centre instead.
  const GripperClearance turned = MeasureClearance(
      scene.depth_m, scene.height_m, Pose(0.68, std::numbers::pi / 2), kFx, core::Gripper{}, 0.008);
  EXPECT_EQ(turned.jaws_m, kNothingUnderGripperM);
  EXPECT_TRUE(ClearanceRule{}.Admits(turned, core::Gripper{}));
  // Grasped 5 mm above the neighbour's top, the fingertips (3 mm beyond) stay clear of it.
  const GripperClearance high =
      MeasureClearance(scene.depth_m, scene.height_m, Pose(0.665), kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(high.jaws_m, 0.005, 1e-6);
  EXPECT_TRUE(ClearanceRule{}.Admits(high, core::Gripper{}));
}

// A pixel counts when the box touches it: at 0.68 m the +u finger's outer face is 33.97 px from
// the centre, so a column 34 px away (centre 0.03 px beyond the face) is under it, one 35 px
// away is not.
TEST(GqcnnClearanceTest, EveryPixelABoxTouchesCounts) {
  Scene touched;
  touched.Block(134, 135, 95, 105, 0.03);
  EXPECT_NEAR(
      MeasureClearance(touched.depth_m, touched.height_m, Pose(0.68), kFx, core::Gripper{}, 0.008)
          .jaws_m,
      0.67 - 0.68, 1e-6);
  Scene beside;
  beside.Block(135, 136, 95, 105, 0.03);
  EXPECT_EQ(
      MeasureClearance(beside.depth_m, beside.height_m, Pose(0.68), kFx, core::Gripper{}, 0.008)
          .jaws_m,
      kNothingUnderGripperM);
}

// The pixels each box covers, whatever the angle and the sub-pixel centre: each pixel around
// the grasp is raised alone and must count exactly when its centre lies in the box grown by half
// a pixel (at 0.68 m: stroke 51.47 px, fingers 8.24 px thick and 15.44 px wide).
TEST(GqcnnClearanceTest, ABoxCoversTheSamePixelsAtEveryAngle) {
  const double depth = 0.68, m_per_px = depth / kFx, half_px = 0.5 * m_per_px;
  const core::Gripper gripper;
  const double inner = 0.5 * gripper.opening_stroke_m - half_px;
  const double outer = 0.5 * gripper.opening_stroke_m + gripper.finger_thickness_m + half_px;
  const double half_width = 0.5 * gripper.finger_width_m + half_px;
  Scene scene;
  int jaw_pixels = 0;
  for (const double degrees : {0.0, 7.5, 30.0, 45.0, 60.0, 90.0, 123.0, 180.0, 271.0}) {
    GraspImagePose pose = Pose(depth, degrees * std::numbers::pi / 180.0);
    pose.center_u_px = 100.3;
    pose.center_v_px = 99.6;
    const double ca = std::cos(pose.angle_rad), sa = std::sin(pose.angle_rad);
    for (int v = 55; v <= 145; ++v) {
      for (int u = 55; u <= 145; ++u) {
        const double du = u - pose.center_u_px, dv = v - pose.center_v_px;
        const double along = std::fabs(du * ca + dv * sa) * m_per_px;
        const double across = std::fabs(dv * ca - du * sa) * m_per_px;
        const bool in_box = along <= outer && across <= half_width;
        const bool under_jaw = in_box && along >= inner;
        scene.Block(u, u + 1, v, v + 1, 0.03);
        const GripperClearance c =
            MeasureClearance(scene.depth_m, scene.height_m, pose, kFx, gripper, 0.008);
        scene.Block(u, u + 1, v, v + 1, 0.0);
        ASSERT_EQ(c.palm_m != kNothingUnderGripperM, in_box)
            << degrees << " deg, " << u << ", " << v;
        ASSERT_EQ(c.jaws_m != kNothingUnderGripperM, under_jaw)
            << degrees << " deg, " << u << ", " << v;
        jaw_pixels += under_jaw ? 1 : 0;
      }
    }
  }
  // Two 9 x 16 px fingers per angle, give or take the pixels their edges cut.
  EXPECT_GT(jaw_pixels, 9 * 200);
  EXPECT_LT(jaw_pixels, 9 * 400);
}

TEST(GqcnnClearanceTest, TheFloorMissingReadingsAndPixelsOutsideTheImageDoNotCount) {
  Scene scene;
  // Low bumps (5 mm, under the 8 mm floor margin) and missing readings under both fingers.
  scene.Block(126, 134, 95, 105, 0.005);
  for (int v = 95; v < 105; ++v) {
    scene.depth_m(v, 70) = 0.0F;
    scene.depth_m(v, 72) = std::numeric_limits<float>::quiet_NaN();
    scene.height_m(v, 70) = scene.height_m(v, 72) = 0.1F;
  }
  const GripperClearance c =
      MeasureClearance(scene.depth_m, scene.height_m, Pose(0.69), kFx, core::Gripper{}, 0.008);
  EXPECT_EQ(c.jaws_m, kNothingUnderGripperM);
  EXPECT_NEAR(c.floor_m, 0.695 - 0.69, 1e-6);  // the bumps are floor
  // With no floor margin the bump is an obstacle.
  const GripperClearance strict =
      MeasureClearance(scene.depth_m, scene.height_m, Pose(0.69), kFx, core::Gripper{}, 0.0);
  EXPECT_NEAR(strict.jaws_m, 0.695 - 0.69, 1e-6);
  // A grasp centred beyond the image's left edge sees only the part of its +u finger's box
  // inside the image (28-34 px right of the centre at 0.68 m).
  scene.Block(0, 10, 0, 10, 0.05);
  GraspImagePose corner = Pose(0.68);
  corner.center_u_px = -28.0;
  corner.center_v_px = 5.0;
  const GripperClearance edge =
      MeasureClearance(scene.depth_m, scene.height_m, corner, kFx, core::Gripper{}, 0.008);
  EXPECT_NEAR(edge.jaws_m, 0.65 - 0.68, 1e-6);
}

TEST(GqcnnClearanceTest, BadPosesMeasureNothing) {
  Scene scene;
  scene.Block(0, kSize, 0, kSize, 0.05);
  for (const double depth : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
    const GripperClearance c =
        MeasureClearance(scene.depth_m, scene.height_m, Pose(depth), kFx, core::Gripper{}, 0.008);
    EXPECT_EQ(c.jaws_m, kNothingUnderGripperM);
  }
}

TEST(GqcnnClearanceTest, TheRuleFollowsTheGrippersFingerLength) {
  const GripperClearance c{0.01, -0.05};
  core::Gripper short_fingers;
  EXPECT_FALSE(ClearanceRule{}.Admits(c, short_fingers));  // palm face 37 mm above the centre
  core::Gripper long_fingers;
  long_fingers.finger_length_m = 0.06;
  EXPECT_TRUE(ClearanceRule{}.Admits(c, long_fingers));               // 57 mm
  EXPECT_FALSE(ClearanceRule{}.Admits({0.003, 0.5}, short_fingers));  // tips 3 mm beyond
  EXPECT_TRUE(ClearanceRule{}.Admits({0.0031, 0.5}, short_fingers));
}

}  // namespace
}  // namespace softgrasp::gqcnn
