#include "service/core/fge.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <set>
#include <stdexcept>

#include "service/core/fge_geometry.h"
#include "service/core/preprocess.h"
#include "tests/support/fge_reference.h"
#include "tests/support/grasp_footprint.h"
#include "tests/support/synthetic_scene.h"

namespace softgrasp::core {
namespace {

using testing::Box;
using testing::RenderScene;
using testing::SceneSpec;

constexpr double kPi = std::numbers::pi;
constexpr double kAngleStepRad = kPi / 16;  // FgeParams{}.num_angles = 16
constexpr double kCenterTolM = 0.004;       // grasp centre vs box centre
constexpr double kFootprintShrinkPx = 1.0;  // rasterisation slack at footprint borders
constexpr double kWorkPixelPx = 2.0;        // the fast path rasterises at half resolution
// Fast vs reference maps (the fast path works at half resolution on rotated images).
constexpr double kMapIouMin = 0.8;        // candidate maps of a single box (measured 0.85-0.9)
constexpr double kMapBorderPx = 3.0;      // disagreements lie this close to a region border
constexpr double kClutterIouMin = 0.5;    // with thin corner slivers (measured 0.57-0.83)
constexpr double kClutterBorderPx = 5.0;  // slivers up to ~10 px thick may differ
constexpr double kCrossScoreMin = 0.95;   // one map's best pixel scores this well in the other
constexpr double kContactRelTol = 0.15;   // mean A_t where both maps have candidates

struct Detection {
  testing::SyntheticScene synth;
  Scene scene;
  std::vector<Grasp> grasps;
};

Detection Detect(const SceneSpec& spec, const FgeParams& params = {}) {
  Detection d{RenderScene(spec), {}, {}};
  auto scene = Preprocess(d.synth.depth, d.synth.camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  d.scene = std::move(scene).value();
  d.grasps = DetectGraspsFge(d.scene, d.synth.camera, Gripper{}, params);
  return d;
}

// Distance between two closing-axis angles (they wrap at pi).
double AngleDistance(double a, double b) {
  const double d = std::fmod(std::abs(a - b), kPi);
  return std::min(d, kPi - d);
}

// Ids of the surfaces the fingers touch: pixels in the closing region above the fingertips.
std::set<int> TouchedIds(const Detection& d, const Grasp& g) {
  const auto fp = testing::RasteriseGrasp(g, d.synth.object_id.size(), kFootprintShrinkPx);
  std::set<int> ids;
  for (int v = 0; v < fp.closing.rows; ++v) {
    for (int u = 0; u < fp.closing.cols; ++u) {
      if (fp.closing(v, u) && d.synth.height_m(v, u) > g.grasp_height_m) {
        ids.insert(d.synth.object_id(v, u));
      }
    }
  }
  return ids;
}

// Highest exact surface under either finger footprint.
double MaxHeightUnderFingers(const Detection& d, const Grasp& g) {
  const auto fp = testing::RasteriseGrasp(g, d.synth.object_id.size(), kFootprintShrinkPx);
  double highest = -1;
  for (int v = 0; v < fp.fingers.rows; ++v) {
    for (int u = 0; u < fp.fingers.cols; ++u) {
      if (fp.fingers(v, u)) highest = std::max(highest, double{d.synth.height_m(v, u)});
    }
  }
  return highest;
}

bool FingersTouchId(const Detection& d, const Grasp& g, int id) {
  const auto fp = testing::RasteriseGrasp(g, d.synth.object_id.size(), kFootprintShrinkPx);
  return cv::countNonZero(fp.fingers & (d.synth.object_id == id)) > 0;
}

int IdAtCenter(const Detection& d, const Grasp& g) {
  return d.synth.object_id(static_cast<int>(std::lround(g.center_v_px)),
                           static_cast<int>(std::lround(g.center_u_px)));
}

TEST(DetectGraspsFge, SlimBoxIsGraspedAcrossItsShortSideAtItsMiddle) {
  SceneSpec spec;
  const Box box{0.02, -0.01, 0.030, 0.080, 0.040, 0.3, 1};
  spec.boxes = {box};
  const Detection d = Detect(spec);
  ASSERT_FALSE(d.grasps.empty());
  const Grasp& best = d.grasps.front();
  EXPECT_LE(AngleDistance(best.angle_rad, box.yaw_rad), kAngleStepRad + 1e-9);
  const cv::Point3d center = testing::TableToCamera(spec, box.x_m, box.y_m, best.grasp_height_m);
  EXPECT_NEAR(best.p_CG_m[0], center.x, kCenterTolM);
  EXPECT_NEAR(best.p_CG_m[1], center.y, kCenterTolM);
  EXPECT_EQ(IdAtCenter(d, best), 1);
  EXPECT_GT(best.score, 0.0);
  EXPECT_LE(best.score, 1.0);
  for (std::size_t i = 1; i < d.grasps.size(); ++i) {
    EXPECT_GE(d.grasps[i - 1].score, d.grasps[i].score);
  }
}

// With 4 angles (0, 45, 90, 135 deg) a box turned by 15 deg meets the fingers at 15 deg: its
// contacts are stable, not firm (docs/fge.md, "Contact check"). It is still grasped alone, but
// beside a box square to the fingers every grasp is on that one.
TEST(DetectGraspsFge, FirmContactsRankFirstAndStableOnesAreTheFallback) {
  FgeParams params;
  params.num_angles = 4;
  SceneSpec spec;
  spec.boxes = {Box{-0.05, 0.0, 0.030, 0.080, 0.040, 15 * kPi / 180, 1}};
  const Detection alone = Detect(spec, params);
  ASSERT_FALSE(alone.grasps.empty());
  EXPECT_EQ(IdAtCenter(alone, alone.grasps.front()), 1);
  spec.boxes.push_back(Box{0.05, 0.0, 0.030, 0.080, 0.040, 0.0, 2});
  const Detection d = Detect(spec, params);
  ASSERT_FALSE(d.grasps.empty());
  for (const Grasp& g : d.grasps) EXPECT_EQ(IdAtCenter(d, g), 2);
}

TEST(DetectGraspsFge, NoGraspSqueezesTwoBoxesAcrossTheirSeam) {
  SceneSpec spec;  // together 60 mm along x: wider than the 50 mm opening; 40 mm along y
  spec.boxes = {Box{-0.015, 0.0, 0.030, 0.040, 0.040, 0.0, 1},
                Box{0.015, 0.0, 0.030, 0.040, 0.065, 0.0, 2}};
  const Detection d = Detect(spec);
  ASSERT_FALSE(d.grasps.empty());
  for (const Grasp& g : d.grasps) {
    const std::set<int> ids = TouchedIds(d, g);
    EXPECT_FALSE(ids.count(1) && ids.count(2))
        << "grasp at " << g.center_u_px << "," << g.center_v_px << " angle " << g.angle_rad
        << " height " << g.contact_height_m << " squeezes both boxes";
  }
}

TEST(DetectGraspsFge, LongBoxIsNotGraspedAlongItsLength) {
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.02, 0.100, 0.030, 0.040, 0.0, 1}};  // 100 mm along x
  const Detection d = Detect(spec);
  ASSERT_FALSE(d.grasps.empty());
  for (const Grasp& g : d.grasps) {
    EXPECT_LT(std::abs(std::cos(g.angle_rad)), std::cos(kPi / 4))
        << "closing axis at " << g.angle_rad << " rad runs along the 100 mm side";
  }
}

TEST(DetectGraspsFge, BoxWiderThanTheOpeningHasNoGrasp) {
  SceneSpec spec;
  spec.boxes = {Box{0.01, -0.02, 0.080, 0.080, 0.040, 0.2, 1}};
  EXPECT_TRUE(Detect(spec).grasps.empty());
}

TEST(DetectGraspsFge, TallNeighbourBlocksOneFinger) {
  SceneSpec spec;
  // Neighbour (id 2): 60 x 60 mm, too wide to grasp, 5 mm from the box's +x side, covering its
  // upper half (y > 0). Only the lower half of the box can be grasped across x.
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.080, 0.045, 0.0, 1},
                Box{0.050, 0.030, 0.060, 0.060, 0.070, 0.0, 2}};
  const Detection d = Detect(spec);
  ASSERT_FALSE(d.grasps.empty());
  const Grasp& best = d.grasps.front();
  EXPECT_EQ(IdAtCenter(d, best), 1);
  EXPECT_FALSE(FingersTouchId(d, best, 2));
  for (const Grasp& g : d.grasps) {
    EXPECT_LE(MaxHeightUnderFingers(d, g), g.grasp_height_m)
        << "finger collides at " << g.center_u_px << "," << g.center_v_px;
  }
}

