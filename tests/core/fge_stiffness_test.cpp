#include "service/core/fge_stiffness.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "service/core/metrics.h"
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
};

Prepared Make(const SceneSpec& spec) {
  Prepared s{RenderScene(spec), {}};
  auto scene = Preprocess(s.synth.depth, s.synth.camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  s.scene = std::move(scene).value();
  return s;
}

// The same grasps, in the same order, field by field.
void ExpectSameGrasps(const std::vector<Grasp>& a, const std::vector<Grasp>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].center_u_px, b[i].center_u_px) << "grasp " << i;
    EXPECT_EQ(a[i].center_v_px, b[i].center_v_px) << "grasp " << i;
    EXPECT_EQ(a[i].angle_rad, b[i].angle_rad) << "grasp " << i;
    EXPECT_EQ(a[i].opening_px, b[i].opening_px) << "grasp " << i;
    EXPECT_EQ(a[i].grasp_height_m, b[i].grasp_height_m) << "grasp " << i;
    EXPECT_EQ(a[i].score, b[i].score) << "grasp " << i;
    EXPECT_EQ(a[i].mean_stiffness, b[i].mean_stiffness) << "grasp " << i;
  }
}

// Stiffness per object id (0 on the table and where nothing is hit).
cv::Mat1f MapById(const testing::SyntheticScene& synth, const std::vector<float>& by_id) {
  cv::Mat1f map(synth.object_id.size(), 0.0f);
  for (int v = 0; v < map.rows; ++v) {
    for (int u = 0; u < map.cols; ++u) {
      const int id = synth.object_id(v, u);
      if (id > 0 && id < static_cast<int>(by_id.size()))
        map(v, u) = by_id[static_cast<std::size_t>(id)];
    }
  }
  return map;
}

int IdAtCenter(const Prepared& s, const Grasp& g) {
  return s.synth.object_id(static_cast<int>(std::lround(g.center_v_px)),
                           static_cast<int>(std::lround(g.center_u_px)));
}

std::set<int> TouchedIds(const Prepared& s, const Grasp& g) {
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

SceneSpec TwoEqualBoxes() {
  SceneSpec spec;  // same size, same height, 12 cm apart: FGE finds both equally graspable
  spec.boxes = {Box{-0.06, 0.0, 0.030, 0.060, 0.040, 0.0, 1},
                Box{0.06, 0.0, 0.030, 0.060, 0.040, 0.0, 2}};
  return spec;
}

TEST(DetectGraspsStiffness, PicksTheHardOfTwoEqualBoxes) {
  const Prepared s = Make(TwoEqualBoxes());
  for (int hard : {1, 2}) {
    const cv::Mat1f map = MapById(
        s.synth, hard == 1 ? std::vector<float>{0, 0.9f, 0.2f} : std::vector<float>{0, 0.2f, 0.9f});
    const auto grasps = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
    ASSERT_FALSE(grasps.empty());
    EXPECT_EQ(IdAtCenter(s, grasps.front()), hard);
    EXPECT_NEAR(grasps.front().mean_stiffness, 0.9, 1e-5);
    for (std::size_t i = 1; i < grasps.size(); ++i) {
      EXPECT_GE(grasps[i - 1].mean_stiffness + 0.05 * grasps[i - 1].score,
                grasps[i].mean_stiffness + 0.05 * grasps[i].score - 1e-9);
    }
  }
  // Classic FGE sees two equal boxes; its grasps carry no stiffness.
  const auto fge = DetectGraspsFge(s.scene, s.synth.camera, Gripper{});
  ASSERT_FALSE(fge.empty());
  EXPECT_TRUE(std::isnan(fge.front().mean_stiffness));
}

// Like classic FGE, the search goes on below a top object too wide to grasp.
TEST(DetectGraspsStiffness, SearchGoesBelowAnUngraspableTopUntilItFindsGrasps) {
  SceneSpec spec;
  spec.boxes = {Box{-0.08, 0.0, 0.080, 0.080, 0.150, 0.0, 1},
                Box{0.08, 0.0, 0.030, 0.080, 0.040, 0.0, 2}};
  const Prepared s = Make(spec);
  const cv::Mat1f map = MapById(s.synth, {0, 0.9f, 0.8f});
  StiffnessFgeParams params;
  params.fge.top_k = 3;
  const auto grasps = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{}, params);
  ASSERT_FALSE(grasps.empty());
  for (const Grasp& g : grasps) {
    EXPECT_EQ(IdAtCenter(s, g), 2);
    EXPECT_GE(g.height_step, params.fge.num_height_steps);
    EXPECT_NEAR(g.mean_stiffness, 0.8, 1e-5);
  }
}

