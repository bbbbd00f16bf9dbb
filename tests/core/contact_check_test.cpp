#include "service/core/contact_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

namespace softgrasp::core {
namespace {

// 1 px = 1 mm; fingers 60 mm apart closing along u at the image centre, 15 mm wide.
constexpr double kPxPerM = 1000.0;
const GripperPx kFingers{60, 15, 8};

cv::Mat1f HeightImage(const std::function<double(double, double)>& height_mm) {
  cv::Mat1f height_m(200, 200, 0.0F);
  for (int v = 0; v < height_m.rows; ++v) {
    for (int u = 0; u < height_m.cols; ++u) {
      height_m(v, u) = static_cast<float>(height_mm(u - 100.0, v - 100.0) / 1000.0);
    }
  }
  return height_m;
}

// A ball of radius 20 mm resting on the floor, seen from above: its upper half.
cv::Mat1f Ball() {
  return HeightImage([](double x, double y) {
    const double r2 = x * x + y * y;
    return r2 < 400.0 ? 20.0 + std::sqrt(400.0 - r2) : 0.0;
  });
}

bool Steep(const cv::Mat1f& height_m, double tip_mm, double mu = 0.5) {
  return ContactFacesSteep(height_m, 100, 100, 0.0, kFingers, kPxPerM, tip_mm / 1000.0, mu);
}

TEST(ContactFacesSteep, ABallHoldsNearItsWaistNotNearItsCrown) {
  // The face at the tips' height leans back by asin((tip - 20) / 20): 3 deg at 21 mm, 12 deg
  // at 24 mm (inside the 26.6 deg cone of mu = 0.5), 37 deg at 32 mm and 53 deg at 36 mm.
  const cv::Mat1f ball = Ball();
  EXPECT_TRUE(Steep(ball, 21));
  EXPECT_TRUE(Steep(ball, 24));
  EXPECT_FALSE(Steep(ball, 32));
  EXPECT_FALSE(Steep(ball, 36));
  // Both patches already hold in the image plane: the image-plane check cannot tell.
  for (const double tip_mm : {21.0, 32.0, 36.0}) {
    EXPECT_NE(CheckContacts(ball, 100, 100, 0.0, kFingers, kPxPerM, tip_mm / 1000.0),
              ContactHold::kNone)
        << tip_mm;
  }
  // A grippier pad (mu = 2, a 63 deg cone) holds the 37 deg face.
  EXPECT_TRUE(Steep(ball, 32, 2.0));
}

TEST(ContactFacesSteep, VerticalWallsSeenFromAboveAreAJumpAndHold) {
  const cv::Mat1f block = HeightImage(
      [](double x, double y) { return std::fabs(x) <= 20 && std::fabs(y) <= 30 ? 30.0 : 0.0; });
  EXPECT_TRUE(Steep(block, 10));
  EXPECT_TRUE(Steep(block, 27.5));  // 2 mm of wall above the tips: 1 px / mu
  EXPECT_FALSE(Steep(block, 29.5));
}

TEST(ContactFacesSteep, ARoofHoldsOnlyWhenItsSlopeIsInsideTheCone) {
  // Faces rising `slope` mm per mm from the eaves at |x| = 20 mm: the normal is atan(1 / slope)
  // off the closing axis, 45 deg at slope 1, 14 deg at slope 4.
  const auto roof = [](double slope) {
    return HeightImage([slope](double x, double y) {
      return std::fabs(y) <= 30 ? std::max(0.0, slope * (20.0 - std::fabs(x))) : 0.0;
    });
  };
  EXPECT_FALSE(Steep(roof(1.0), 5));
  EXPECT_TRUE(Steep(roof(4.0), 5));
}

TEST(ContactFacesSteep, EachFingerMustMeetASteepFace) {
  // A wall on the right (x > 0), a 45 deg slope from the floor on the left.
  const cv::Mat1f half = HeightImage([](double x, double y) {
    if (std::fabs(y) > 30 || std::fabs(x) > 20) return 0.0;
    return x >= 0 ? 30.0 : 20.0 + x;
  });
  EXPECT_FALSE(Steep(half, 5));
  // Nothing between the fingers: nothing to hold.
  EXPECT_FALSE(Steep(HeightImage([](double, double) { return 0.0; }), 5));
}

}  // namespace
}  // namespace softgrasp::core