TEST(DetectGraspsFge, PoseMatchesPixelAndHeight) {
  SceneSpec spec;
  spec.boxes = {Box{-0.03, 0.04, 0.030, 0.080, 0.040, 1.0, 1}};
  spec.table_tilt_rad = 0.1;
  const Detection d = Detect(spec);
  ASSERT_FALSE(d.grasps.empty());
  const Camera& cam = d.synth.camera;
  const Plane& floor = d.scene.floor;
  for (const Grasp& g : d.grasps) {
    const auto& p = g.p_CG_m;
    EXPECT_NEAR(cam.fx * p[0] / p[2] + cam.cx, g.center_u_px, 1e-6);
    EXPECT_NEAR(cam.fy * p[1] / p[2] + cam.cy, g.center_v_px, 1e-6);
    EXPECT_NEAR(floor.n[0] * p[0] + floor.n[1] * p[1] + floor.n[2] * p[2] + floor.d,
                g.grasp_height_m, 1e-9);
    EXPECT_NEAR(g.grasp_height_m, g.contact_height_m - FgeParams{}.grip_depth_m, 1e-12);
    const auto& q = g.q_CG_wxyz;  // (w, x, y, z)
    EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
    // x axis of G in C: first column of R(q).
    const double rx = 1 - 2 * (q[2] * q[2] + q[3] * q[3]);
    const double ry = 2 * (q[1] * q[2] + q[0] * q[3]);
    const double rz = 2 * (q[1] * q[3] - q[0] * q[2]);
    EXPECT_NEAR(rx, std::cos(g.angle_rad), 1e-12);
    EXPECT_NEAR(ry, std::sin(g.angle_rad), 1e-12);
    EXPECT_NEAR(rz, 0.0, 1e-12);
    EXPECT_GE(g.angle_rad, 0.0);
    EXPECT_LT(g.angle_rad, kPi);
    EXPECT_DOUBLE_EQ(g.opening_m, Gripper{}.opening_stroke_m);
    EXPECT_GT(g.opening_px, g.finger_width_px);
  }
}