TEST(DetectGraspsStiffness, GraspsTheHardEndOfALongBox) {
  // A 30 x 120 mm box along y (image v): FGE prefers its middle; with the last 40 mm (y > 0.02)
  // hard (1.0) and the rest soft (0.3) the stiffness strategy grasps that end, like a bottle
  // by its cap.
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.120, 0.040, 0.0, 1}};
  const Prepared s = Make(spec);
  cv::Mat1f map = MapById(s.synth, {0, 0.3f});
  const double v_hard = testing::ProjectTablePoint(spec, 0, 0.02, 0.04).y;
  for (int v = 0; v < map.rows; ++v) {
    if (v < v_hard) continue;
    for (int u = 0; u < map.cols; ++u) {
      if (map(v, u) > 0) map(v, u) = 1.0f;
    }
  }
  const auto fge = DetectGraspsFge(s.scene, s.synth.camera, Gripper{});
  ASSERT_FALSE(fge.empty());
  const double v_mid = testing::ProjectTablePoint(spec, 0, 0, 0.04).y;
  EXPECT_NEAR(fge.front().center_v_px, v_mid, 12.0);
  const double fge_mean = ContactMeanStiffness(s.scene, map, fge.front());
  EXPECT_LT(fge_mean, 0.5);

  const auto grasps = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
  ASSERT_FALSE(grasps.empty());
  const Grasp& best = grasps.front();
  EXPECT_GT(best.center_v_px, v_hard);
  EXPECT_GT(best.mean_stiffness, 0.95);
  // The search's box-sum mean (work resolution) agrees with the per-pixel mean within the few
  // border pixels that reach into the soft part.
  EXPECT_NEAR(ContactMeanStiffness(s.scene, map, best), best.mean_stiffness, 0.08);
  // The closing region spans the 30 mm width: across the box (closing axis along u).
  EXPECT_LT(std::abs(std::sin(best.angle_rad)), 0.25);
  // Eq. 3.14 on the map agrees: the hard end scores higher than FGE's middle.
  EXPECT_GT(MeanStiffnessInGraspRegion(map, best), MeanStiffnessInGraspRegion(map, fge.front()));
}

TEST(DetectGraspsStiffness, SlipAndSeamFiltersStillApply) {
  // Two boxes pressed together (heights 40 and 65 mm): the seam between them is made the
  // hardest place of the map, yet no grasp may squeeze both boxes.
  SceneSpec spec;
  spec.boxes = {Box{-0.015, 0.0, 0.030, 0.040, 0.040, 0.0, 1},
                Box{0.015, 0.0, 0.030, 0.040, 0.065, 0.0, 2}};
  const Prepared s = Make(spec);
  cv::Mat1f map = MapById(s.synth, {0, 0.2f, 0.2f});
  const double u_seam = testing::ProjectTablePoint(spec, 0.0, 0.0, 0.05).x;
  for (int v = 0; v < map.rows; ++v) {
    for (int u = 0; u < map.cols; ++u) {
      if (map(v, u) > 0 && std::abs(u - u_seam) < 10) map(v, u) = 1.0f;
    }
  }
  const auto grasps = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
  ASSERT_FALSE(grasps.empty());
  for (const Grasp& g : grasps) {
    const std::set<int> ids = TouchedIds(s, g);
    EXPECT_FALSE(ids.count(1) && ids.count(2))
        << "grasp at " << g.center_u_px << "," << g.center_v_px << " squeezes both boxes";
  }
}

TEST(DetectGraspsStiffness, SlopedSurfaceIsRejectedBySlip) {
  // A low wide box (the base) with a slim tall box on it, made hard: grasping the slim box
  // from a slice where the wide base fills the closing region below the contact is slip.
  // Every returned grasp must satisfy FGE's slip rule, checked on the exact heights.
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.045, 0.045, 0.020, 0.0, 1},
                Box{0.0, 0.0, 0.012, 0.030, 0.060, 0.0, 2}};
  const Prepared s = Make(spec);
  const cv::Mat1f map = MapById(s.synth, {0, 0.2f, 1.0f});
  const auto grasps = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
  for (const Grasp& g : grasps) {
    const auto fp = testing::RasteriseGrasp(g, s.synth.object_id.size(), kFootprintShrinkPx);
    const int contact = cv::countNonZero(fp.closing & (s.synth.height_m > g.contact_height_m));
    const int above_tips = cv::countNonZero(fp.closing & (s.synth.height_m > g.grasp_height_m));
    EXPECT_LE(above_tips, 1.5 * contact * 1.1 + 4)
        << "slip grasp at " << g.center_u_px << "," << g.center_v_px;
  }
}

