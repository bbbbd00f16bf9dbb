#include "service/core/fge_deformability.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>
#include <stdexcept>

#include "tests/support/grasp_footprint.h"
#include "tests/support/synthetic_scene.h"

namespace softgrasp::core {
namespace {

using testing::Box;
using testing::RenderScene;
using testing::SceneSpec;

constexpr double kFootprintShrinkPx = 1.0;

struct Prepared {
  testing::SyntheticScene synth;
  Scene scene;
  ObjectMaps objects;
};

// `instance_of_box`: synthetic box id -> instance id (several boxes may form one object);
// `deformability_of_box`: synthetic box id -> deformability; `scores` per instance id - 1.
Prepared Make(const SceneSpec& spec, const std::map<int, int>& instance_of_box,
              const std::map<int, float>& deformability_of_box, std::vector<float> scores) {
  Prepared s{RenderScene(spec), {}, {}};
  auto scene = Preprocess(s.synth.depth, s.synth.camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  s.scene = std::move(scene).value();
  s.objects.labels = cv::Mat1w(s.synth.object_id.size(), 0);
  s.objects.deformability = cv::Mat1f(s.synth.object_id.size(), 0.0f);
  s.objects.scores = std::move(scores);
  for (int v = 0; v < s.synth.object_id.rows; ++v) {
    for (int u = 0; u < s.synth.object_id.cols; ++u) {
      const int box = s.synth.object_id(v, u);
      if (box <= 0) continue;
      s.objects.labels(v, u) = static_cast<std::uint16_t>(instance_of_box.at(box));
      s.objects.deformability(v, u) = deformability_of_box.at(box);
    }
  }
  return s;
}

int BoxAtCenter(const Prepared& s, const Grasp& g) {
  return s.synth.object_id(static_cast<int>(std::lround(g.center_v_px)),
                           static_cast<int>(std::lround(g.center_u_px)));
}

// Synthetic boxes with a surface above the fingertips inside the closing region.
std::set<int> BoxesBetweenFingers(const Prepared& s, const Grasp& g) {
  const auto fp = testing::RasteriseGrasp(g, s.synth.object_id.size(), kFootprintShrinkPx);
  std::set<int> ids;
  for (int v = 0; v < fp.closing.rows; ++v) {
    for (int u = 0; u < fp.closing.cols; ++u) {
      if (fp.closing(v, u) && s.synth.height_m(v, u) > g.grasp_height_m) {
        ids.insert(s.synth.object_id(v, u));
      }
    }
  }
  return ids;
}

// Synthetic boxes reaching above the fingertips under the finger footprints.
std::set<int> BoxesUnderFingers(const Prepared& s, const Grasp& g) {
  const auto fp = testing::RasteriseGrasp(g, s.synth.object_id.size(), kFootprintShrinkPx);
  std::set<int> ids;
  for (int v = 0; v < fp.fingers.rows; ++v) {
    for (int u = 0; u < fp.fingers.cols; ++u) {
      if (fp.fingers(v, u) && s.synth.height_m(v, u) > g.grasp_height_m) {
        ids.insert(s.synth.object_id(v, u));
      }
    }
  }
  return ids;
}

// A brush lying on the table: a hard handle (box 1, 20 x 100 mm, 25 mm high) and a soft,
// taller head (box 2, 45 x 45 mm, 45 mm high) form instance 1.
SceneSpec Brush() {
  SceneSpec spec;
  spec.boxes = {Box{-0.04, 0.0, 0.100, 0.020, 0.025, 0.0, 1},
                Box{0.0325, 0.0, 0.045, 0.045, 0.045, 0.0, 2}};
  return spec;
}

TEST(DetectGraspsDeformability, GraspsTheHardHandleOfABrush) {
  const Prepared s = Make(Brush(), {{1, 1}, {2, 1}}, {{1, 0.05f}, {2, 0.9f}}, {0.9f});
  const auto result = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{});
  ASSERT_EQ(result.target_id, 1);
  ASSERT_FALSE(result.grasps.empty());
  EXPECT_FALSE(result.soft_part_allowed);
  for (const DeformabilityGrasp& dg : result.grasps) {
    EXPECT_EQ(dg.instance_id, 1);
    EXPECT_EQ(BoxAtCenter(s, dg.grasp), 1) << "grasp at " << dg.grasp.center_u_px;
    // The soft head is never contact: nothing of it between the fingers.
    EXPECT_EQ(BoxesBetweenFingers(s, dg.grasp).count(2), 0u);
    EXPECT_NEAR(dg.mean_deformability, 0.05, 1e-4);
    EXPECT_NEAR(dg.grasp.mean_stiffness, 0.95, 1e-4);
  }
  // The head is the target's top, so the first slices see the head alone; the handle is found
  // lower, inside the M slices.
  EXPECT_GT(result.grasps.front().grasp.height_step, 0);
  EXPECT_LT(result.grasps.front().grasp.contact_height_m, 0.025);
}

TEST(DetectGraspsDeformability, WithoutThePartialRuleTheSoftHeadIsTouched) {
  // The same brush with the rule off (fraction 0): the planner starts at the head's top and
  // grasps the head, which is the thesis' failure case for plain FGE.
  const Prepared s = Make(Brush(), {{1, 1}, {2, 1}}, {{1, 0.05f}, {2, 0.9f}}, {0.9f});
  DeformabilityParams params;
  params.stiff_part_fraction = 0;
  params.num_slices = 1;  // the head's slice only
  const auto result =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  ASSERT_FALSE(result.grasps.empty());
  EXPECT_EQ(BoxAtCenter(s, result.grasps.front().grasp), 2);
  EXPECT_GT(result.grasps.front().mean_deformability, 0.8);
}

// A 30 x 70 mm box (instance 1, rigid) between two sponges (instances 2 and 3, 35 mm high)
// 5 mm away on both long sides: the fingers fit only by pressing the sponges.
SceneSpec BoxBetweenSponges() {
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.070, 0.040, 0.0, 1},
                Box{-0.040, 0.0, 0.040, 0.090, 0.035, 0.0, 2},
                Box{0.040, 0.0, 0.040, 0.090, 0.035, 0.0, 3}};
  return spec;
}

