#include "service/core/preprocess.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "tests/support/synthetic_scene.h"

namespace softgrasp::core {
namespace {

using testing::Box;
using testing::RenderScene;
using testing::SceneSpec;

constexpr double kHeightTolM = 0.001;  // heights from an exact scene
constexpr double kFlatTolM = 1e-4;     // a bare table is flat to well under a millimetre
constexpr double kNormalTolRad = 0.2 * std::numbers::pi / 180;
constexpr double kFilledTolM = 0.005;  // inpainted table pixels
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

double MaxAbsHeightWhere(const Scene& scene, const cv::Mat1b& mask, double expected) {
  double worst = 0;
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      if (mask(v, u)) worst = std::max(worst, std::abs(scene.height_m(v, u) - expected));
    }
  }
  return worst;
}

// Largest |height - exact height| over the image.
double MaxHeightError(const Scene& scene, const testing::SyntheticScene& synth) {
  cv::Mat1f error;
  cv::absdiff(scene.height_m, synth.height_m, error);
  double worst = 0;
  cv::minMaxLoc(error, nullptr, &worst);
  return worst;
}

// Pixels of one object, away from its silhouette edges by `margin_px`.
cv::Mat1b ObjectInterior(const cv::Mat1i& ids, int id, int margin_px = 2) {
  cv::Mat1b mask = ids == id;
  cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), margin_px);
  return mask;
}

TEST(Preprocess, FlatTableHasZeroHeight) {
  const auto synth = RenderScene(SceneSpec{});
  const auto scene = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_NEAR(scene.value().floor.d, 0.6, 1e-4);
  EXPECT_NEAR(scene.value().floor.n[2], -1.0, 1e-6);
  EXPECT_EQ(scene.value().missing_fraction, 0.0);
  EXPECT_LT(MaxAbsHeightWhere(scene.value(), cv::Mat1b(synth.object_id.size(), 255), 0.0),
            kFlatTolM);
}

TEST(Preprocess, BoxHeightAboveTable) {
  SceneSpec spec;
  spec.boxes = {Box{0.02, -0.03, 0.06, 0.10, 0.040, 0.4, 1}};
  const auto synth = RenderScene(spec);
  const auto scene = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_LT(MaxAbsHeightWhere(scene.value(), ObjectInterior(synth.object_id, 1), 0.040),
            kHeightTolM);
  EXPECT_LT(MaxHeightError(scene.value(), synth), kHeightTolM);
}

TEST(Preprocess, TiltedTableIsRecovered) {
  SceneSpec spec;
  spec.table_tilt_rad = 15 * std::numbers::pi / 180;
  spec.boxes = {Box{-0.05, 0.02, 0.05, 0.05, 0.030, 0.0, 1}};
  const auto synth = RenderScene(spec);
  const auto scene = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  // The table normal (0, 0, 1) in table coordinates, seen from the camera.
  const cv::Point3d up =
      testing::TableToCamera(spec, 0, 0, 1) - testing::TableToCamera(spec, 0, 0, 0);
  const auto& n = scene.value().floor.n;
  const double cos_err = n[0] * up.x + n[1] * up.y + n[2] * up.z;
  EXPECT_GT(cos_err, std::cos(kNormalTolRad));
  EXPECT_LT(MaxHeightError(scene.value(), synth), kHeightTolM);  // box top, sides and table
}

TEST(Preprocess, FloorFoundUnderALargeObject) {
  SceneSpec spec;  // the box top covers about 45 % of the image
  spec.boxes = {Box{0.0, 0.0, 0.45, 0.35, 0.050, 0.0, 1}};
  const auto synth = RenderScene(spec);
  const auto scene = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_NEAR(scene.value().floor.d, 0.6, 1e-3);
  EXPECT_LT(MaxAbsHeightWhere(scene.value(), ObjectInterior(synth.object_id, 1), 0.050),
            kHeightTolM);
}

