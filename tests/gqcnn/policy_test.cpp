#include "service/gqcnn/policy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "service/core/preprocess.h"
#include "service/gqcnn/clearance.h"
#include "service/gqcnn/dataset_format.h"

namespace softgrasp::gqcnn {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTableZ = 0.70;  // camera looks straight down at a table 0.70 m away

core::Camera TestCamera() { return {525.0, 525.0, 159.5, 119.5, 320, 240}; }

// A box of footprint long_m x short_m (long side along +u rotated by `yaw_rad`), `height_m` tall,
// centred under pixel (cu, cv) on the table.
core::DepthImage BoxScene(double cu, double cv, double long_m, double short_m, double height_m,
                          double yaw_rad) {
  const core::Camera camera = TestCamera();
  core::DepthImage depth{cv::Mat1f(camera.height, camera.width, static_cast<float>(kTableZ))};
  const double top = kTableZ - height_m;
  const double px_per_m = camera.fx / top;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const double du = (u - cu) / px_per_m;
      const double dv = (v - cv) / px_per_m;
      const double a = std::cos(yaw_rad) * du + std::sin(yaw_rad) * dv;
      const double b = -std::sin(yaw_rad) * du + std::cos(yaw_rad) * dv;
      if (std::fabs(a) <= long_m / 2 && std::fabs(b) <= short_m / 2) {
        depth.depth_m(v, u) = static_cast<float>(top);
      }
    }
  }
  return depth;
}

core::Scene Prepared(const core::DepthImage& depth) {
  auto scene = core::Preprocess(depth, TestCamera());
  EXPECT_TRUE(scene.ok());
  return scene.value();
}

// The fraction of the crop's centre row (along the grasp axis) that is nearer than the table:
// across a 3 cm side of a box the jaws see a narrow band, along its 9 cm side a long one.
double CentreRowObjectFraction(const float* crop) {
  int object = 0;
  const int row = kCropSizePx / 2;
  for (int c = 0; c < kCropSizePx; ++c) {
    if (crop[row * kCropSizePx + c] > 0.0F && crop[row * kCropSizePx + c] < kTableZ - 0.01)
      ++object;
  }
  return static_cast<double>(object) / kCropSizePx;
}

// A stand-in GQ-CNN with a known optimum: grasps whose centre row crosses a narrow band of
// object, with the centre on the object and the grasp depth 2 cm below the top, score highest.
QualityFunction NarrowBandQuality(int* calls = nullptr) {
  return [calls](std::span<const float> crops, std::span<const float> depths,
                 std::span<const float>) {
    if (calls) ++*calls;
    std::vector<float> out(depths.size());
    for (std::size_t i = 0; i < depths.size(); ++i) {
      const float* crop = crops.data() + i * kCropPixels;
      const float centre = crop[(kCropSizePx / 2) * kCropSizePx + kCropSizePx / 2];
      const double band = CentreRowObjectFraction(crop);
      const double depth_error = std::fabs(depths[i] - (centre + 0.02));
      const double q = (centre > 0.0F && centre < kTableZ - 0.01 ? 1.0 : 0.0) *
                       std::exp(-std::pow((band - 0.25) / 0.1, 2)) * std::exp(-depth_error / 0.01);
      out[i] = static_cast<float>(q);
    }
    return out;
  };
}

TEST(GqcnnPolicyTest, GraspsABoxAcrossItsShortSideAtTheRightDepth) {
  const double yaw = 0.6;
  const core::Scene scene = Prepared(BoxScene(160, 120, 0.09, 0.03, 0.05, yaw));
  PolicyParams params;
  params.seed = 3;
  auto plan = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, NarrowBandQuality());
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ASSERT_FALSE(plan.value().grasps.empty());
  EXPECT_GT(plan.value().antipodal_pairs, 0);
  EXPECT_EQ(plan.value().evaluated,
            params.seed_samples + params.cem_iterations * params.cem_samples);
  const PolicyGrasp& best = plan.value().grasps.front();
  // The short side is across yaw + 90 degrees.
  double across = std::fmod(yaw + kPi / 2, kPi);
  double error = std::fabs(best.grasp.angle_rad - across);
  error = std::min(error, kPi - error);
  EXPECT_LT(error, 12.0 * kPi / 180.0) << best.grasp.angle_rad;
  // On the box, its fingers beside it (the stand-in quality does not care where along it).
  const double px_per_m = 525.0 / 0.65;
  const double du = (best.grasp.center_u_px - 160) / px_per_m;
  const double dv = (best.grasp.center_v_px - 120) / px_per_m;
  EXPECT_LT(std::fabs(std::cos(yaw) * du + std::sin(yaw) * dv), 0.045 - 0.0075);
  EXPECT_LT(std::fabs(-std::sin(yaw) * du + std::cos(yaw) * dv), 0.015);
  EXPECT_GT(best.quality, 0.7F);
  EXPECT_FLOAT_EQ(static_cast<float>(best.grasp.score), best.quality);
  // Between the box top (0.65 m) and the table, as the quality function prefers.
  EXPECT_NEAR(best.image_pose.depth_m, 0.67, 0.006);
  EXPECT_NEAR(best.grasp.p_CG_m[2], best.image_pose.depth_m, 1e-12);
  EXPECT_NEAR(best.grasp.grasp_height_m, kTableZ - best.image_pose.depth_m, 0.002);
  EXPECT_NEAR(best.grasp.contact_height_m, 0.05, 0.002);
  // Back-projection of the centre pixel at the grasp depth.
  EXPECT_NEAR(best.grasp.p_CG_m[0], (best.grasp.center_u_px - 159.5) / 525.0 * best.grasp.p_CG_m[2],
              1e-9);
  // Ranked best first, no near-duplicates.
  for (std::size_t i = 1; i < plan.value().grasps.size(); ++i) {
    EXPECT_LE(plan.value().grasps[i].quality, plan.value().grasps[i - 1].quality);
  }
}