// A rigid box (synthetic box 1) among soft sponges (boxes 2 and 3), each its own instance.
Prepared BoxAndSponges(const SceneSpec& spec) {
  return Make(spec, {{1, 1}, {2, 2}, {3, 3}}, {{1, 0.05f}, {2, 0.9f}, {3, 0.9f}},
              {0.9f, 0.9f, 0.9f});
}

TEST(DetectGraspsDeformability, PressesSoftSpongesAsideToReachABox) {
  const Prepared s = BoxAndSponges(BoxBetweenSponges());
  DeformabilityParams params;
  params.target_id = 1;
  const auto result =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  ASSERT_EQ(result.target_id, 1);
  ASSERT_FALSE(result.grasps.empty());
  const DeformabilityGrasp& best = result.grasps.front();
  EXPECT_EQ(BoxAtCenter(s, best.grasp), 1);
  EXPECT_EQ(best.pressed_ids, (std::vector<int>{2, 3}));
  // The fingertips go down to at most the press depth below the sponges' tops.
  EXPECT_GT(best.press_depth_m, 0.0);
  EXPECT_LE(best.press_depth_m, params.max_press_depth_m + 1e-3);
  EXPECT_NEAR(best.press_depth_m, 0.035 - best.grasp.grasp_height_m, 2e-3);
  EXPECT_EQ(BoxesUnderFingers(s, best.grasp), (std::set<int>{2, 3}));
  // Across the box (closing axis along u), the only direction within the stroke.
  EXPECT_LT(std::abs(std::sin(best.grasp.angle_rad)), 0.25);

  // Pushing off, or rigid neighbours: no grasp at all.
  params.soft_obstacle_threshold = 1.5;
  EXPECT_TRUE(DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params)
                  .grasps.empty());
  const Prepared rigid = Make(BoxBetweenSponges(), {{1, 1}, {2, 2}, {3, 3}},
                              {{1, 0.05f}, {2, 0.1f}, {3, 0.1f}}, {0.9f, 0.9f, 0.9f});
  params.soft_obstacle_threshold = 0.5;
  EXPECT_TRUE(
      DetectGraspsDeformability(rigid.scene, rigid.synth.camera, rigid.objects, Gripper{}, params)
          .grasps.empty());
  // A press depth too shallow for the slices: no grasp either.
  params.max_press_depth_m = 0.002;
  EXPECT_TRUE(DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params)
                  .grasps.empty());
}