TEST(DetectGraspsFge, Deterministic) {
  const SceneSpec spec = testing::ClutterSceneSpec();
  const Detection a = Detect(spec);
  const Detection b = Detect(spec);
  ASSERT_EQ(a.grasps.size(), b.grasps.size());
  for (std::size_t i = 0; i < a.grasps.size(); ++i) {
    EXPECT_EQ(a.grasps[i].center_u_px, b.grasps[i].center_u_px);
    EXPECT_EQ(a.grasps[i].center_v_px, b.grasps[i].center_v_px);
    EXPECT_EQ(a.grasps[i].angle_rad, b.grasps[i].angle_rad);
    EXPECT_EQ(a.grasps[i].score, b.grasps[i].score);
  }
}

TEST(DetectGraspsFge, ClutterGraspsAreCollisionFreeAndSuppressed) {
  FgeParams params;
  params.top_k = 10;
  const Detection d = Detect(testing::ClutterSceneSpec(), params);
  ASSERT_GE(d.grasps.size(), 3u);
  for (std::size_t i = 0; i < d.grasps.size(); ++i) {
    const Grasp& g = d.grasps[i];
    EXPECT_LE(MaxHeightUnderFingers(d, g), g.grasp_height_m);
    EXPECT_GE(g.grasp_height_m, params.floor_clearance_m);
    for (std::size_t j = 0; j < i; ++j) {
      const Grasp& h = d.grasps[j];
      const bool near = std::hypot(g.center_u_px - h.center_u_px, g.center_v_px - h.center_v_px) <
                        params.nms_radius_px;
      const bool similar = AngleDistance(g.angle_rad, h.angle_rad) <= kAngleStepRad + 1e-9;
      EXPECT_FALSE(near && similar) << "grasps " << j << " and " << i << " were not merged";
    }
  }
}

TEST(DetectGraspsFge, SurfacesTouchingTheImageBorderAreNeverGrasped) {
  SceneSpec spec;  // a thin wall (like a bin wall) running out of the image, and a slim box
  spec.boxes = {Box{-0.25, 0.0, 0.006, 0.80, 0.080, 0.0, 1},
                Box{0.05, 0.02, 0.030, 0.080, 0.040, 0.5, 2}};
  const Detection d = Detect(spec);
  ASSERT_FALSE(d.grasps.empty());
  for (const Grasp& g : d.grasps) {
    EXPECT_EQ(IdAtCenter(d, g), 2) << "grasp at " << g.center_u_px << "," << g.center_v_px;
    EXPECT_EQ(TouchedIds(d, g).count(1), 0u);
  }
}

