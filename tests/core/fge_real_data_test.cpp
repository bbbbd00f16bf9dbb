// Preprocess + FGE on real depth frames from the GQ-CNN example data (Primesense, Photoneo).
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <string>

#include "service/core/fge.h"
#include "service/core/preprocess.h"
#include "tests/support/grasp_footprint.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_data.h"

namespace softgrasp::core {
namespace {

constexpr double kFingerHeightTolM = 0.002;  // fingers may touch surfaces this much above the tips
const std::string kData = testing::TestData("gqcnn");

Camera Primesense() { return Camera{525.0, 525.0, 319.5, 239.5, 640, 480}; }
Camera Phoxi() { return Camera{552.5, 552.5, 255.5, 191.75, 516, 386}; }

Scene Prepare(const std::string& npy, const Camera& camera) {
  const DepthImage depth{testing::LoadNpyFloat32(npy)};
  auto scene = Preprocess(depth, camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  return std::move(scene).value();
}

class PrimesenseSingleObject : public ::testing::TestWithParam<int> {};

TEST_P(PrimesenseSingleObject, BestGraspIsOnTheObjectAndFingersAreFree) {
  const int i = GetParam();
  const std::string stem = kData + "/primesense/single_";
  const Scene scene = Prepare(stem + "depth_" + std::to_string(i) + ".npy", Primesense());
  const cv::Mat1b mask =
      cv::imread(stem + "segmask_" + std::to_string(i) + ".png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(mask.empty());
  ASSERT_EQ(mask.size(), scene.height_m.size());

  const auto grasps = DetectGraspsFge(scene, Primesense(), Gripper{});
  ASSERT_FALSE(grasps.empty());
  const Grasp& best = grasps.front();
  const int u = static_cast<int>(std::lround(best.center_u_px));
  const int v = static_cast<int>(std::lround(best.center_v_px));
  EXPECT_GT(mask(v, u), 0) << "best grasp at " << u << "," << v << " is off the object";

  const auto fp = testing::RasteriseGrasp(best, mask.size());
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (!fp.fingers(y, x)) continue;
      EXPECT_LE(scene.height_m(y, x), best.grasp_height_m + kFingerHeightTolM)
          << "finger covers a surface at " << x << "," << y;
    }
  }
}

// The wrist camera's fingers at 0.544 m reach down to the table: the cut at 0.6 m takes their
// base, the fill what is joined to it (thousands of pixels more), and none of the object.
TEST_P(PrimesenseSingleObject, MinimumDepthExcludesTheWholeFingersAndNoneOfTheObject) {
  const int i = GetParam();
  const std::string stem = kData + "/primesense/single_";
  Scene scene = Prepare(stem + "depth_" + std::to_string(i) + ".npy", Primesense());
  const cv::Mat1b mask =
      cv::imread(stem + "segmask_" + std::to_string(i) + ".png", cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(mask.size(), scene.height_m.size());
  RestrictContact(scene, {}, 0.6);
  const int excluded = cv::countNonZero(scene.contact_allowed == 0);
  const int nearer = cv::countNonZero(scene.depth_filled_m < 0.6f);
  EXPECT_GT(excluded, nearer + 5000) << "the fingers' deeper parts are excluded too";
  EXPECT_EQ(cv::countNonZero((scene.contact_allowed == 0) & (mask > 0)), 0);
}

INSTANTIATE_TEST_SUITE_P(Frames, PrimesenseSingleObject, ::testing::Values(0, 1, 2));

TEST(PhoxiClutter, FindsAGraspDespiteMissingPixels) {
  const Scene scene = Prepare(kData + "/phoxi/clutter_depth_0.npy", Phoxi());
  EXPECT_GT(scene.missing_fraction, 0.25);
  const auto grasps = DetectGraspsFge(scene, Phoxi(), Gripper{});
  EXPECT_FALSE(grasps.empty());
}

}  // namespace
}  // namespace softgrasp::core
