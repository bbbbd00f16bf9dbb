// Dense bins seen from close above (walls at the image border), as `softgrasp-sim generate
// --objects 15-30 --camera-height 0.32` makes them: the service's preprocessing must find the bin
// floor, and FGE must return grasps. The scenes are those of the dataset with seed 101 (val split)
// in which either used to fail: the floor fit tilted through the pile (scenes 0, 5, 10) or filled
// sensor dropouts along object edges were taken for seams (17, 24). docs/fge.md has the figures
// for the whole set.

#include <gtest/gtest.h>

#include <cmath>

#include "service/core/fge.h"
#include "service/core/finger_clearance.h"
#include "service/core/preprocess.h"
#include "sim/dataset/dataset.h"
#include "sim/dataset/scene_gen.h"
#include "sim/render/render.h"

namespace softgrasp::sim {
namespace {

constexpr double kCameraHeightM = 0.32;
constexpr double kFloorTiltTolRad = 0.03;  // 1.7 deg; the old fits were tilted by 15-60 deg
constexpr double kFloorDistanceTolM = 0.003;

class DenseBinFromClose : public ::testing::TestWithParam<int> {};

TEST_P(DenseBinFromClose, FloorIsFoundAndFgeReturnsGrasps) {
  SceneSpec spec;
  spec.min_objects = 15;
  spec.max_objects = 30;
  spec.split = ShapeSplit::kVal;
  spec.render.world_from_camera = OverheadCameraPose(kCameraHeightM);
  const auto generated = GenerateScene(spec, SceneSeed(101, GetParam(), ShapeSplit::kVal));
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  ASSERT_GE(generated.value().scene.objects.size(), 12u);

  // As the dataset stores it: whole millimetres, 0 = missing.
  core::DepthImage depth;
  DepthToMillimetres(generated.value().views.depth.depth_m).convertTo(depth.depth_m, CV_32F, 1e-3);
  depth.depth_m.setTo(std::numeric_limits<float>::quiet_NaN(), depth.depth_m == 0.0f);
  const auto scene = core::Preprocess(depth, spec.render.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;

  // The camera looks straight down at the support's top (z = 0 in W) from kCameraHeightM.
  const core::Plane& floor = scene.value().floor;
  EXPECT_LT(std::acos(std::min(1.0, -floor.n[2])), kFloorTiltTolRad)
      << "normal " << floor.n[0] << " " << floor.n[1] << " " << floor.n[2];
  EXPECT_NEAR(floor.d, kCameraHeightM, kFloorDistanceTolM);

  const auto grasps = core::DetectGraspsFge(scene.value(), spec.render.camera, core::Gripper{});
  EXPECT_FALSE(grasps.empty());
}

INSTANTIATE_TEST_SUITE_P(Seed101, DenseBinFromClose, ::testing::Values(0, 5, 10, 17, 24));

// Frames as `softgrasp-sim generate` writes them (sensor noise on). In 16 and 21 every one of
// FGE's five best candidates puts a finger through a surface the camera saw (FingerClearance);
// FGE must drop them before top_k, or the service, which answers only clear grasps, has none.
class NoisyDenseBinFromClose : public ::testing::TestWithParam<int> {};

TEST_P(NoisyDenseBinFromClose, FgeDropsBlockedCandidatesBeforeTopK) {
  SceneSpec spec;
  spec.min_objects = 15;
  spec.max_objects = 30;
  spec.split = ShapeSplit::kVal;
  spec.render.world_from_camera = OverheadCameraPose(kCameraHeightM);
  spec.render.noise.enabled = true;
  const auto generated = GenerateScene(spec, SceneSeed(101, GetParam(), ShapeSplit::kVal));
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  core::DepthImage depth;
  DepthToMillimetres(generated.value().views.depth.depth_m).convertTo(depth.depth_m, CV_32F, 1e-3);
  depth.depth_m.setTo(std::numeric_limits<float>::quiet_NaN(), depth.depth_m == 0.0f);
  const auto scene = core::Preprocess(depth, spec.render.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const core::Gripper gripper;
  const core::FingerClearance clearance(scene.value(), spec.render.camera);

  core::FgeParams params;  // top_k 5, as the service answers
  params.check_finger_clearance = false;
  const auto unchecked = core::DetectGraspsFge(scene.value(), spec.render.camera, gripper, params);
  ASSERT_FALSE(unchecked.empty());
  for (const core::Grasp& g : unchecked) {
    EXPECT_FALSE(clearance.Clear(g, gripper)) << "the frame no longer tests the case";
  }
  params.check_finger_clearance = true;
  const auto grasps = core::DetectGraspsFge(scene.value(), spec.render.camera, gripper, params);
  EXPECT_FALSE(grasps.empty());
  for (const core::Grasp& g : grasps) EXPECT_TRUE(clearance.Clear(g, gripper));
}

INSTANTIATE_TEST_SUITE_P(Seed101, NoisyDenseBinFromClose, ::testing::Values(16, 21));

// The simulator's default camera (0.55 m): dense bins of 15-30 objects whose piles reach the
// walls, as `softgrasp-sim generate --objects 15-30` writes them (noise on). On 200 such frames
// (seeds 102 and 103) every one gets grasps (docs/fge.md); three of them are held here.
class NoisyDenseBinDefaultCamera : public ::testing::TestWithParam<int> {};

TEST_P(NoisyDenseBinDefaultCamera, FgeReturnsClearGrasps) {
  SceneSpec spec;
  spec.min_objects = 15;
  spec.max_objects = 30;
  spec.split = ShapeSplit::kVal;
  spec.render.noise.enabled = true;
  const auto generated = GenerateScene(spec, SceneSeed(102, GetParam(), ShapeSplit::kVal));
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  ASSERT_GE(generated.value().scene.objects.size(), 12u);
  core::DepthImage depth;
  DepthToMillimetres(generated.value().views.depth.depth_m).convertTo(depth.depth_m, CV_32F, 1e-3);
  depth.depth_m.setTo(std::numeric_limits<float>::quiet_NaN(), depth.depth_m == 0.0f);
  const auto scene = core::Preprocess(depth, spec.render.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const core::Gripper gripper;
  const auto grasps = core::DetectGraspsFge(scene.value(), spec.render.camera, gripper);
  EXPECT_EQ(grasps.size(), 5u);
  const core::FingerClearance clearance(scene.value(), spec.render.camera);
  for (const core::Grasp& g : grasps) EXPECT_TRUE(clearance.Clear(g, gripper));
}

INSTANTIATE_TEST_SUITE_P(Seed102, NoisyDenseBinDefaultCamera, ::testing::Values(0, 1, 2));

}  // namespace
}  // namespace softgrasp::sim