// Beyond the image nothing is known: it counts as an obstacle, so no finger is placed there.
TEST(DetectGraspsFge, FingersStayInsideTheImage) {
  int grasps = 0;
  for (double gap_m : {0.006, 0.010, 0.015, 0.020}) {  // box top edge to the left image border
    SceneSpec spec;
    spec.boxes = {Box{-0.3413 + gap_m + 0.015, 0.0, 0.030, 0.080, 0.040, 0.0, 1}};
    const Detection d = Detect(spec);
    for (const Grasp& g : d.grasps) {
      ++grasps;
      const double reach_u =
          std::abs(std::cos(g.angle_rad)) * (g.opening_px / 2 + g.finger_thickness_px) +
          std::abs(std::sin(g.angle_rad)) * g.finger_width_px / 2;
      EXPECT_GE(g.center_u_px - reach_u, -0.5 - kWorkPixelPx)
          << "gap " << gap_m << ": a finger leaves the image";
    }
  }
  EXPECT_GT(grasps, 0);
}

TEST(DetectGraspsFge, LowObjectIsGraspedWithFingertipsAtTheClearance) {
  SceneSpec spec;  // 18 mm tall: the second 10 mm step would put the tips under the floor
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.080, 0.018, 0.0, 1}};
  const Detection d = Detect(spec);
  ASSERT_FALSE(d.grasps.empty());
  const FgeParams params;
  bool at_clearance = false;
  for (const Grasp& g : d.grasps) {
    EXPECT_GE(g.grasp_height_m, params.floor_clearance_m - 1e-12);
    at_clearance |= std::abs(g.grasp_height_m - params.floor_clearance_m) < 1e-9;
  }
  EXPECT_TRUE(at_clearance);
}

// GQ-CNN's segmask: only the masked object may be grasped; the others stay obstacles.
TEST(DetectGraspsFge, RegionOfInterestLimitsContactsToTheMask) {
  SceneSpec spec;  // two slim boxes; box 1 is taller, so it would win without a mask
  spec.boxes = {Box{-0.06, 0.0, 0.030, 0.080, 0.060, 0.0, 1},
                Box{0.06, 0.0, 0.030, 0.080, 0.040, 0.0, 2}};
  const Detection plain = Detect(spec);
  ASSERT_FALSE(plain.grasps.empty());
  ASSERT_EQ(IdAtCenter(plain, plain.grasps.front()), 1);

  for (int target : {1, 2}) {
    SCOPED_TRACE(target);
    Detection d = Detect(spec);
    const cv::Mat1b mask = d.synth.object_id == target;
    RestrictContact(d.scene, mask, 0.0);
    FgeParams params;
    params.top_k = 10;
    d.grasps = DetectGraspsFge(d.scene, d.synth.camera, Gripper{}, params);
    ASSERT_FALSE(d.grasps.empty());
    for (const Grasp& g : d.grasps) {
      EXPECT_EQ(IdAtCenter(d, g), target) << "grasp at " << g.center_u_px << "," << g.center_v_px;
      EXPECT_EQ(TouchedIds(d, g), std::set<int>{target});
    }
  }
  Detection empty = Detect(spec);
  RestrictContact(empty.scene, cv::Mat1b(empty.scene.height_m.size(), uchar{0}), 0.0);
  EXPECT_TRUE(DetectGraspsFge(empty.scene, empty.synth.camera, Gripper{}).empty());
}