TEST(DetectGraspsDeformability, ASoftTargetPressesItsSoftNeighboursButNotItself) {
  // The box between the sponges is as soft as they are. Pressing lowers its neighbours only:
  // the grasps are those of the rigid box (the box is one material either way), and the shared
  // pressed heights that rigid targets use, where the box would be lowered too, are not used.
  const Prepared rigid = BoxAndSponges(BoxBetweenSponges());
  const Prepared soft = Make(BoxBetweenSponges(), {{1, 1}, {2, 2}, {3, 3}},
                             {{1, 0.9f}, {2, 0.9f}, {3, 0.9f}}, {0.9f, 0.9f, 0.9f});
  DeformabilityParams params;
  params.target_id = 1;
  const auto a =
      DetectGraspsDeformability(rigid.scene, rigid.synth.camera, rigid.objects, Gripper{}, params);
  const auto b =
      DetectGraspsDeformability(soft.scene, soft.synth.camera, soft.objects, Gripper{}, params);
  ASSERT_FALSE(a.grasps.empty());
  ASSERT_EQ(a.grasps.size(), b.grasps.size());
  for (std::size_t i = 0; i < a.grasps.size(); ++i) {
    EXPECT_EQ(a.grasps[i].grasp.center_u_px, b.grasps[i].grasp.center_u_px) << i;
    EXPECT_EQ(a.grasps[i].grasp.center_v_px, b.grasps[i].grasp.center_v_px) << i;
    EXPECT_EQ(a.grasps[i].grasp.angle_rad, b.grasps[i].grasp.angle_rad) << i;
    EXPECT_EQ(a.grasps[i].grasp.grasp_height_m, b.grasps[i].grasp.grasp_height_m) << i;
    EXPECT_EQ(b.grasps[i].pressed_ids, (std::vector<int>{2, 3})) << i;
    EXPECT_NEAR(b.grasps[i].mean_deformability, 0.9, 1e-3) << i;
  }
}

TEST(DetectGraspsDeformability, NeverPressesASpongeThatFillsTheGap) {
  // The same box with the sponges flush against its long sides: a finger pressing a sponge
  // would have the sponge between itself and the box and squeeze both. No grasp.
  SceneSpec spec = BoxBetweenSponges();
  spec.boxes[1].x_m = -0.035;
  spec.boxes[2].x_m = 0.035;
  const Prepared s = BoxAndSponges(spec);
  DeformabilityParams params;
  params.target_id = 1;
  EXPECT_TRUE(DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params)
                  .grasps.empty());
}

TEST(DetectGraspsDeformability, PressesOnlyWhenNoGraspTouchesNothing) {
  // A 30 x 110 mm box with sponges 5 mm from both long sides along most of its length; its last
  // 25 mm stand free. A grasp across the free end touches nothing, so it is taken over the
  // many grasps further along that would press the sponges (a "sponge" may be a piece of the
  // target the segmentation split off).
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.110, 0.040, 0.0, 1},
                Box{-0.040, 0.0125, 0.040, 0.085, 0.035, 0.0, 2},
                Box{0.040, 0.0125, 0.040, 0.085, 0.035, 0.0, 3}};
  const Prepared s = BoxAndSponges(spec);
  DeformabilityParams params;
  params.target_id = 1;
  const auto result =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  ASSERT_EQ(result.target_id, 1);
  ASSERT_FALSE(result.grasps.empty());
  for (const DeformabilityGrasp& dg : result.grasps) {
    EXPECT_TRUE(dg.pressed_ids.empty());
    EXPECT_EQ(dg.press_depth_m, 0.0);
    EXPECT_TRUE(BoxesUnderFingers(s, dg.grasp).empty());
    EXPECT_EQ(BoxAtCenter(s, dg.grasp), 1);
  }
}

// One object of two widths: a narrow arm (box 1, 18 mm across) and a wide one (box 2, 40 mm),
// both 70 mm long (too long for the 50 mm stroke) and equally rigid.
SceneSpec TwoWidths() {
  SceneSpec spec;
  spec.boxes = {Box{-0.05, 0.0, 0.018, 0.070, 0.040, 0.0, 1},
                Box{0.05, 0.0, 0.040, 0.070, 0.040, 0.0, 2}};
  return spec;
}