TEST(DetectGraspsStiffness, BadInputThrowsOrYieldsNothing) {
  const Prepared s = Make(TwoEqualBoxes());
  const cv::Mat1f wrong(10, 10, 0.5f);
  EXPECT_THROW(DetectGraspsStiffness(s.scene, s.synth.camera, wrong, Gripper{}),
               std::invalid_argument);
  const cv::Mat1f map = MapById(s.synth, {0, 0.5f, 0.5f});
  StiffnessFgeParams bad;
  bad.candidate_step_px = 0;
  EXPECT_THROW(DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{}, bad),
               std::invalid_argument);
  bad = {};
  bad.fge.num_angles = 0;
  EXPECT_THROW(DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{}, bad),
               std::invalid_argument);
  // An all-NaN map (a broken model) ranks everything as softest but still returns FGE grasps.
  const cv::Mat1f nan(map.size(), std::nanf(""));
  const auto grasps = DetectGraspsStiffness(s.scene, s.synth.camera, nan, Gripper{});
  ASSERT_FALSE(grasps.empty());
  EXPECT_EQ(grasps.front().mean_stiffness, 0.0);
  // Values out of [0, 1] count as the nearest end: 3 as 1, -2 as 0, +-infinity likewise.
  const cv::Mat1f high = MapById(s.synth, {0, 3.0f, 3.0f}), one = MapById(s.synth, {0, 1, 1});
  const cv::Mat1f low = MapById(s.synth, {0, -2.0f, -std::numeric_limits<float>::infinity()});
  ExpectSameGrasps(DetectGraspsStiffness(s.scene, s.synth.camera, high, Gripper{}),
                   DetectGraspsStiffness(s.scene, s.synth.camera, one, Gripper{}));
  const auto from_low = DetectGraspsStiffness(s.scene, s.synth.camera, low, Gripper{});
  ASSERT_FALSE(from_low.empty());
  EXPECT_EQ(from_low.front().mean_stiffness, 0.0);
  // A flat table: nothing to grasp.
  const Prepared flat = Make(SceneSpec{});
  EXPECT_TRUE(DetectGraspsStiffness(flat.scene, flat.synth.camera,
                                    cv::Mat1f(flat.scene.height_m.size(), 1.0f), Gripper{})
                  .empty());
}

// The fast path's mean (A_st / A_t from box sums at work resolution) agrees with the
// straightforward per-pixel mean over each returned grasp's closing region, on a smooth map and on
// one with steps inside objects.
TEST(DetectGraspsStiffness, FastMeanMatchesThePerPixelMean) {
  const Prepared s = Make(testing::ClutterSceneSpec());
  cv::Mat1f ramp(s.scene.height_m.size()), steps(s.scene.height_m.size());
  for (int v = 0; v < ramp.rows; ++v) {
    for (int u = 0; u < ramp.cols; ++u) {
      ramp(v, u) = static_cast<float>(0.5 + 0.45 * std::sin(u / 23.0) * std::cos(v / 31.0));
      steps(v, u) = 0.1f + 0.9f * static_cast<float>((u / 40 + v / 30) % 10) / 9.0f;
    }
  }
  StiffnessFgeParams params;
  params.fge.top_k = 40;
  for (const cv::Mat1f& map : {ramp, steps}) {
    const auto grasps = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{}, params);
    ASSERT_GE(grasps.size(), 20u);
    for (const Grasp& g : grasps) {
      const double reference = ContactMeanStiffness(s.scene, map, g);
      ASSERT_TRUE(std::isfinite(reference));
      // Measured: at most 0.006 (nearest-neighbour rotation of 2 x 2 pixel blocks at the borders).
      EXPECT_NEAR(g.mean_stiffness, reference, 0.015)
          << "grasp at " << g.center_u_px << "," << g.center_v_px << " angle " << g.angle_rad;
    }
  }
}

TEST(DetectGraspsStiffness, Deterministic) {
  const Prepared s = Make(testing::ClutterSceneSpec());
  cv::Mat1f map(s.scene.height_m.size());
  for (int v = 0; v < map.rows; ++v) {
    for (int u = 0; u < map.cols; ++u) map(v, u) = 0.1f + 0.9f * ((u / 40 + v / 30) % 10) / 9.0f;
  }
  const auto a = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
  const auto b = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
  ASSERT_FALSE(a.empty());
  ExpectSameGrasps(a, b);
}