// A wrist camera sees the gripper's own fingers near the lens: with a minimum working distance
// they are never grasped, and grasps elsewhere keep their fingers off them.
TEST(DetectGraspsFge, SurfacesNearerThanTheMinimumDepthAreObstaclesOnly) {
  // Camera 0.6 m above the table; the "finger" is 0.2 m tall (its top 0.4 m from the lens, on
  // the optical axis so that only its top is seen) and stands 20 mm from the box's -x side, so
  // grasps across x pass close to it.
  SceneSpec spec;
  spec.boxes = {Box{0.0, 0.0, 0.030, 0.040, 0.200, 0.0, 1},
                Box{0.05, 0.0, 0.030, 0.080, 0.040, 0.0, 2}};
  const Detection plain = Detect(spec);
  ASSERT_FALSE(plain.grasps.empty());
  EXPECT_EQ(IdAtCenter(plain, plain.grasps.front()), 1) << "the tall part wins without a limit";

  Detection d = Detect(spec);
  RestrictContact(d.scene, {}, 0.45);
  FgeParams params;
  params.top_k = 10;
  d.grasps = DetectGraspsFge(d.scene, d.synth.camera, Gripper{}, params);
  ASSERT_FALSE(d.grasps.empty());
  for (const Grasp& g : d.grasps) {
    EXPECT_EQ(IdAtCenter(d, g), 2) << "grasp at " << g.center_u_px << "," << g.center_v_px;
    EXPECT_FALSE(FingersTouchId(d, g, 1));
    EXPECT_LE(MaxHeightUnderFingers(d, g), g.grasp_height_m);
  }
  EXPECT_THROW(RestrictContact(d.scene, cv::Mat1b(10, 10, uchar{255}), 0.0), std::invalid_argument);
  EXPECT_THROW(RestrictContact(d.scene, {}, -1.0), std::invalid_argument);
}

// A dense bin: the highest object is too wide to grasp and everything else lies more than
// num_height_steps slices below its top. The search goes on down until it finds grasps.
TEST(DetectGraspsFge, SearchGoesBelowAnUngraspableTopUntilItFindsGrasps) {
  SceneSpec spec;
  spec.boxes = {Box{-0.08, 0.0, 0.080, 0.080, 0.150, 0.0, 1},  // 80 mm wide, 150 mm tall
                Box{0.08, 0.0, 0.030, 0.080, 0.040, 0.0, 2}};  // slim, 110 mm lower
  FgeParams params;
  params.top_k = 3;
  const Detection d = Detect(spec, params);
  ASSERT_FALSE(d.grasps.empty());
  for (const Grasp& g : d.grasps) {
    EXPECT_EQ(IdAtCenter(d, g), 2) << "grasp at " << g.center_u_px << "," << g.center_v_px;
    EXPECT_GE(g.height_step, params.num_height_steps) << "found below the first batch";
    EXPECT_LE(MaxHeightUnderFingers(d, g), g.grasp_height_m);
  }
}

// Grasps of a higher batch of slices rank first, so the first batch's answer is a prefix of
// the answer: asking for more grasps never changes the best one.
TEST(DetectGraspsFge, HigherSlicesRankFirstAndMoreGraspsKeepThePrefix) {
  SceneSpec spec;
  spec.boxes = {Box{-0.08, 0.0, 0.030, 0.080, 0.120, 0.0, 1},  // slim and tall: one grasp
                Box{0.08, 0.0, 0.030, 0.080, 0.030, 0.0, 2}};  // slim and low
  FgeParams one;
  one.top_k = 1;
  FgeParams many;
  many.top_k = 6;
  const Detection a = Detect(spec, one);
  const Detection b = Detect(spec, many);
  ASSERT_EQ(a.grasps.size(), 1u);
  ASSERT_GE(b.grasps.size(), 2u);
  EXPECT_EQ(a.grasps[0].center_u_px, b.grasps[0].center_u_px);
  EXPECT_EQ(a.grasps[0].angle_rad, b.grasps[0].angle_rad);
  EXPECT_EQ(IdAtCenter(b, b.grasps[0]), 1);
  bool low_box = false;
  for (std::size_t i = 1; i < b.grasps.size(); ++i) {
    EXPECT_GE(b.grasps[i].height_step / many.num_height_steps,
              b.grasps[i - 1].height_step / many.num_height_steps);
    low_box |= IdAtCenter(b, b.grasps[i]) == 2;
  }
  EXPECT_TRUE(low_box) << "the low box is reached once the first batch runs out";
}

