// The grasp-aligned crop (service/gqcnn/crop.h) on analytic depth images: a flat table with a
// raised plate whose edges land in the crop exactly where the projection puts them, the grasp
// axis along the crop's +u (a 90 degree turn swaps the axes), the centre pixel at the centre
// depth, holes and the outside of the image kept at 0 without bleeding, and the projection of
// camera-frame grasps.
#include "service/gqcnn/crop.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>

namespace softgrasp::gqcnn {
namespace {

constexpr float kTableM = 0.70F;
constexpr float kPlateM = 0.65F;
constexpr double kPi = std::numbers::pi;

using Crop = std::array<float, kCropPixels>;

float At(const Crop& crop, int row, int col) { return crop[row * kCropSizePx + col]; }

/// A table at 0.70 m with the pixels from column `edge_u` on at 0.65 m (a plate's left edge).
core::DepthImage StepImage(int width, int height, int edge_u) {
  core::DepthImage image;
  image.depth_m = cv::Mat1f(height, width, kTableM);
  for (int v = 0; v < height; ++v) {
    for (int u = edge_u; u < width; ++u) image.depth_m(v, u) = kPlateM;
  }
  return image;
}

Crop CropOf(const core::DepthImage& image, const GraspImagePose& pose) {
  Crop crop{};
  CropGrasp(image, pose, crop.data());
  return crop;
}

/// Expected value of a crop column (angle 0) or row whose centre lies `offset_px` source pixels
/// from the grasp centre, when source pixels at offsets >= edge_offset_px read kPlateM and the
/// others kTableM: the documented triangle filter of radius 3 (taps -2..2, weights 1 2 3 2 1).
double Expected(int offset_px, int edge_offset_px) {
  const double weights[5] = {1, 2, 3, 2, 1};
  double sum = 0.0;
  for (int k = -2; k <= 2; ++k) {
    sum += weights[k + 2] * (offset_px + k >= edge_offset_px ? kPlateM : kTableM);
  }
  return sum / 9.0;
}

TEST(GqcnnCropTest, FlatImageGivesItsDepthEverywhereAndTheCentrePixelIsTheCentreDepth) {
  core::DepthImage image;
  image.depth_m = cv::Mat1f(240, 320, kTableM);
  image.depth_m(100, 150) = 0.5F;  // one distinct pixel under the grasp centre
  const Crop crop = CropOf(image, {150.0, 100.0, 0.3, 0.69, 40.0});
  // A rotated crop wholly inside a flat patch reads its depth everywhere.
  core::DepthImage plain;
  plain.depth_m = cv::Mat1f(240, 320, kTableM);
  const Crop flat = CropOf(plain, {160.0, 120.0, 1.1, 0.69, 40.0});
  for (float z : flat) EXPECT_NEAR(z, kTableM, 1e-6);
  // The distinct pixel contributes to the centre crop pixel with the centre weight 9/81.
  EXPECT_NEAR(At(crop, 16, 16), (9.0 * 0.5 + 72.0 * kTableM) / 81.0, 1e-6);
  EXPECT_NEAR(At(crop, 16, 18), kTableM, 1e-6);  // 6 px away: not a tap
}

TEST(GqcnnCropTest, StepEdgeLandsWhereTheOffsetSaysAtAngleZero) {
  // Edge 31 px right of the grasp centre (u = 100): columns centred 3 (j - 16) px away.
  const core::DepthImage image = StepImage(300, 200, 131);
  const Crop crop = CropOf(image, {100.0, 90.0, 0.0, 0.69, 40.0});
  for (int row = 0; row < kCropSizePx; ++row) {
    for (int col = 0; col < kCropSizePx; ++col) {
      EXPECT_NEAR(At(crop, row, col), Expected(3 * (col - 16), 31), 1e-6)
          << "row " << row << " col " << col;
    }
  }
  EXPECT_NEAR(At(crop, 5, 25), kTableM, 1e-6);  // taps 25..29 px
  EXPECT_NEAR(At(crop, 5, 27), kPlateM, 1e-6);  // taps 31..35 px
  EXPECT_GT(At(crop, 5, 26), kPlateM + 0.001F);
  EXPECT_LT(At(crop, 5, 26), kTableM - 0.001F);
}

TEST(GqcnnCropTest, AHalfTurnMirrorsAndAQuarterTurnSwapsTheAxes) {
  const core::DepthImage image = StepImage(300, 200, 131);
  const Crop crop0 = CropOf(image, {100.0, 90.0, 0.0, 0.69, 40.0});
  // Angle pi/2: crop +u = image +v (down), crop +v = image -u, so the edge (image +u) is at the
  // top of the crop: row i is centred -3 (i - 16) px along image u.
  const Crop crop90 = CropOf(image, {100.0, 90.0, kPi / 2, 0.69, 40.0});
  for (int row = 1; row < kCropSizePx; ++row) {
    for (int col = 0; col < kCropSizePx; ++col) {
      EXPECT_NEAR(At(crop90, row, col), At(crop0, 0, kCropSizePx - row), 1e-6)
          << "row " << row << " col " << col;
    }
  }
  EXPECT_NEAR(At(crop90, 5, 0), kPlateM, 1e-6);
  EXPECT_NEAR(At(crop90, 7, 0), kTableM, 1e-6);
  // Angle pi: the edge is on the left, column j centred -3 (j - 16) px along image u.
  const Crop crop180 = CropOf(image, {100.0, 90.0, kPi, 0.69, 40.0});
  for (int col = 1; col < kCropSizePx; ++col) {
    EXPECT_NEAR(At(crop180, 10, col), At(crop0, 10, kCropSizePx - col), 1e-6) << col;
  }
}

TEST(GqcnnCropTest, ObliqueAngleFollowsTheRotatedOffset) {
  // Angle 30 degrees: crop pixel (i, j) is centred at image offset
  // 3 (j - 16) (cos, sin) + 3 (i - 16) (-sin, cos); where all 25 taps are well away from the
  // edge (more than 3 * sqrt(2) * 2 + 1 px), the value is the side's.
  const core::DepthImage image = StepImage(300, 200, 131);
  const double a = kPi / 6;
  const Crop crop = CropOf(image, {100.0, 90.0, a, 0.69, 40.0});
  int checked = 0;
  for (int row = 0; row < kCropSizePx; ++row) {
    for (int col = 0; col < kCropSizePx; ++col) {
      const double du = 3 * (col - 16) * std::cos(a) - 3 * (row - 16) * std::sin(a);
      const double u = 100.0 + du;
      if (std::abs(u - 130.5) < 9.0) continue;
      const double v = 90.0 + 3 * (col - 16) * std::sin(a) + 3 * (row - 16) * std::cos(a);
      if (v < 4.0 || v > 195.0) continue;
      EXPECT_NEAR(At(crop, row, col), u > 130.5 ? kPlateM : kTableM, 1e-6)
          << "row " << row << " col " << col;
      ++checked;
    }
  }
  EXPECT_GT(checked, 700);
}

TEST(GqcnnCropTest, MissingReadingsStayZeroAndDoNotBleed) {
  core::DepthImage image;
  image.depth_m = cv::Mat1f(200, 200, kTableM);
  // A NaN hole from column 100 on and a zero (no reading) hole of rows >= 120.
  for (int v = 0; v < 200; ++v) {
    for (int u = 0; u < 200; ++u) {
      if (u >= 100) image.depth_m(v, u) = std::numeric_limits<float>::quiet_NaN();
      if (v >= 120) image.depth_m(v, u) = 0.0F;
    }
  }
  const Crop crop = CropOf(image, {80.0, 100.0, 0.0, 0.69, 40.0});
  for (int row = 0; row < kCropSizePx; ++row) {
    for (int col = 0; col < kCropSizePx; ++col) {
      const float z = At(crop, row, col);
      // Pixels with a valid tap hold the only valid depth; the others are 0.
      const int u_lo = 80 + 3 * (col - 16) - 2;
      const int v_lo = 100 + 3 * (row - 16) - 2;
      const bool any_valid = u_lo < 100 && v_lo < 120;
      if (any_valid) {
        EXPECT_NEAR(z, kTableM, 1e-6) << "row " << row << " col " << col;
      } else {
        EXPECT_EQ(z, 0.0F) << "row " << row << " col " << col;
      }
    }
  }
  EXPECT_EQ(At(crop, 0, 31), 0.0F);
  EXPECT_EQ(At(crop, 31, 0), 0.0F);
}

TEST(GqcnnCropTest, OutsideTheImageIsZero) {
  core::DepthImage image;
  image.depth_m = cv::Mat1f(100, 120, kTableM);
  // Grasp at the top-left corner pixel: crop pixels centred left of or above the image (with
  // every tap outside) are 0, those fully inside read the table.
  const Crop crop = CropOf(image, {0.0, 0.0, 0.0, 0.69, 40.0});
  for (int row = 0; row < kCropSizePx; ++row) {
    for (int col = 0; col < kCropSizePx; ++col) {
      const int u_hi = 3 * (col - 16) + 2;
      const int v_hi = 3 * (row - 16) + 2;
      if (u_hi < 0 || v_hi < 0) {
        EXPECT_EQ(At(crop, row, col), 0.0F) << row << " " << col;
      } else {
        EXPECT_NEAR(At(crop, row, col), kTableM, 1e-6) << row << " " << col;
      }
    }
  }
  // Far outside the image entirely: all zero.
  const Crop away = CropOf(image, {-500.0, 50.0, 0.4, 0.69, 40.0});
  for (float z : away) EXPECT_EQ(z, 0.0F);
}

TEST(GqcnnCropTest, ProjectedPlateEdgeLandsWhereTheCameraPutsIt) {
  // A camera looking straight down at a table 0.70 m away with a plate (top at 0.65 m) covering
  // x >= 0.03 m in the camera frame. A grasp 2.5 cm above the table at the optical axis with its
  // axis along camera x (then along y) is cropped; the plate edge must appear at the column
  // (row) the pinhole projection gives.
  core::Camera camera;
  camera.fx = 525.0;
  camera.fy = 527.0;
  camera.cx = 160.3;
  camera.cy = 119.8;
  camera.width = 320;
  camera.height = 240;
  const double edge_x_m = 0.03;
  core::DepthImage image;
  image.depth_m = cv::Mat1f(camera.height, camera.width, kTableM);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      if ((u - camera.cx) * kPlateM / camera.fx >= edge_x_m) image.depth_m(v, u) = kPlateM;
    }
  }
  const double edge_u = camera.cx + camera.fx * edge_x_m / kPlateM;  // ~184.5 px
  const Eigen::Vector3d center_c(0.0, 0.0, 0.675);
  const auto along_x = ProjectGrasp(camera, center_c, Eigen::Vector3d::UnitX(), 0.05);
  ASSERT_TRUE(along_x.has_value());
  EXPECT_NEAR(along_x->center_u_px, camera.cx, 1e-9);
  EXPECT_NEAR(along_x->center_v_px, camera.cy, 1e-9);
  EXPECT_NEAR(along_x->angle_rad, 0.0, 1e-12);
  EXPECT_NEAR(along_x->depth_m, 0.675, 1e-12);
  EXPECT_NEAR(along_x->width_px, camera.fx * 0.05 / 0.675, 1e-9);
  const Crop crop_x = CropOf(image, *along_x);
  // Crop column j is centred 3 (j - 16) px right of the centre; those whose taps all lie beyond
  // (before) the edge read the plate (table).
  const double edge_offset = edge_u - along_x->center_u_px;
  int plate_cols = 0;
  for (int col = 0; col < kCropSizePx; ++col) {
    const double c = 3.0 * (col - 16);
    if (c - 2 > edge_offset + 0.5) {
      EXPECT_NEAR(At(crop_x, 16, col), kPlateM, 1e-6) << col;
      ++plate_cols;
    } else if (c + 2 < edge_offset - 0.5) {
      EXPECT_NEAR(At(crop_x, 16, col), kTableM, 1e-6) << col;
    }
  }
  EXPECT_GE(plate_cols, 3);
  // Axis along camera y: the angle is pi/2 and the plate (image +u) is at the crop's top.
  const auto along_y = ProjectGrasp(camera, center_c, Eigen::Vector3d::UnitY(), 0.05);
  ASSERT_TRUE(along_y.has_value());
  EXPECT_NEAR(along_y->angle_rad, kPi / 2, 1e-12);
  const Crop crop_y = CropOf(image, *along_y);
  for (int row = 0; row < kCropSizePx; ++row) {
    const double c = -3.0 * (row - 16);  // image u offset of row i
    if (c - 2 > edge_offset + 0.5) {
      EXPECT_NEAR(At(crop_y, row, 16), kPlateM, 1e-6) << row;
    } else if (c + 2 < edge_offset - 0.5) {
      EXPECT_NEAR(At(crop_y, row, 16), kTableM, 1e-6) << row;
    }
  }
}