TEST(DetectGraspsDeformability, ALowContrastSoftPartIsContactOnlyWhenNothingElseWorks) {
  // One object: an 18 mm arm and a 60 x 70 mm block (wider than the 50 mm stroke both ways).
  // The map shows the arm at stiffness 0.24 and the block at 0.5: below half the maximum, but
  // only 0.26 apart, as a learned map shows a rigid object among sponges. Kept out of the
  // contact, the object has no grasp; the second pass allows the arm and says so. With the
  // second pass off the arm is never contact. With a clear contrast (the arm at 0.1) the policy
  // never makes it contact, while a request that names the object gets the whole of it in a
  // last pass, flagged the same way.
  SceneSpec spec;
  spec.boxes = {Box{-0.05, 0.0, 0.018, 0.070, 0.040, 0.0, 1},
                Box{0.06, 0.0, 0.060, 0.070, 0.040, 0.0, 2}};
  DeformabilityParams params;
  params.target_id = 1;
  const Gripper gripper;
  const Prepared noisy = Make(spec, {{1, 1}, {2, 1}}, {{1, 0.76f}, {2, 0.5f}}, {0.9f});
  const auto result =
      DetectGraspsDeformability(noisy.scene, noisy.synth.camera, noisy.objects, gripper, params);
  EXPECT_TRUE(result.soft_part_allowed);
  EXPECT_EQ(result.tried_ids, (std::vector<int>{1}));
  ASSERT_FALSE(result.grasps.empty());
  EXPECT_EQ(BoxAtCenter(noisy, result.grasps.front().grasp), 1);

  params.min_part_contrast = 0;
  EXPECT_TRUE(
      DetectGraspsDeformability(noisy.scene, noisy.synth.camera, noisy.objects, gripper, params)
          .grasps.empty());
  params.min_part_contrast = DeformabilityParams{}.min_part_contrast;
  const Prepared parts = Make(spec, {{1, 1}, {2, 1}}, {{1, 0.9f}, {2, 0.5f}}, {0.9f});
  params.target_id = 0;
  params.whole_scene_fallback = false;
  const auto by_policy =
      DetectGraspsDeformability(parts.scene, parts.synth.camera, parts.objects, gripper, params);
  EXPECT_EQ(by_policy.tried_ids, (std::vector<int>{1}));
  EXPECT_TRUE(by_policy.grasps.empty());
  params.target_id = 1;
  const auto named =
      DetectGraspsDeformability(parts.scene, parts.synth.camera, parts.objects, gripper, params);
  EXPECT_TRUE(named.soft_part_allowed);
  ASSERT_FALSE(named.grasps.empty());
  EXPECT_EQ(BoxAtCenter(parts, named.grasps.front().grasp), 1);
}

TEST(DetectGraspsDeformability, TheSmallestOpeningThatWorksWins) {
  const Prepared s = Make(TwoWidths(), {{1, 1}, {2, 1}}, {{1, 0.1f}, {2, 0.1f}}, {0.9f});
  const Gripper gripper;
  const auto result = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, gripper);
  ASSERT_FALSE(result.grasps.empty());
  for (const DeformabilityGrasp& dg : result.grasps) {
    EXPECT_DOUBLE_EQ(dg.opening_fraction, 0.5);
    EXPECT_NEAR(dg.grasp.opening_m, 0.025, 1e-12);
    EXPECT_EQ(BoxAtCenter(s, dg.grasp), 1);
  }
  // The wide arm alone as the target (the narrow one another object): neither 25 nor 37.5 mm
  // fit around its 40 mm, the full stroke does.
  const Prepared apart = Make(TwoWidths(), {{1, 2}, {2, 1}}, {{1, 0.1f}, {2, 0.1f}}, {0.9f, 0.9f});
  DeformabilityParams wide;
  wide.target_id = 1;
  const auto full =
      DetectGraspsDeformability(apart.scene, apart.synth.camera, apart.objects, gripper, wide);
  ASSERT_FALSE(full.grasps.empty());
  for (const auto& dg : full.grasps) {
    EXPECT_DOUBLE_EQ(dg.opening_fraction, 1.0);
    EXPECT_NEAR(dg.grasp.opening_m, 0.050, 1e-12);
    EXPECT_EQ(BoxAtCenter(apart, dg.grasp), 2);
  }
}