// A pile that reaches a bin wall running out of the image: box 3 touches the wall only through
// the low box 2, and a free-standing box 4 elsewhere is free at the lowest level. Box 3 stands free
// of the wall above box 2, so it may be grasped; the wall and box 2 may not.
TEST(DetectGraspsFge, PileJoinedToAWallLowDownIsGraspableWhereItStandsFree) {
  SceneSpec spec;
  spec.boxes = {Box{-0.25, 0.0, 0.010, 0.80, 0.060, 0.0, 1},    // wall, out of the image
                Box{-0.215, 0.0, 0.060, 0.060, 0.015, 0.0, 2},  // low box against the wall
                Box{-0.17, 0.0, 0.030, 0.080, 0.050, 0.0, 3},   // leans on the low box
                Box{0.10, 0.05, 0.030, 0.080, 0.060, 0.0, 4}};  // free-standing
  FgeParams params;
  params.top_k = 10;
  const Detection d = Detect(spec, params);
  bool third = false;
  for (const Grasp& g : d.grasps) {
    const int id = IdAtCenter(d, g);
    EXPECT_TRUE(id == 3 || id == 4) << "grasp at " << g.center_u_px << "," << g.center_v_px;
    EXPECT_EQ(TouchedIds(d, g).count(1), 0u);
    EXPECT_LE(MaxHeightUnderFingers(d, g), g.grasp_height_m);
    third |= id == 3;
  }
  EXPECT_TRUE(third);
}

// A box pushed against a bin wall that runs out of the image is joined to the border at every
// level below its top, so no level leaves it free; its top face still meets the taller wall along
// the wall's steep side, and that face may be grasped (along the wall, fingers clear of it).
TEST(DetectGraspsFge, BoxAgainstAWallIsGraspedByItsOwnTopFace) {
  SceneSpec spec;
  spec.boxes = {Box{-0.25, 0.0, 0.006, 0.80, 0.080, 0.0, 1},    // wall, out of the image
                Box{-0.227, 0.0, 0.040, 0.030, 0.030, 0.0, 2},  // against the wall
                Box{0.10, 0.05, 0.030, 0.080, 0.050, 0.0, 3}};  // free-standing
  FgeParams params;
  params.top_k = 10;
  const Detection d = Detect(spec, params);
  bool against = false;
  for (const Grasp& g : d.grasps) {
    const int id = IdAtCenter(d, g);
    EXPECT_TRUE(id == 2 || id == 3) << "grasp at " << g.center_u_px << "," << g.center_v_px;
    EXPECT_EQ(TouchedIds(d, g).count(1), 0u);
    EXPECT_FALSE(FingersTouchId(d, g, 1));
    EXPECT_LE(MaxHeightUnderFingers(d, g), g.grasp_height_m);
    against |= id == 2;
  }
  EXPECT_TRUE(against);
}

