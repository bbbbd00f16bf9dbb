// Depth colour maps and grasp overlays.
#include "service/io/overlay.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace softgrasp::io {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// 160 x 120 depth rising from 0.5 m (left) to about 0.82 m (right), a missing block top-left.
core::DepthImage TestDepth() {
  core::DepthImage depth{cv::Mat1f(120, 160)};
  for (int r = 0; r < 120; ++r) {
    for (int c = 0; c < 160; ++c) depth.depth_m(r, c) = 0.5f + 0.002f * static_cast<float>(c);
  }
  depth.depth_m(cv::Rect(0, 0, 10, 10)).setTo(kNaN);
  return depth;
}

/// Closing axis along +u, centre (80, 60): fingers centred at u = 80 -/+ 18, rows 54..66.
core::Grasp BestGrasp() {
  core::Grasp g;
  g.center_u_px = 80;
  g.center_v_px = 60;
  g.angle_rad = 0;
  g.opening_px = 30;
  g.finger_thickness_px = 6;
  g.finger_width_px = 12;
  g.score = 0.9;
  return g;
}

bool SamePixel(const cv::Mat3b& a, const cv::Mat3b& b, int u, int v) { return a(v, u) == b(v, u); }

TEST(ColorizeDepthTest, NearIsWarmFarIsColdMissingIsBlack) {
  const cv::Mat3b image = ColorizeDepth(TestDepth());
  ASSERT_EQ(image.size(), cv::Size(160, 120));
  const cv::Vec3b near = image(60, 12);
  const cv::Vec3b far = image(60, 159);
  EXPECT_GT(near[2], near[0] + 50) << "near should be red-ish";
  EXPECT_GT(far[0], far[2]) << "far should be blue-ish";
  EXPECT_EQ(image(5, 5), cv::Vec3b(0, 0, 0));
  EXPECT_NE(image(60, 80), cv::Vec3b(0, 0, 0));
}

TEST(ColorizeDepthTest, AllMissingIsBlackAndEmptyIsEmpty) {
  const cv::Mat3b black = ColorizeDepth(core::DepthImage{cv::Mat1f(4, 5, kNaN)});
  ASSERT_EQ(black.size(), cv::Size(5, 4));
  EXPECT_EQ(cv::countNonZero(black.reshape(1)), 0);
  EXPECT_TRUE(ColorizeDepth(core::DepthImage{}).empty());
  EXPECT_TRUE(RenderGraspOverlay(core::DepthImage{}, {BestGrasp()}).empty());
}

TEST(ColorizeDepthTest, ConstantDepthDoesNotDivideByZero) {
  const cv::Mat3b image = ColorizeDepth(core::DepthImage{cv::Mat1f(4, 5, 0.7f)});
  ASSERT_EQ(image.size(), cv::Size(5, 4));
  EXPECT_EQ(image(0, 0), image(3, 4));
}

TEST(GraspOverlayTest, NoGraspsGivesTheColorizedImage) {
  const core::DepthImage depth = TestDepth();
  const cv::Mat3b plain = ColorizeDepth(depth);
  const cv::Mat3b overlay = RenderGraspOverlay(depth, {});
  ASSERT_EQ(overlay.size(), plain.size());
  EXPECT_EQ(cv::norm(overlay, plain, cv::NORM_INF), 0.0);
}

TEST(GraspOverlayTest, DrawsFingersAndClosingLineOfTheBestGrasp) {
  const core::DepthImage depth = TestDepth();
  const cv::Mat3b plain = ColorizeDepth(depth);
  const cv::Mat3b overlay = RenderGraspOverlay(depth, {BestGrasp()});
  // Closing line between the fingers, and the centre dot.
  for (const int u : {70, 75, 80, 85, 90}) EXPECT_FALSE(SamePixel(overlay, plain, u, 60)) << u;
  // Inside both finger rectangles (centres u = 62 and 98, 6 px along u, 12 px along v).
  for (const int u : {61, 62, 63, 97, 98, 99}) {
    for (const int v : {56, 60, 64}) {
      EXPECT_FALSE(SamePixel(overlay, plain, u, v)) << u << "," << v;
    }
  }
  EXPECT_EQ(overlay(60, 75), cv::Vec3b(0, 255, 0)) << "best grasp is green";
  // Far away nothing changes.
  for (const cv::Point p : {cv::Point(5, 100), cv::Point(150, 10), cv::Point(80, 20),
                            cv::Point(80, 100), cv::Point(30, 60), cv::Point(130, 60)}) {
    EXPECT_TRUE(SamePixel(overlay, plain, p.x, p.y)) << p;
  }
}

TEST(GraspOverlayTest, FollowsTheClosingAngle) {
  const core::DepthImage depth = TestDepth();
  const cv::Mat3b plain = ColorizeDepth(depth);
  core::Grasp g = BestGrasp();
  g.angle_rad = std::numbers::pi / 2;  // closing along +v: fingers at v = 60 -/+ 18
  const cv::Mat3b overlay = RenderGraspOverlay(depth, {g});
  EXPECT_FALSE(SamePixel(overlay, plain, 80, 42));
  EXPECT_FALSE(SamePixel(overlay, plain, 80, 78));
  EXPECT_FALSE(SamePixel(overlay, plain, 80, 50));
  EXPECT_TRUE(SamePixel(overlay, plain, 62, 60));
  EXPECT_TRUE(SamePixel(overlay, plain, 98, 60));
}

TEST(GraspOverlayTest, BestGraspIsDrawnOnTopOfTheOthers) {
  const core::DepthImage depth = TestDepth();
  core::Grasp other = BestGrasp();
  other.angle_rad = std::numbers::pi / 2;
  other.score = 0.5;
  const cv::Mat3b plain = ColorizeDepth(depth);
  const cv::Mat3b overlay = RenderGraspOverlay(depth, {BestGrasp(), other});
  EXPECT_EQ(overlay(60, 80), cv::Vec3b(0, 255, 0));
  EXPECT_FALSE(SamePixel(overlay, plain, 80, 42)) << "the other grasp is drawn too";
  EXPECT_NE(overlay(42, 80), cv::Vec3b(0, 255, 0)) << "in another colour";
}

TEST(GraspOverlayTest, SkipsGraspsWithNonFiniteOrHugeValues) {
  const core::DepthImage depth = TestDepth();
  core::Grasp nan_grasp = BestGrasp();
  nan_grasp.angle_rad = std::numeric_limits<double>::quiet_NaN();
  core::Grasp huge = BestGrasp();
  huge.center_u_px = 1e300;
  core::Grasp inf_opening = BestGrasp();
  inf_opening.opening_px = std::numeric_limits<double>::infinity();
  const cv::Mat3b overlay = RenderGraspOverlay(depth, {nan_grasp, huge, inf_opening});
  EXPECT_EQ(cv::norm(overlay, ColorizeDepth(depth), cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace softgrasp::io