TEST(DetectGraspsDeformability, ANarrowOpeningMustLeaveRoomToWork) {
  // A 30 mm box: 37.5 mm clears it with a narrow band of candidates (graspability about 0.09),
  // which works by default; asked for more room (0.2), the full stroke is used.
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.070, 0.040, 0.0, 1}};
  const Prepared s = Make(spec, {{1, 1}}, {{1, 0.1f}}, {0.9f});
  DeformabilityParams params;
  auto result = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  ASSERT_FALSE(result.grasps.empty());
  EXPECT_DOUBLE_EQ(result.grasps.front().opening_fraction, 0.75);
  for (const auto& dg : result.grasps) EXPECT_GE(dg.grasp.score, params.min_graspability);
  params.min_graspability = 0.2;
  result = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  ASSERT_FALSE(result.grasps.empty());
  EXPECT_DOUBLE_EQ(result.grasps.front().opening_fraction, 1.0);
}

// Two free boxes: a tall soft one (instance 1, 60 mm) and a lower rigid one (instance 2, 40 mm).
SceneSpec TallSoftLowHard() {
  SceneSpec spec;
  spec.boxes = {Box{-0.07, 0.0, 0.030, 0.060, 0.060, 0.0, 1},
                Box{0.07, 0.0, 0.030, 0.060, 0.040, 0.0, 2}};
  return spec;
}

TEST(DetectGraspsDeformability, TargetPolicies) {
  const Prepared s =
      Make(TallSoftLowHard(), {{1, 1}, {2, 2}}, {{1, 0.8f}, {2, 0.1f}}, {0.9f, 0.9f});
  DeformabilityParams params;
  EXPECT_EQ(OrderTargets(s.scene, s.objects, params), (std::vector<int>{1, 2}));
  auto result = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(result.target_id, 1);
  EXPECT_EQ(result.tried_ids, (std::vector<int>{1}));

  params.policy = TargetPolicy::kLeastDeformable;
  EXPECT_EQ(OrderTargets(s.scene, s.objects, params), (std::vector<int>{2, 1}));
  result = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(result.target_id, 2);
  ASSERT_FALSE(result.grasps.empty());
  EXPECT_NEAR(result.grasps.front().mean_deformability, 0.1, 1e-4);

  // Within the tie tolerance the highest wins.
  const Prepared close =
      Make(TallSoftLowHard(), {{1, 1}, {2, 2}}, {{1, 0.13f}, {2, 0.1f}}, {0.9f, 0.9f});
  EXPECT_EQ(OrderTargets(close.scene, close.objects, params), (std::vector<int>{1, 2}));

  // An explicit target wins over the policy.
  params.target_id = 1;
  EXPECT_EQ(
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params).target_id,
      1);
}

TEST(DetectGraspsDeformability, LeastDeformableLooksPastATargetWhoseStiffPartIsOutOfReach) {
  // Instance 1: a rigid slab too wide to grasp (box 1, 90 x 90 mm) joined to a 30 mm arm of
  // deformability 0.45 (box 2): its touchable part is mostly rigid, but the only grasp is on the
  // arm. Instance 2 (box 3, 30 mm, deformability 0.3, lower) gives a gentler grasp.
  SceneSpec spec;
  spec.boxes = {Box{-0.06, 0.0, 0.090, 0.090, 0.050, 0.0, 1},
                Box{0.005, 0.0, 0.040, 0.030, 0.050, 0.0, 2},
                Box{0.08, 0.0, 0.030, 0.070, 0.040, 0.0, 3}};
  const Prepared s =
      Make(spec, {{1, 1}, {2, 1}, {3, 2}}, {{1, 0.0f}, {2, 0.45f}, {3, 0.3f}}, {0.9f, 0.9f});
  DeformabilityParams params;
  params.policy = TargetPolicy::kLeastDeformable;
  EXPECT_EQ(OrderTargets(s.scene, s.objects, params), (std::vector<int>{1, 2}));
  const auto result =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(result.tried_ids, (std::vector<int>{1, 2}));
  ASSERT_EQ(result.target_id, 2);
  EXPECT_NEAR(result.grasps.front().mean_deformability, 0.3, 0.02);
  // The thesis' policy takes the first reachable target (the highest) as it is.
  params.policy = TargetPolicy::kHighest;
  const auto highest =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(highest.target_id, 1);
  EXPECT_EQ(highest.tried_ids, (std::vector<int>{1}));
}

