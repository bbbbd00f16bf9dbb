// Dense bins seen from close above (walls at the image border), as `softgrasp-sim generate
// --objects 15-30 --camera-height 0.32` makes them: the service's preprocessing must find the bin
// floor, and FGE must return grasps. The scenes are those of the dataset with seed 101 (val split)
// in which either used to fail: the floor fit tilted through the pile (scenes 0, 5, 10) or filled
// sensor dropouts along object edges were taken for seams (17, 24). docs/fge.md has the figures
// for the whole set. Further down: noisy frames as the CLI writes them, from close and from the
// default camera.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "service/core/fge.h"
#include "service/core/finger_clearance.h"
#include "service/core/preprocess.h"
#include "sim/dataset/dataset.h"
#include "sim/dataset/scene_gen.h"
#include "sim/render/render.h"

namespace softgrasp::sim {
namespace {

constexpr double kCloseCameraM = 0.32;
constexpr double kFloorTiltTolRad = 0.03;  // 1.7 deg; the old fits were tilted by 15-60 deg
constexpr double kFloorDistanceTolM = 0.003;

// A val-split bin of 15-30 objects, seen straight down from `camera_height_m`, its depth as the
// dataset stores it (whole millimetres, 0 = missing), preprocessed as the service does.
struct DenseFrame {
  core::Scene scene;
  core::Camera camera;
};

DenseFrame MakeDenseFrame(std::uint64_t dataset_seed, int index, double camera_height_m,
                          bool noise) {
  SceneSpec spec;
  spec.min_objects = 15;
  spec.max_objects = 30;
  spec.split = ShapeSplit::kVal;
  spec.render.world_from_camera = OverheadCameraPose(camera_height_m);
  spec.render.noise.enabled = noise;
  const auto generated = GenerateScene(spec, SceneSeed(dataset_seed, index, ShapeSplit::kVal));
  if (!generated.ok()) throw std::runtime_error(generated.error().message);
  if (generated.value().scene.objects.size() < 12u) throw std::runtime_error("not a dense bin");
  core::DepthImage depth;
  DepthToMillimetres(generated.value().views.depth.depth_m).convertTo(depth.depth_m, CV_32F, 1e-3);
  depth.depth_m.setTo(std::numeric_limits<float>::quiet_NaN(), depth.depth_m == 0.0f);
  auto scene = core::Preprocess(depth, spec.render.camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  return {std::move(scene).value(), spec.render.camera};
}

class DenseBinFromClose : public ::testing::TestWithParam<int> {};

TEST_P(DenseBinFromClose, FloorIsFoundAndFgeReturnsGrasps) {
  const DenseFrame f = MakeDenseFrame(101, GetParam(), kCloseCameraM, /*noise=*/false);
  // The camera looks straight down at the support's top (z = 0 in W) from kCloseCameraM.
  const core::Plane& floor = f.scene.floor;
  EXPECT_LT(std::acos(std::min(1.0, -floor.n[2])), kFloorTiltTolRad)
      << "normal " << floor.n[0] << " " << floor.n[1] << " " << floor.n[2];
  EXPECT_NEAR(floor.d, kCloseCameraM, kFloorDistanceTolM);
  EXPECT_FALSE(core::DetectGraspsFge(f.scene, f.camera, core::Gripper{}).empty());
}

INSTANTIATE_TEST_SUITE_P(Seed101, DenseBinFromClose, ::testing::Values(0, 5, 10, 17, 24));

// Frames as `softgrasp-sim generate` writes them (sensor noise on). In 16 and 21 every one of
// FGE's five best candidates puts a finger through a surface the camera saw (FingerClearance);
// FGE must drop them before top_k, or the service, which answers only clear grasps, has none.
class NoisyDenseBinFromClose : public ::testing::TestWithParam<int> {};

TEST_P(NoisyDenseBinFromClose, FgeDropsBlockedCandidatesBeforeTopK) {
  const DenseFrame f = MakeDenseFrame(101, GetParam(), kCloseCameraM, /*noise=*/true);
  const core::Gripper gripper;
  const core::FingerClearance clearance(f.scene, f.camera);
  core::FgeParams params;  // top_k 5, as the service answers
  params.check_finger_clearance = false;
  const auto unchecked = core::DetectGraspsFge(f.scene, f.camera, gripper, params);
  ASSERT_FALSE(unchecked.empty());
  for (const core::Grasp& g : unchecked) {
    EXPECT_FALSE(clearance.Clear(g, gripper)) << "the frame no longer tests the case";
  }
  params.check_finger_clearance = true;
  const auto grasps = core::DetectGraspsFge(f.scene, f.camera, gripper, params);
  EXPECT_FALSE(grasps.empty());
  for (const core::Grasp& g : grasps) EXPECT_TRUE(clearance.Clear(g, gripper));
}

INSTANTIATE_TEST_SUITE_P(Seed101, NoisyDenseBinFromClose, ::testing::Values(16, 21));

// The simulator's default camera (0.55 m), noise on: on 200 such frames (seeds 102 and 103)
// every one gets grasps (docs/fge.md); three of them are held here.
class NoisyDenseBinDefaultCamera : public ::testing::TestWithParam<int> {};

TEST_P(NoisyDenseBinDefaultCamera, FgeReturnsClearGrasps) {
  const DenseFrame f = MakeDenseFrame(102, GetParam(), 0.55, /*noise=*/true);
  const core::Gripper gripper;
  const auto grasps = core::DetectGraspsFge(f.scene, f.camera, gripper);
  EXPECT_EQ(grasps.size(), 5u);
  const core::FingerClearance clearance(f.scene, f.camera);
  for (const core::Grasp& g : grasps) EXPECT_TRUE(clearance.Clear(g, gripper));
}

INSTANTIATE_TEST_SUITE_P(Seed102, NoisyDenseBinDefaultCamera, ::testing::Values(0, 1, 2));

}  // namespace
}  // namespace softgrasp::sim