// Structured-light and stereo sensors drop pixels along object edges; the fill bridges the
// step with runs of in-between heights, which look like a lower surface pressed against the box.
// They are no surface: no seam may come of them, and the box stays graspable.
TEST(DetectGraspsFge, FilledDropoutsAlongAnEdgeAreNoSeam) {
  SceneSpec spec;
  const Box box{0.0, 0.0, 0.030, 0.080, 0.040, 0.0, 1};
  spec.boxes = {box};
  testing::SyntheticScene synth = RenderScene(spec);
  // Missing: the table pixels within kBandPx of the box along each row (both long sides).
  constexpr int kBandPx = 8;
  const cv::Mat1b on_box = synth.object_id == box.id;
  cv::Mat1b band;
  cv::dilate(on_box, band, cv::Mat1b::ones(1, 2 * kBandPx + 1));
  band &= (synth.object_id == testing::kTableId);
  synth.depth.depth_m.setTo(std::numeric_limits<float>::quiet_NaN(), band);
  ASSERT_GT(cv::countNonZero(band), 0);

  auto scene = Preprocess(synth.depth, synth.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const Scene& s = scene.value();
  const double tip_m = box.height_m - 0.01 - FgeParams{}.grip_depth_m;  // the top slice's tips
  // Measured pixels only: no seam reaches above the fingertips. Counting the filled ones, the
  // runs of in-between heights beside the box would make seams (the failure this guards).
  const cv::Mat1f with_fill = fge_detail::SeamLevels(s.height_m, cv::Mat1b(), 0.01);
  const cv::Mat1f measured = fge_detail::SeamLevels(s.height_m, s.missing_mask, 0.01);
  EXPECT_GT(cv::countNonZero(with_fill > tip_m), 0) << "the fill made no step: the test is moot";
  EXPECT_EQ(cv::countNonZero(measured > tip_m), 0);

  const auto grasps = DetectGraspsFge(s, synth.camera, Gripper{});
  ASSERT_FALSE(grasps.empty());
  EXPECT_LE(AngleDistance(grasps.front().angle_rad, box.yaw_rad), kAngleStepRad + 1e-9);
}

TEST(DetectGraspsFge, FlatTableHasNoGrasp) { EXPECT_TRUE(Detect(SceneSpec{}).grasps.empty()); }

// The contact check (docs/fge.md) on a plateau 40 mm across between fingers 60 mm apart that
// close along u, 1 px = 1 mm, with 15 mm wide fingers.
cv::Mat1f Plateau(double slant_deg, int first_row) {
  cv::Mat1f height_m(200, 200, 0.0f);
  const double t = slant_deg * CV_PI / 180;
  for (int v = first_row; v < height_m.rows; ++v) {
    for (int u = 0; u < height_m.cols; ++u) {
      if (std::abs((u - 100) * std::cos(t) + (v - 100) * std::sin(t)) <= 20) height_m(v, u) = 0.03f;
    }
  }
  return height_m;
}

ContactHold Hold(const cv::Mat1f& height_m) {
  const GripperPx fingers{60, 15, 8};  // lines b = -7 ... 7 across the fingers
  return CheckContacts(height_m, 100, 100, 0.0, fingers, 1000.0, 0.01);
}

TEST(ContactCheck, FirmWhenEachFingerRestsOnHalfItsWidth) {
  using enum ContactHold;
  EXPECT_EQ(Hold(Plateau(0, 0)), kFirm);
  // A slanted face: of the 15 lines, those meeting it within 2 mm of the first contact are all
  // 15 at 10 deg, 6 at 25 deg (stable: >= 5 mm; the contact sits near the face's corner), 4 at
  // 35 deg.
  EXPECT_EQ(Hold(Plateau(10, 0)), kFirm);
  EXPECT_EQ(Hold(Plateau(25, 0)), kStable);
  EXPECT_EQ(Hold(Plateau(35, 0)), kNone);
  // The plateau's end under the fingers: 8 of the 15 lines reach it, then 6.
  EXPECT_EQ(Hold(Plateau(0, 100)), kFirm);
  EXPECT_EQ(Hold(Plateau(0, 102)), kStable);
  EXPECT_EQ(Hold(cv::Mat1f(200, 200, 0.0f)), kNone);
}

TEST(DetectGraspsFge, RejectsBadParameters) {
  const Detection d = Detect(SceneSpec{});
  FgeParams params;
  params.num_angles = 0;
  EXPECT_THROW(DetectGraspsFge(d.scene, d.synth.camera, Gripper{}, params), std::invalid_argument);
  Gripper gripper;
  gripper.opening_stroke_m = -1;
  EXPECT_THROW(DetectGraspsFge(d.scene, d.synth.camera, gripper, FgeParams{}),
               std::invalid_argument);
}

// --- fast maps vs the filter2D reference ---------------------------------------------------

struct MapComparison {
  double iou = 1;
  double worst_mismatch_depth_px = 0;  // how far inside a region a disagreeing pixel lies
  double ref_score_at_fast_best = 0;   // reference graspability where the fast map peaks, / max
  double fast_score_at_ref_best = 0;   // and vice versa
};

// Distance from each pixel of `mask` to the nearest pixel outside it (0 outside the mask).
cv::Mat1f DepthInside(const cv::Mat1b& mask) {
  cv::Mat1f dist;
  cv::distanceTransform(mask, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  return dist;
}

double RelativeScoreAt(const cv::Mat1f& map, cv::Point p) {
  double best = 0;
  cv::minMaxLoc(map, nullptr, &best);
  return best > 0 ? map(p) / best : 1.0;
}

// A pixel where the candidate maps disagree lies inside exactly one of the two candidate
// regions; its depth inside that region says whether it is a border effect (small) or a real
// disagreement.
MapComparison Compare(const FgeMaps& fast, const FgeMaps& ref) {
  const cv::Mat1b f = fast.graspability > 0;
  const cv::Mat1b r = ref.graspability > 0;
  MapComparison out;
  const int uni = cv::countNonZero(f | r);
  out.iou = uni == 0 ? 1.0 : static_cast<double>(cv::countNonZero(f & r)) / uni;
  const cv::Mat1f depth_f = DepthInside(f);
  const cv::Mat1f depth_r = DepthInside(r);
  for (int v = 0; v < f.rows; ++v) {
    for (int u = 0; u < f.cols; ++u) {
      if (f(v, u) == r(v, u)) continue;
      const double depth = f(v, u) ? depth_f(v, u) : depth_r(v, u);
      out.worst_mismatch_depth_px = std::max(out.worst_mismatch_depth_px, depth);
    }
  }
  cv::Point fa, ra;
  cv::minMaxLoc(fast.graspability, nullptr, nullptr, nullptr, &fa);
  cv::minMaxLoc(ref.graspability, nullptr, nullptr, nullptr, &ra);
  out.ref_score_at_fast_best = RelativeScoreAt(ref.graspability, fa);
  out.fast_score_at_ref_best = RelativeScoreAt(fast.graspability, ra);
  return out;
}

struct MapTolerances {
  double min_iou;
  double border_px;
  bool check_peaks_and_counts;
};

void ExpectMapsAgree(const Detection& d, double angle, double height, const MapTolerances& tol) {
  const FgeMaps fast =
      ComputeFgeMaps(d.scene, d.synth.camera, Gripper{}, FgeParams{}, angle, height);
  const FgeMaps ref =
      ComputeFgeMapsReference(d.scene, d.synth.camera, Gripper{}, FgeParams{}, angle, height);
  ASSERT_EQ(fast.graspability.size(), d.scene.height_m.size());
  ASSERT_EQ(ref.graspability.size(), d.scene.height_m.size());
  const MapComparison c = Compare(fast, ref);
  SCOPED_TRACE(::testing::Message() << "angle " << angle << " height " << height);
  std::printf("angle %.3f height %.3f: iou %.3f, mismatch depth %.2f px, cross scores %.3f %.3f\n",
              angle, height, c.iou, c.worst_mismatch_depth_px, c.ref_score_at_fast_best,
              c.fast_score_at_ref_best);
  EXPECT_GT(cv::countNonZero(ref.graspability > 0), 0);
  EXPECT_GE(c.iou, tol.min_iou);
  EXPECT_LE(c.worst_mismatch_depth_px, tol.border_px);
  double lo = 0, hi = 0;
  cv::minMaxLoc(fast.graspability, &lo, &hi);
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 1.0);
  if (!tol.check_peaks_and_counts) return;
  EXPECT_GE(c.ref_score_at_fast_best, kCrossScoreMin);
  EXPECT_GE(c.fast_score_at_ref_best, kCrossScoreMin);
  // About the same A_t where both have candidates (the fast path counts at half resolution).
  const cv::Mat1b both = (ref.graspability > 0) & (fast.graspability > 0);
  const double ref_contact = cv::mean(ref.contact, both)[0];
  EXPECT_NEAR(cv::mean(fast.contact, both)[0], ref_contact, kContactRelTol * ref_contact);
}

// One slim box: its candidate regions are wide, so the IoU measures rasterisation only.
TEST(FastVsReference, SingleBoxMapsAgree) {
  SceneSpec spec;
  spec.boxes = {Box{0.02, -0.01, 0.030, 0.080, 0.040, 0.3, 1}};
  const Detection d = Detect(spec);
  for (double angle : {0.3 - kAngleStepRad, 0.3, 0.3 + kAngleStepRad}) {
    for (double height : {0.035, 0.02}) {
      ExpectMapsAgree(d, angle, height, {kMapIouMin, kMapBorderPx, true});
    }
  }
}

// Several boxes and arbitrary angles: thin slivers (closing regions that just reach a corner)
// make the IoU meaningless, but disagreements must stay at region borders.
class FastVsReference : public ::testing::TestWithParam<double> {};

TEST_P(FastVsReference, ClutterMapsAgreeUpToBorders) {
  SceneSpec spec;
  spec.boxes = {Box{0.02, -0.01, 0.030, 0.080, 0.040, 0.3, 1},
                Box{-0.12, 0.05, 0.035, 0.060, 0.050, 1.1, 2},
                Box{0.12, 0.08, 0.080, 0.080, 0.045, 0.0, 3}};
  const Detection d = Detect(spec);
  for (double height : {0.03, 0.02}) {
    ExpectMapsAgree(d, GetParam(), height, {kClutterIouMin, kClutterBorderPx, false});
  }
}

INSTANTIATE_TEST_SUITE_P(Angles, FastVsReference,
                         ::testing::Values(0.0, 0.3, kPi / 4, 1.1, kPi / 2, 2.5));

}  // namespace
}  // namespace softgrasp::core