TEST(DetectGraspsDeformability, UnconfidentInstancesAreNeverTargets) {
  const Prepared s =
      Make(TallSoftLowHard(), {{1, 1}, {2, 2}}, {{1, 0.1f}, {2, 0.1f}}, {0.1f, 0.9f});
  DeformabilityParams params;  // R = 0.25
  EXPECT_EQ(OrderTargets(s.scene, s.objects, params), (std::vector<int>{2}));
  const auto result =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(result.target_id, 2);
  params.min_score = 0.95;
  EXPECT_TRUE(OrderTargets(s.scene, s.objects, params).empty());
  // No target: the whole scene, ranked by the map (both boxes equally rigid here).
  const auto fallback =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(fallback.target_id, 0);
  EXPECT_TRUE(fallback.fallback);
  ASSERT_FALSE(fallback.grasps.empty());
  for (const auto& dg : fallback.grasps) {
    EXPECT_EQ(dg.instance_id, BoxAtCenter(s, dg.grasp));
    EXPECT_NEAR(dg.mean_deformability, 0.1, 1e-4);
  }
  params.whole_scene_fallback = false;
  const auto none =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(none.target_id, 0);
  EXPECT_FALSE(none.fallback);
  EXPECT_TRUE(none.grasps.empty());
}

TEST(DetectGraspsDeformability, TheNextTargetIsTriedWhenTheFirstHasNoGrasp) {
  // The highest box is 80 mm wide in both directions: nothing grasps it; the next one is used.
  SceneSpec spec;
  spec.boxes = {Box{-0.08, 0.0, 0.080, 0.080, 0.070, 0.0, 1},
                Box{0.08, 0.0, 0.030, 0.060, 0.040, 0.0, 2}};
  const Prepared s = Make(spec, {{1, 1}, {2, 2}}, {{1, 0.1f}, {2, 0.1f}}, {0.9f, 0.9f});
  const auto result = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{});
  EXPECT_EQ(result.tried_ids, (std::vector<int>{1, 2}));
  EXPECT_EQ(result.target_id, 2);
  DeformabilityParams one;
  one.max_targets = 1;
  one.whole_scene_fallback = false;
  EXPECT_EQ(DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, one).target_id,
            0);
}

TEST(DetectGraspsDeformability, AMaskCoveringPartOfItsObjectGrowsIntoTheUnlabelledForeground) {
  // The segmenter labelled only the left half of a 30 x 70 mm box (the rest is foreground
  // without an instance). Without the foreground the unlabelled half is an obstacle and no
  // grasp fits; with it the target is the whole box.
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.070, 0.040, 0.0, 1}};
  Prepared s = Make(spec, {{1, 1}}, {{1, 0.1f}}, {0.9f});
  const double u_mid = testing::ProjectTablePoint(spec, 0.0, 0.0, 0.04).x;
  s.objects.foreground = cv::Mat1f(s.objects.labels.size(), 0.0f);
  s.objects.foreground.setTo(1.0f, s.objects.labels == 1);
  for (int v = 0; v < s.objects.labels.rows; ++v) {
    for (int u = static_cast<int>(u_mid); u < s.objects.labels.cols; ++u)
      s.objects.labels(v, u) = 0;
  }
  DeformabilityParams params;
  params.whole_scene_fallback = false;
  ObjectMaps cut = s.objects;
  cut.foreground = cv::Mat1f();
  EXPECT_TRUE(
      DetectGraspsDeformability(s.scene, s.synth.camera, cut, Gripper{}, params).grasps.empty());
  const auto grown =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(grown.target_id, 1);
  ASSERT_FALSE(grown.grasps.empty());
  EXPECT_EQ(BoxAtCenter(s, grown.grasps.front().grasp), 1);
}