TEST(GqcnnPolicyTest, CemImprovesOnTheSeedCandidates) {
  const core::Scene scene = Prepared(BoxScene(150, 110, 0.09, 0.03, 0.05, 1.1));
  PolicyParams seeds_only;
  seeds_only.seed = 5;
  seeds_only.seed_samples = 40;
  seeds_only.cem_iterations = 0;
  PolicyParams refined = seeds_only;
  refined.cem_iterations = 3;
  auto a = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, seeds_only, NarrowBandQuality());
  auto b = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, refined, NarrowBandQuality());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_FALSE(a.value().grasps.empty());
  EXPECT_GT(b.value().grasps.front().quality, a.value().grasps.front().quality);
}

TEST(GqcnnPolicyTest, SameSeedSamePlan) {
  const core::Scene scene = Prepared(BoxScene(170, 115, 0.08, 0.035, 0.04, 0.2));
  PolicyParams params;
  params.seed = 9;
  auto a = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, NarrowBandQuality());
  auto b = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, NarrowBandQuality());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a.value().grasps.size(), b.value().grasps.size());
  for (std::size_t i = 0; i < a.value().grasps.size(); ++i) {
    EXPECT_EQ(a.value().grasps[i].grasp.center_u_px, b.value().grasps[i].grasp.center_u_px);
    EXPECT_EQ(a.value().grasps[i].image_pose.depth_m, b.value().grasps[i].image_pose.depth_m);
  }
}

TEST(GqcnnPolicyTest, ContactsOnlyWhereAllowedAndNothingOnAnEmptyTable) {
  core::Scene scene = Prepared(BoxScene(160, 120, 0.09, 0.03, 0.05, 0.0));
  scene.contact_allowed = cv::Mat1b(scene.depth_filled_m.size(), 255);
  scene.contact_allowed(cv::Rect(100, 60, 120, 120)).setTo(0);  // the box's surroundings
  auto masked = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, {}, NarrowBandQuality());
  ASSERT_TRUE(masked.ok());
  EXPECT_TRUE(masked.value().grasps.empty());
  EXPECT_EQ(masked.value().antipodal_pairs, 0);

  // Only the box's top excluded (as min_depth_m excludes a near finger): the edge pixels on the
  // table beside it are allowed, but the surface between them is not, so nothing is grasped.
  core::Scene top_excluded = Prepared(BoxScene(160, 120, 0.09, 0.03, 0.05, 0.0));
  top_excluded.contact_allowed = cv::Mat1b(top_excluded.depth_filled_m.size(), 255);
  top_excluded.contact_allowed.setTo(0, top_excluded.depth_filled_m < kTableZ - 0.01);
  auto top = PlanGqcnnGrasps(top_excluded, TestCamera(), core::Gripper{}, {}, NarrowBandQuality());
  ASSERT_TRUE(top.ok());
  for (const auto& g : top.value().grasps) {
    const int u = static_cast<int>(std::lround(g.grasp.center_u_px));
    const int v = static_cast<int>(std::lround(g.grasp.center_v_px));
    EXPECT_NE(top_excluded.contact_allowed(v, u), 0) << "a grasp centred on the excluded box top";
  }

  core::DepthImage flat = BoxScene(160, 120, 0.0, 0.0, 0.0, 0.0);
  int calls = 0;
  auto empty =
      PlanGqcnnGrasps(Prepared(flat), TestCamera(), core::Gripper{}, {}, NarrowBandQuality(&calls));
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty.value().grasps.empty());
  EXPECT_EQ(calls, 0);
}