// One slice search serves every opening: the grasps are those of a search made per call.
TEST(DetectGraspsStiffness, ASharedSliceSearchGivesTheSameGraspsForEachOpening) {
  const Prepared s = Make(testing::ClutterSceneSpec());
  const cv::Mat1f map = MapById(s.synth, {0.0f, 1.0f, 0.3f, 0.8f, 0.5f, 1.0f, 0.2f, 0.9f, 0.6f});
  const Gripper full{};
  const fge_detail::SliceSearch search = StiffnessSliceSearch(s.scene, s.synth.camera, full);
  ASSERT_FALSE(search.slices.empty());
  std::size_t found = 0;
  for (const double fraction : {0.5, 0.75, 1.0}) {
    Gripper opened = full;
    opened.opening_stroke_m = full.opening_stroke_m * fraction;
    const auto own = DetectGraspsStiffness(s.scene, s.synth.camera, map, opened);
    const auto shared = DetectGraspsStiffness(s.scene, s.synth.camera, map, opened, {}, search);
    SCOPED_TRACE("opening fraction " + std::to_string(fraction));
    ExpectSameGrasps(own, shared);
    found += own.size();
  }
  EXPECT_GT(found, 0u);
}

// The candidates of the angles are computed on OpenCV's threads: one thread or two, the same
// grasps in the same order.
TEST(DetectGraspsStiffness, TheGraspsDoNotDependOnTheThreadCount) {
  const Prepared s = Make(testing::ClutterSceneSpec());
  const cv::Mat1f map = MapById(s.synth, {0.0f, 1.0f, 0.3f, 0.8f, 0.5f, 1.0f, 0.2f, 0.9f, 0.6f});
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const auto one = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
  cv::setNumThreads(2);
  const auto two = DetectGraspsStiffness(s.scene, s.synth.camera, map, Gripper{});
  cv::setNumThreads(threads);
  ASSERT_FALSE(one.empty());
  ExpectSameGrasps(one, two);
}

// The work a slice search does before it looks at the contact mask is shared by every target
// of the deformability planner: the slices and graspable pixels are those of a search made per
// mask, for each object, for a mask with no pixel and for no mask at all.
TEST(DetectGraspsStiffness, ASharedFreeSpaceGivesTheSameSearchForEveryContactMask) {
  const Prepared s = Make(testing::ClutterSceneSpec());
  const StiffnessFgeParams params;
  fge_detail::FreeSpace free_space(
      s.scene.height_m, fge_detail::PxPerMetre(s.scene.floor, s.synth.camera, 0), params.fge);
  double max_id = 0;
  cv::minMaxLoc(s.synth.object_id, nullptr, &max_id);
  ASSERT_GE(max_id, 3);
  std::vector<cv::Mat1b> masks = {cv::Mat1b(), cv::Mat1b(s.scene.height_m.size(), 0)};
  for (int id = 1; id <= static_cast<int>(max_id); ++id) masks.push_back(s.synth.object_id == id);
  int searched = 0;
  for (const cv::Mat1b& mask : masks) {
    Scene view = s.scene;
    view.contact_allowed = mask;
    const auto own = StiffnessSliceSearch(view, s.synth.camera, Gripper{}, params);
    const auto shared = StiffnessSliceSearch(view, s.synth.camera, Gripper{}, params, free_space);
    ASSERT_EQ(own.slices.size(), shared.slices.size());
    for (std::size_t k = 0; k < own.slices.size(); ++k) {
      EXPECT_EQ(own.slices[k].contact_height_m, shared.slices[k].contact_height_m);
    }
    ASSERT_EQ(own.graspable.size(), shared.graspable.size());
    if (!own.graspable.empty()) {
      EXPECT_EQ(cv::countNonZero(own.graspable != shared.graspable), 0);
    }
    if (!own.slices.empty()) ++searched;
  }
  EXPECT_GE(searched, 4);  // every object and the whole scene have slices

  StiffnessFgeParams other = params;  // other levels: the free space does not serve them
  other.fge.height_step_m *= 2;
  EXPECT_THROW(StiffnessSliceSearch(s.scene, s.synth.camera, Gripper{}, other, free_space),
               std::invalid_argument);
  Scene copy = s.scene;  // other heights
  copy.height_m = s.scene.height_m.clone();
  EXPECT_THROW(StiffnessSliceSearch(copy, s.synth.camera, Gripper{}, params, free_space),
               std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::core