TEST(DetectGraspsDeformability, AMaskDoesNotGrowIntoForegroundThatDoesNotTouchIt) {
  // Box 2 is foreground without an instance but stands apart from instance 1: the target grows
  // only into the pieces that touch it, so every grasp stays on box 1.
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.070, 0.040, 0.0, 1},
                Box{0.12, 0.0, 0.030, 0.070, 0.060, 0.0, 2}};
  Prepared s = Make(spec, {{1, 1}, {2, 0}}, {{1, 0.1f}, {2, 0.1f}}, {0.9f});
  s.objects.foreground = cv::Mat1f(s.objects.labels.size(), 0.0f);
  s.objects.foreground.setTo(1.0f, s.synth.object_id > 0);
  DeformabilityParams params;
  params.whole_scene_fallback = false;
  const auto result =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(result.target_id, 1);
  ASSERT_FALSE(result.grasps.empty());
  for (const auto& g : result.grasps) EXPECT_EQ(BoxAtCenter(s, g.grasp), 1);
}

// A segmentation that merged a box with the taller sponge beside it (one instance, and a map
// that calls both rigid): named by id, the instance's top is the sponge's and the grasp lands
// there; named by a click on the box, only the box is grasped and the sponge is an obstacle.
TEST(DetectGraspsDeformability, AClickCutsAMergedTargetToTheClickedObject) {
  SceneSpec spec;  // box 1 (40 mm) and sponge 2 (70 mm) touching along x; 40 mm across y
  spec.boxes = {Box{-0.06, 0.02, 0.030, 0.040, 0.040, 0.0, 1},
                Box{-0.03, 0.02, 0.030, 0.040, 0.070, 0.0, 2}};
  const Prepared s = Make(spec, {{1, 1}, {2, 1}}, {{1, 0.0f}, {2, 0.0f}}, {0.9f});
  DeformabilityParams params;
  params.target_id = 1;
  const auto by_id =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  ASSERT_FALSE(by_id.grasps.empty());
  EXPECT_EQ(BoxAtCenter(s, by_id.grasps.front().grasp), 2);

  // The click: the box's centre pixel.
  cv::Point click(-1, -1);
  double best = -1;
  cv::Mat1f distance;
  cv::distanceTransform(s.synth.object_id == 1, distance, cv::DIST_L2, 3);
  cv::minMaxLoc(distance, nullptr, &best, nullptr, &click);
  params.target_px = click;
  const auto by_click =
      DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  EXPECT_EQ(by_click.target_id, 1);
  ASSERT_FALSE(by_click.grasps.empty());
  for (const DeformabilityGrasp& dg : by_click.grasps) {
    EXPECT_EQ(BoxAtCenter(s, dg.grasp), 1);
    EXPECT_EQ(BoxesBetweenFingers(s, dg.grasp), (std::set<int>{1}));
    EXPECT_TRUE(BoxesUnderFingers(s, dg.grasp).empty());
  }

  // A click off the instance names nothing to cut: the whole instance, as by id.
  params.target_px = cv::Point(5, 5);
  const auto off = DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, params);
  ASSERT_FALSE(off.grasps.empty());
  EXPECT_EQ(BoxAtCenter(s, off.grasps.front().grasp), 2);
}