TEST(GqcnnPolicyTest, TooWideForTheStrokeGivesNoPairs) {
  // 8 cm across its short side: wider than the 5 cm stroke every way.
  const core::Scene scene = Prepared(BoxScene(160, 120, 0.12, 0.08, 0.05, 0.0));
  auto plan = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, {}, NarrowBandQuality());
  ASSERT_TRUE(plan.ok());
  EXPECT_EQ(plan.value().antipodal_pairs, 0);
}

// A 3 cm wide box (5 cm tall) with a 4 cm tall block 1.5 cm beside its long side: across the
// box, the 5 cm stroke puts one finger on the block unless the fingertips stay above it. With a
// quality function that likes everything, the clearance check keeps only grasps whose fingertips
// clear the block (grasp height above 4 cm); without it, deeper grasps that land on the block
// are returned too.
// A 9 x 3 x 5 cm box in the middle of the image and, 1.5 cm beside its long side, a 4 cm high
// block filling the image's lower part: open jaws across the box low enough land on the block.
core::Scene BoxBesideBlockScene() {
  core::DepthImage depth = BoxScene(160, 120, 0.09, 0.03, 0.05, 0.0);
  const double block_top = kTableZ - 0.04;
  const double px_per_m = TestCamera().fx / block_top;
  // The block: v from 1.5 + 1.5 cm below the box's centre row to the image's bottom, across.
  for (int v = static_cast<int>(std::ceil(120 + 0.03 * px_per_m)); v < depth.depth_m.rows; ++v) {
    for (int u = 0; u < depth.depth_m.cols; ++u) {
      depth.depth_m(v, u) = static_cast<float>(block_top);
    }
  }
  return Prepared(depth);
}

// Grasps across the box of BoxBesideBlockScene (|angle - 90 deg| < 20 deg) near its middle.
bool AcrossTheBox(const core::Grasp& g) {
  return std::fabs(g.angle_rad - kPi / 2) < 0.35 && std::fabs(g.center_v_px - 120) < 10 &&
         std::fabs(g.center_u_px - 160) < 60;
}

TEST(GqcnnPolicyTest, OpenJawsMustReachTheGraspDepth) {
  const core::Scene scene = BoxBesideBlockScene();
  const auto anything = [](std::span<const float>, std::span<const float> depths,
                           std::span<const float>) {
    return std::vector<float>(depths.size(), 0.5F);
  };
  PolicyParams params;
  params.num_grasps = 50;
  const auto across_box = AcrossTheBox;
  auto checked = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, anything);
  ASSERT_TRUE(checked.ok());
  int across = 0;
  for (const PolicyGrasp& g : checked.value().grasps) {
    if (!across_box(g.grasp)) continue;
    ++across;
    EXPECT_GT(g.grasp.grasp_height_m, 0.04) << "a finger lands on the block";
  }
  EXPECT_GT(across, 0);
  params.check_clearance = false;
  auto unchecked = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, anything);
  ASSERT_TRUE(unchecked.ok());
  int landing = 0;
  for (const PolicyGrasp& g : unchecked.value().grasps) {
    if (across_box(g.grasp) && g.grasp.grasp_height_m < 0.035) ++landing;
  }
  EXPECT_GT(landing, 0);
}

// The quality function is handed each candidate's clearance as the check measures it (a network
// with clearance inputs reads them), in the candidates' order: scored by the clearance rule
// alone, with the planner's own check off, every returned grasp's score says whether the rule
// admits the clearance measured again at its pose, and the block stops some of them.
TEST(GqcnnPolicyTest, TheQualityFunctionSeesEachCandidatesClearance) {
  const core::Scene scene = BoxBesideBlockScene();
  const ClearanceRule rule;
  int blocked = 0;
  const auto by_clearance = [&](std::span<const float>, std::span<const float> depths,
                                std::span<const float> clearances) {
    EXPECT_EQ(clearances.size(), 3 * depths.size());
    std::vector<float> p(depths.size());
    for (std::size_t i = 0; i < depths.size(); ++i) {
      const GripperClearance c{clearances[3 * i], clearances[3 * i + 1], clearances[3 * i + 2]};
      const bool admitted = rule.Admits(c, core::Gripper{});
      p[i] = admitted ? 0.9F : 0.1F;
      blocked += admitted ? 0 : 1;
    }
    return p;
  };
  PolicyParams params;
  params.num_grasps = 400;
  params.check_clearance = false;
  auto plan = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, by_clearance);
  ASSERT_TRUE(plan.ok());
  EXPECT_GT(blocked, 0);
  int high = 0, low = 0;
  for (const PolicyGrasp& g : plan.value().grasps) {
    const GripperClearance c =
        MeasureClearance(scene.depth_filled_m, scene.height_m, g.image_pose, TestCamera().fx,
                         core::Gripper{}, rule.min_height_m);
    EXPECT_EQ(g.quality > 0.5F, rule.Admits(c, core::Gripper{}))
        << "jaws " << c.jaws_m << " palm " << c.palm_m << " floor " << c.floor_m;
    (g.quality > 0.5F ? high : low) += 1;
  }
  EXPECT_GT(high, 0);
  EXPECT_GT(low, 0);
}

