// The one contact-region policy (engine/contact_region.h): on an analytic scene with a robot
// finger reaching in from the image border, and with every registered strategy on the real
// Primesense wrist-camera frames, whose own gripper fingers stand in the view, with no hint.
#include "service/engine/contact_region.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>

#include "service/core/preprocess.h"
#include "service/engine/engine.h"
#include "tests/support/grasp_footprint.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_data.h"

namespace softgrasp::engine {
namespace {

// A free box in the middle of the table and a tall bar that enters the view from the bottom
// border, as a wrist camera sees its own finger.
struct FingerScene {
  testing::SyntheticScene synth;
  core::Scene scene;
};

const FingerScene& Finger() {
  static const FingerScene s = [] {
    testing::SceneSpec spec;
    spec.boxes.push_back({0.0, -0.02, 0.03, 0.06, 0.04, 0.0, 1});
    // 0.6 m camera: the image's bottom row sees y ~ 0.27 m at the table; the bar runs past it.
    spec.boxes.push_back({0.0, 0.24, 0.03, 0.12, 0.15, 0.0, 2});
    FingerScene out{testing::RenderScene(spec), {}};
    auto scene = core::Preprocess(out.synth.depth, out.synth.camera);
    if (!scene.ok()) throw std::runtime_error(scene.error().message);
    out.scene = std::move(scene).value();
    return out;
  }();
  return s;
}

// The bar touches the border, the box does not.
TEST(FingerScene, IsWhatTheTestsAssume) {
  const cv::Mat1i& id = Finger().synth.object_id;
  EXPECT_GT(cv::countNonZero(id.row(id.rows - 1) == 2), 10);
  EXPECT_EQ(cv::countNonZero(id.row(id.rows - 1) == 1), 0);
  EXPECT_GT(cv::countNonZero(id == 1), 1000);
}

TEST(ApplyContactRegion, KeepsTheFingerOutWithoutAHint) {
  core::Scene scene = Finger().scene;
  const cv::Mat1b region =
      ApplyContactRegion(&scene, Finger().synth.camera, core::Gripper{}, core::FgeParams{}, {});
  ASSERT_FALSE(region.empty());
  const cv::Mat1i& id = Finger().synth.object_id;
  EXPECT_EQ(cv::countNonZero(region & (id == 2)), 0) << "contact on the finger";
  // The box's top face (its footprint shrunk by its sides' slope) stays in the region.
  const int box = cv::countNonZero(id == 1);
  EXPECT_GT(cv::countNonZero(region & (id == 1)), box / 2);
}

TEST(ApplyContactRegion, NarrowsToTheSegmaskAndTheTarget) {
  core::Scene scene = Finger().scene;
  const cv::Mat1b none(scene.height_m.size(), static_cast<std::uint8_t>(0));
  const cv::Mat1b region = ApplyContactRegion(&scene, Finger().synth.camera, core::Gripper{},
                                              core::FgeParams{}, {none, 0.0, {}});
  EXPECT_EQ(cv::countNonZero(scene.contact_allowed), 0);
  EXPECT_EQ(cv::countNonZero(region), 0);
  core::Scene targeted = Finger().scene;
  const cv::Mat1b table = Finger().synth.object_id == 0;
  const cv::Mat1b on_table = ApplyContactRegion(&targeted, Finger().synth.camera, core::Gripper{},
                                                core::FgeParams{}, {{}, 0.0, table});
  EXPECT_EQ(cv::countNonZero(targeted.contact_allowed & (Finger().synth.object_id == 1)), 0);
  EXPECT_EQ(cv::countNonZero(on_table & (Finger().synth.object_id == 1)), 0);
}

// A grasp across a 3 cm wide box whose top face is centred at (x_m, y_m, top_m) on the table,
// closing along +u, the fingertips 2 cm below the top.
core::Grasp AcrossBox(double x_m, double y_m, double top_m) {
  testing::SceneSpec spec;
  const cv::Point2d centre = testing::ProjectTablePoint(spec, x_m, y_m, top_m);
  const cv::Point2d side = testing::ProjectTablePoint(spec, x_m + 0.025, y_m, top_m);
  core::Grasp g;
  g.center_u_px = centre.x;
  g.center_v_px = centre.y;
  g.angle_rad = 0;  // along +u, across the box's 3 cm
  g.opening_px = 2 * (side.x - centre.x);
  g.finger_width_px = 10;
  g.finger_thickness_px = 5;
  g.grasp_height_m = top_m - 0.02;
  g.contact_height_m = top_m - 0.005;
  return g;
}

TEST(ClosesInRegion, AdmitsTheBoxAndRefusesTheFinger) {
  core::Scene scene = Finger().scene;
  const cv::Mat1b region =
      ApplyContactRegion(&scene, Finger().synth.camera, core::Gripper{}, core::FgeParams{}, {});
  EXPECT_TRUE(ClosesInRegion(scene, region, AcrossBox(0.0, -0.02, 0.04)));
  EXPECT_FALSE(ClosesInRegion(scene, region, AcrossBox(0.0, 0.22, 0.15)));
  // Without a region every grasp is admitted.
  EXPECT_TRUE(ClosesInRegion(scene, cv::Mat1b(), AcrossBox(0.0, 0.22, 0.15)));
}

TEST(PlanGrasps, FgeNeverClosesOnTheFingerOfTheAnalyticScene) {
  PlanOptions options;
  options.fge.top_k = 10;
  auto plan = PlanGrasps(Finger().synth.depth, Finger().synth.camera, options, {});
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ASSERT_FALSE(plan.value().grasps.empty());
  for (const PlannedGrasp& g : plan.value().grasps) {
    const int u = static_cast<int>(std::lround(g.grasp.center_u_px));
    const int v = static_cast<int>(std::lround(g.grasp.center_v_px));
    EXPECT_EQ(Finger().synth.object_id(v, u), 1) << "grasp at " << u << "," << v;
  }
}

// The shipped models, loaded once.
Models ShippedModels() {
  static const Models models = [] {
    const std::string dir = std::string(SOFTGRASP_SOURCE_DIR) + "/models/";
    auto stiffness = models::StiffnessModel::Load(dir + "pix2stiffness.pt");
    auto segmentation = models::SegmentationModel::Load(dir + "segmentation.pt");
    auto gqcnn = models::GqcnnModel::Load(dir + "gqcnn.pt");
    if (!stiffness.ok() || !segmentation.ok() || !gqcnn.ok()) {
      throw std::runtime_error("a shipped model cannot be loaded");
    }
    return Models{
        std::make_shared<const models::StiffnessModel>(std::move(stiffness).value()),
        std::make_shared<const models::SegmentationModel>(std::move(segmentation).value()),
        std::make_shared<const models::GqcnnModel>(std::move(gqcnn).value())};
  }();
  return models;
}

class PrimesenseWithoutHint : public ::testing::TestWithParam<int> {};

// The wrist camera's fingers, found as the tests of core::RestrictContact show they are: what
// the 0.6 m cut and the fill from it exclude (none of the object).
cv::Mat1b FingersOf(const core::DepthImage& depth, const core::Camera& camera) {
  auto scene = core::Preprocess(depth, camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  core::RestrictContact(scene.value(), {}, 0.6);
  return scene.value().contact_allowed == 0;
}

TEST_P(PrimesenseWithoutHint, NoStrategyClosesOnTheGrippersOwnFingers) {
  const int i = GetParam();
  const std::string stem = testing::TestData("gqcnn/primesense/single_");
  const core::DepthImage depth{
      testing::LoadNpyFloat32(stem + "depth_" + std::to_string(i) + ".npy")};
  const core::Camera camera{525.0, 525.0, 319.5, 239.5, 640, 480};
  const cv::Mat1b object =
      cv::imread(stem + "segmask_" + std::to_string(i) + ".png", cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(object.size(), depth.depth_m.size());
  const cv::Mat1b fingers = FingersOf(depth, camera);
  ASSERT_GT(cv::countNonZero(fingers), 20000);
  for (const Strategy* strategy : Strategies()) {
    SCOPED_TRACE(strategy->info().name);
    PlanOptions options;
    options.strategy = strategy->info().name;
    options.min_depth_m = 0;  // no hint
    auto plan = PlanGrasps(depth, camera, options, ShippedModels());
    ASSERT_TRUE(plan.ok()) << plan.error().message;
    const auto& grasps = plan.value().grasps;
    ASSERT_FALSE(grasps.empty());
    const int u0 = static_cast<int>(std::lround(grasps.front().grasp.center_u_px));
    const int v0 = static_cast<int>(std::lround(grasps.front().grasp.center_v_px));
    EXPECT_GT(object(v0, u0), 0) << "best grasp at " << u0 << "," << v0 << " is off the object";
    for (std::size_t k = 0; k < grasps.size(); ++k) {
      const core::Grasp& g = grasps[k].grasp;
      // Surfaces between the fingers, above the fingertips: what they would squeeze.
      const auto fp = testing::RasteriseGrasp(g, depth.depth_m.size());
      const cv::Mat1b squeezed =
          fp.closing & (plan.value().scene.height_m > static_cast<float>(g.grasp_height_m));
      EXPECT_EQ(cv::countNonZero(squeezed & fingers), 0)
          << "grasp " << k + 1 << " at " << g.center_u_px << "," << g.center_v_px
          << " closes on a finger";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Frames, PrimesenseWithoutHint, ::testing::Values(0, 1, 2));

// The PhoXi heap in a bin: every strategy's best grasp stands on something (its centre's surface
// at least 1 cm above the bin's floor), not on the floor. (The frame's segmask leaves out parts
// of the objects, e.g. the far end of the large box, where strategy=deformability's best grasp
// lies, so it is not the yardstick here.)
TEST(PhoxiHeap, EveryStrategysBestGraspIsOnAnObject) {
  const core::DepthImage depth{
      testing::LoadNpyFloat32(testing::TestData("gqcnn/phoxi/clutter_depth_0.npy"))};
  const core::Camera camera{552.5, 552.5, 255.5, 191.75, 516, 386};
  for (const Strategy* strategy : Strategies()) {
    SCOPED_TRACE(strategy->info().name);
    PlanOptions options;
    options.strategy = strategy->info().name;
    auto plan = PlanGrasps(depth, camera, options, ShippedModels());
    ASSERT_TRUE(plan.ok()) << plan.error().message;
    ASSERT_FALSE(plan.value().grasps.empty());
    const core::Grasp& best = plan.value().grasps.front().grasp;
    const int u = static_cast<int>(std::lround(best.center_u_px));
    const int v = static_cast<int>(std::lround(best.center_v_px));
    EXPECT_GT(plan.value().scene.height_m(v, u), 0.01f) << "best grasp at " << u << "," << v;
  }
}

}  // namespace
}  // namespace softgrasp::engine