TEST(GqcnnCropTest, ProjectGraspRefusesWhatCannotBeSeen) {
  const core::Camera camera;
  EXPECT_FALSE(ProjectGrasp(camera, {0, 0, -0.5}, Eigen::Vector3d::UnitX(), 0.05));  // behind
  EXPECT_FALSE(ProjectGrasp(camera, {0, 0, 0.5}, Eigen::Vector3d::UnitZ(), 0.05));   // on sight
  EXPECT_FALSE(ProjectGrasp(camera, {0, 0, 0.5}, Eigen::Vector3d::Zero(), 0.05));
  EXPECT_FALSE(ProjectGrasp(camera, {0, std::nan(""), 0.5}, Eigen::Vector3d::UnitX(), 0.05));
  // An axis tilted towards the camera still projects; the angle is that of the image segment,
  // wrapped to [0, 2 pi).
  const auto tilted = ProjectGrasp(camera, {0.01, 0.02, 0.6}, Eigen::Vector3d(-1, -1, 0.5), 0.05);
  ASSERT_TRUE(tilted.has_value());
  EXPECT_GT(tilted->angle_rad, kPi);
  EXPECT_LT(tilted->angle_rad, 1.5 * kPi);
}

TEST(GqcnnCropTest, EveryPixelIsZeroOrAWeightedMeanOfReadings) {
  // Random images with holes and random grasps, in and out of the image: every crop pixel is 0
  // or within the range of the image's valid readings (a weighted mean of some of them).
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> depth(0.4F, 0.9F);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const int width = 20 + static_cast<int>(300 * unit(rng));
    const int height = 20 + static_cast<int>(300 * unit(rng));
    core::DepthImage image;
    image.depth_m = cv::Mat1f(height, width);
    float lo = 10.0F;
    float hi = 0.0F;
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const double r = unit(rng);
        float z = depth(rng);
        if (r < 0.1) z = std::numeric_limits<float>::quiet_NaN();
        if (r >= 0.1 && r < 0.15) z = 0.0F;
        if (r >= 0.15 && r < 0.17) z = -1.0F;
        if (r >= 0.17 && r < 0.18) z = std::numeric_limits<float>::infinity();
        image.depth_m(v, u) = z;
        if (z > 0.0F && std::isfinite(z)) {
          lo = std::min(lo, z);
          hi = std::max(hi, z);
        }
      }
    }
    const GraspImagePose pose{(unit(rng) * 1.6 - 0.3) * width, (unit(rng) * 1.6 - 0.3) * height,
                              unit(rng) * 2 * kPi, 0.7, 30.0};
    Crop crop{};
    CropGrasp(image, pose, crop.data(), trial % 2 == 0 ? 96 : 50);
    for (float z : crop) {
      ASSERT_TRUE(z == 0.0F || (z >= lo - 1e-6F && z <= hi + 1e-6F)) << z << " trial " << trial;
    }
  }
}

TEST(GqcnnCropTest, BadArgumentsThrow) {
  core::DepthImage image;
  image.depth_m = cv::Mat1f(10, 10, kTableM);
  Crop crop{};
  EXPECT_THROW(CropGrasp(image, {std::nan(""), 0, 0, 0.7, 10}, crop.data()), std::invalid_argument);
  EXPECT_THROW(CropGrasp(image, {0, 0, 0, 0.7, 10}, crop.data(), 16), std::invalid_argument);
  // An empty image is all outside: zeros.
  CropGrasp(core::DepthImage{}, {0, 0, 0, 0.7, 10}, crop.data());
  for (float z : crop) EXPECT_EQ(z, 0.0F);
}

}  // namespace
}  // namespace softgrasp::gqcnn