// A ball of radius `radius_m` resting on the table under pixel (cu, cv).
core::DepthImage BallScene(double cu, double cv, double radius_m) {
  const core::Camera camera = TestCamera();
  core::DepthImage depth{cv::Mat1f(camera.height, camera.width, static_cast<float>(kTableZ))};
  const double centre_z = kTableZ - radius_m;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      // The pixel's ray (x, y, 1) z meets the sphere |p - c|^2 = r^2, c = (cx, cy, 1) centre_z.
      const double x = (u - camera.cx) / camera.fx;
      const double y = (v - camera.cy) / camera.fy;
      const double cx = (cu - camera.cx) / camera.fx * centre_z;
      const double cy = (cv - camera.cy) / camera.fy * centre_z;
      const double a = x * x + y * y + 1.0;
      const double b = -2.0 * (x * cx + y * cy + centre_z);
      const double c = cx * cx + cy * cy + centre_z * centre_z - radius_m * radius_m;
      const double disc = b * b - 4.0 * a * c;
      if (disc >= 0.0) depth.depth_m(v, u) = static_cast<float>((-b - std::sqrt(disc)) / (2 * a));
    }
  }
  return depth;
}

TEST(GqcnnPolicyTest, FingersMustMeetFacesThatHold) {
  // A 4 cm ball and a network that likes shallow grasps best: near the crown the faces at the
  // fingertips lean back out of the friction cone (mu = 0.5: 26.6 deg) and the ball slips.
  const double radius = 0.02;
  const core::Scene scene = Prepared(BallScene(160, 120, radius));
  const double crown_z = kTableZ - 2 * radius;
  const auto shallow_first = [crown_z](std::span<const float>, std::span<const float> depths,
                                       std::span<const float>) {
    std::vector<float> out(depths.size());
    for (std::size_t i = 0; i < depths.size(); ++i) {
      out[i] = static_cast<float>(std::exp(-std::max(0.0, depths[i] - crown_z) / 0.01));
    }
    return out;
  };
  // The face's lean at the fingertips' height h: asin((h - r) / r).
  const auto lean_deg = [&](const core::Grasp& g) {
    return std::asin(std::clamp((g.grasp_height_m - radius) / radius, -1.0, 1.0)) * 180 / kPi;
  };
  PolicyParams params;
  params.num_grasps = 20;
  auto checked = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, shallow_first);
  ASSERT_TRUE(checked.ok());
  ASSERT_FALSE(checked.value().grasps.empty());
  for (const PolicyGrasp& g : checked.value().grasps) {
    EXPECT_LT(lean_deg(g.grasp), 30.0) << "at " << g.grasp.grasp_height_m << " m";
  }
  params.check_contacts = false;
  auto unchecked = PlanGqcnnGrasps(scene, TestCamera(), core::Gripper{}, params, shallow_first);
  ASSERT_TRUE(unchecked.ok());
  ASSERT_FALSE(unchecked.value().grasps.empty());
  EXPECT_GT(lean_deg(unchecked.value().grasps.front().grasp), 40.0);
}

TEST(GqcnnPolicyTest, RefusesBadParametersAndBadQualityFunctions) {
  const core::Scene scene = Prepared(BoxScene(160, 120, 0.09, 0.03, 0.05, 0.0));
  PolicyParams params;
  params.seed_samples = 0;
  EXPECT_EQ(PlanGqcnnGrasps(scene, TestCamera(), {}, params, NarrowBandQuality()).error().field,
            "seed_samples");
  params = {};
  params.cem_elite_fraction = 1.5;
  EXPECT_EQ(ValidatePolicyParams(params)->field, "cem_elite_fraction");
  auto wrong_count = [](std::span<const float>, std::span<const float> depths,
                        std::span<const float>) {
    return std::vector<float>(depths.size() + 1, 0.5F);
  };
  auto result = PlanGqcnnGrasps(scene, TestCamera(), {}, {}, wrong_count);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, core::ErrorCode::kInternal);
  auto nan = [](std::span<const float>, std::span<const float> depths, std::span<const float>) {
    return std::vector<float>(depths.size(), std::nanf(""));
  };
  EXPECT_EQ(PlanGqcnnGrasps(scene, TestCamera(), {}, {}, nan).error().code,
            core::ErrorCode::kInternal);
}

}  // namespace
}  // namespace softgrasp::gqcnn