TEST(Preprocess, MissingPixelsAreFilled) {
  SceneSpec spec;
  spec.boxes = {Box{0.08, 0.05, 0.05, 0.05, 0.040, 0.0, 1}};
  auto synth = RenderScene(spec);
  cv::Mat1b holes = cv::Mat1b::zeros(synth.depth.depth_m.size());
  holes(cv::Rect(100, 120, 80, 60)).setTo(255);  // a large hole on the table
  for (int v = 0; v < holes.rows; v += 7) holes.row(v).colRange(300, 420).setTo(255);
  synth.depth.depth_m.setTo(kNaN, holes);
  synth.depth.depth_m(10, 10) = 0.0f;  // zero counts as missing too
  holes(10, 10) = 255;
  const double expected_missing = static_cast<double>(cv::countNonZero(holes)) / holes.total();

  const auto scene = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const Scene& s = scene.value();
  EXPECT_NEAR(s.missing_fraction, expected_missing, 1e-12);
  EXPECT_EQ(cv::countNonZero(s.missing_mask != holes), 0);
  for (int v = 0; v < holes.rows; ++v) {
    for (int u = 0; u < holes.cols; ++u) {
      ASSERT_TRUE(std::isfinite(s.depth_filled_m(v, u)) && s.depth_filled_m(v, u) > 0)
          << "pixel " << u << "," << v;
    }
  }
  cv::Mat1b table_holes = holes & (synth.object_id == testing::kTableId);
  cv::erode(table_holes, table_holes, cv::Mat(), cv::Point(-1, -1), 3);
  EXPECT_LT(MaxAbsHeightWhere(s, table_holes, 0.0), kFilledTolM);
}

TEST(Preprocess, SameInputSamePlane) {
  SceneSpec spec;
  spec.table_tilt_rad = 0.1;
  spec.boxes = {Box{0.0, 0.0, 0.05, 0.08, 0.04, 0.2, 1}};
  const auto synth = RenderScene(spec);
  const auto a = Preprocess(synth.depth, synth.camera);
  const auto b = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a.value().floor.n, b.value().floor.n);
  EXPECT_EQ(a.value().floor.d, b.value().floor.d);
}

TEST(Preprocess, AllMissingIsUnprocessable) {
  DepthImage depth{cv::Mat1f(480, 640, kNaN)};
  const auto scene = Preprocess(depth, Camera{});
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().code, ErrorCode::kUnprocessable);
}

TEST(Preprocess, AlmostAllMissingIsUnprocessable) {
  DepthImage depth{cv::Mat1f(480, 640, 0.0f)};
  depth.depth_m(cv::Rect(0, 0, 40, 40)).setTo(0.6f);  // 0.5 % valid
  const auto scene = Preprocess(depth, Camera{});
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().code, ErrorCode::kUnprocessable);
}

TEST(Preprocess, RejectsEmptyImageAndBadIntrinsics) {
  EXPECT_EQ(Preprocess(DepthImage{}, Camera{}).error().code, ErrorCode::kInvalidArgument);
  Camera bad;
  bad.fx = 0;
  const auto synth = RenderScene(SceneSpec{});
  EXPECT_EQ(Preprocess(synth.depth, bad).error().code, ErrorCode::kInvalidArgument);
}

// A wrist camera's finger reaches down towards the table: min_depth_m cuts its base, and the
// rest of it, joined to the base without a height step, is excluded too. A block touching its
// tip across a 3 cm step, a box elsewhere and the table stay graspable.
TEST(RestrictContact, SurfacesJoinedToANearSurfaceAreExcludedToo) {
  SceneSpec spec;  // camera 0.6 m above the table, looking straight down
  spec.boxes = {Box{0.06, 0.0, 0.03, 0.04, 0.040, 0.0, 2}};
  auto synth = RenderScene(spec);
  const cv::Rect finger(150, 200, 101, 80), block(251, 200, 30, 80);
  for (int v = finger.y; v < finger.y + finger.height; ++v) {
    for (int u = finger.x; u < finger.x + finger.width; ++u) {  // 0.20 m high down to 0.02 m
      synth.depth.depth_m(v, u) = static_cast<float>(0.6 - (0.20 - 0.18 * (u - finger.x) / 100.0));
    }
  }
  synth.depth.depth_m(block).setTo(0.6 - 0.05);
  auto scene = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  constexpr double kMinDepthM = 0.5;
  ASSERT_GT(cv::countNonZero(synth.depth.depth_m(finger) >= kMinDepthM), 0)
      << "part of the finger must lie beyond the cut";
  RestrictContact(scene.value(), {}, kMinDepthM);
  const cv::Mat1b& allowed = scene.value().contact_allowed;
  EXPECT_EQ(cv::countNonZero(allowed(finger)), 0);
  EXPECT_EQ(cv::countNonZero(allowed(block)), block.area());
  const cv::Mat1b box = ObjectInterior(synth.object_id, 2);
  EXPECT_EQ(cv::countNonZero(allowed & box), cv::countNonZero(box));
  const cv::Rect table_corner(0, 0, 100, 100);
  EXPECT_EQ(cv::countNonZero(allowed(table_corner)), table_corner.area());
}

}  // namespace
}  // namespace softgrasp::core