// A 40 mm box target at x = 50 mm; soft boxes 30 mm beside it (y), 180 mm away (x = -200 mm),
// and a 300 mm tall one 40 mm beside it (x = 130 mm) whose top, near the camera, is seen far off.
TEST(SoftNeighbourInReach, LooksWhereTheGripperCanReachAtEveryDepth) {
  SceneSpec spec;
  spec.boxes = {Box{0.05, 0.0, 0.04, 0.04, 0.04, 0.0, 1}, Box{0.05, 0.07, 0.04, 0.04, 0.04, 0.0, 2},
                Box{-0.20, 0.0, 0.04, 0.04, 0.04, 0.0, 3},
                Box{0.13, 0.0, 0.04, 0.04, 0.30, 0.0, 4}};
  const Prepared s = Make(spec, {{1, 1}, {2, 2}, {3, 3}, {4, 4}},
                          {{1, 0.1f}, {2, 0.9f}, {3, 0.9f}, {4, 0.9f}}, {0.9f, 0.9f, 0.9f, 0.9f});
  const Camera& camera = s.synth.camera;
  const cv::Mat1b target = s.objects.labels == 1;
  const cv::Mat1b beside = s.objects.labels == 2;
  const cv::Mat1b far = s.objects.labels == 3;
  const cv::Mat1b tall_top = (s.objects.labels == 4) & (s.scene.height_m > 0.29f);
  ASSERT_GT(cv::countNonZero(tall_top), 0);
  const Gripper gripper;
  EXPECT_TRUE(SoftNeighbourInReach(s.scene, camera, gripper, target, beside));
  EXPECT_FALSE(SoftNeighbourInReach(s.scene, camera, gripper, target, far));
  // The tall box's top lies 40 mm from the target in x-y (within the 58 mm the gripper spans
  // from a contact pixel), but further from it in the image than the gripper reaches at the
  // target's depth (0.56 m).
  const double reach_px_at_target = 0.07 * camera.fx / 0.56;
  const cv::Rect target_box = cv::boundingRect(target);
  const cv::Rect top_box = cv::boundingRect(tall_top);
  ASSERT_GT(top_box.x - (target_box.x + target_box.width), reach_px_at_target);
  EXPECT_TRUE(SoftNeighbourInReach(s.scene, camera, gripper, target, tall_top));
  // A wider stroke reaches the far box too.
  Gripper wide;
  wide.opening_stroke_m = 0.25;
  EXPECT_TRUE(SoftNeighbourInReach(s.scene, camera, wide, target, far));
  // Nothing soft, or no contact: nothing to press.
  const cv::Mat1b none(target.size(), static_cast<unsigned char>(0));
  EXPECT_FALSE(SoftNeighbourInReach(s.scene, camera, gripper, target, none));
  EXPECT_FALSE(SoftNeighbourInReach(s.scene, camera, gripper, none, beside));
}

TEST(DetectGraspsDeformability, BadInputThrows) {
  const Prepared s =
      Make(TallSoftLowHard(), {{1, 1}, {2, 2}}, {{1, 0.1f}, {2, 0.1f}}, {0.9f, 0.9f});
  ObjectMaps wrong = s.objects;
  wrong.deformability = cv::Mat1f(10, 10, 0.f);
  EXPECT_THROW(DetectGraspsDeformability(s.scene, s.synth.camera, wrong, Gripper{}),
               std::invalid_argument);
  wrong = s.objects;
  wrong.foreground = cv::Mat1f(10, 10, 0.f);
  EXPECT_THROW(DetectGraspsDeformability(s.scene, s.synth.camera, wrong, Gripper{}),
               std::invalid_argument);
  wrong = s.objects;
  wrong.scores = {0.9f};  // id 2 has no score
  EXPECT_THROW(DetectGraspsDeformability(s.scene, s.synth.camera, wrong, Gripper{}),
               std::invalid_argument);
  const auto bad = [&](auto change) {
    DeformabilityParams p;
    change(p);
    EXPECT_THROW(DetectGraspsDeformability(s.scene, s.synth.camera, s.objects, Gripper{}, p),
                 std::invalid_argument);
  };
  bad([](DeformabilityParams& p) { p.slice_step_m = 0; });
  bad([](DeformabilityParams& p) { p.slice_step_m = 0.05; });  // longer than the fingers
  bad([](DeformabilityParams& p) { p.num_slices = 0; });
  bad([](DeformabilityParams& p) { p.min_score = 1.5; });
  bad([](DeformabilityParams& p) { p.opening_fractions = {}; });
  bad([](DeformabilityParams& p) { p.opening_fractions = {1.0, 0.5}; });
  bad([](DeformabilityParams& p) { p.opening_fractions = {0.0}; });
  bad([](DeformabilityParams& p) { p.stiff_part_fraction = -0.1; });
  bad([](DeformabilityParams& p) { p.max_press_depth_m = -1; });
  bad([](DeformabilityParams& p) { p.min_part_contrast = 1.5; });
  bad([](DeformabilityParams& p) { p.min_target_area_px = std::nan(""); });
  bad([](DeformabilityParams& p) { p.max_targets = 0; });
  bad([](DeformabilityParams& p) { p.min_graspability = 2; });
  bad([](DeformabilityParams& p) { p.deformability_step = -0.1; });
  bad([](DeformabilityParams& p) { p.fge.num_angles = 0; });
}

}  // namespace
}  // namespace softgrasp::core
