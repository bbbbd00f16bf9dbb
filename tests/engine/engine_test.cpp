// The planning engine on analytic scenes: the strategy registry, what each option computes,
// given maps and labels, targets, contact regions, and the errors callers can cause.
#include "service/engine/engine.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <set>
#include <string>

#include "service/core/fge.h"
#include "service/core/fge_stiffness.h"
#include "tests/support/synthetic_scene.h"

namespace softgrasp::engine {
namespace {

using testing::Box;
using testing::RenderScene;
using testing::SceneSpec;

// Two 30 x 80 x 40 mm boxes 160 mm apart: ids 1 (left) and 2 (right).
struct TwoBoxes {
  SceneSpec spec;
  testing::SyntheticScene synth;
  cv::Mat1w labels;  ///< the boxes' ids, 0 on the table
};

const TwoBoxes& Scene() {
  static const TwoBoxes s = [] {
    TwoBoxes t;
    t.spec.boxes = {Box{-0.08, 0.0, 0.03, 0.08, 0.04, 0.0, 1},
                    Box{0.08, 0.0, 0.03, 0.08, 0.04, 0.0, 2}};
    t.synth = RenderScene(t.spec);
    t.labels = cv::Mat1w(t.synth.object_id.size(), 0);
    for (int v = 0; v < t.labels.rows; ++v) {
      for (int u = 0; u < t.labels.cols; ++u) {
        const int id = t.synth.object_id(v, u);
        if (id > 0) t.labels(v, u) = static_cast<std::uint16_t>(id);
      }
    }
    return t;
  }();
  return s;
}

int BoxAt(const core::Grasp& g) {
  return Scene().synth.object_id(static_cast<int>(std::lround(g.center_v_px)),
                                 static_cast<int>(std::lround(g.center_u_px)));
}

// A stiffness map: `left` on box 1, `right` on box 2, 0 on the table.
cv::Mat1f MapOf(float left, float right) {
  cv::Mat1f map(Scene().labels.size(), 0.0f);
  map.setTo(left, Scene().labels == 1);
  map.setTo(right, Scene().labels == 2);
  return map;
}

// An image the preprocessing cannot use: no pixel measured.
struct NoMeasurements {
  core::DepthImage depth{cv::Mat1f(48, 64, std::nanf(""))};
  core::Camera camera{525.0, 525.0, 31.5, 23.5, 64, 48};
};

Plan MustPlan(const PlanOptions& options, const Models& models = {}) {
  auto plan = PlanGrasps(Scene().synth.depth, Scene().synth.camera, options, models);
  EXPECT_TRUE(plan.ok()) << plan.error().message;
  return plan.ok() ? std::move(plan).value() : Plan{};
}

std::shared_ptr<const models::StiffnessModel> ShippedStiffness() {
  static const auto model = [] {
    auto loaded = models::StiffnessModel::Load(std::string(SOFTGRASP_SOURCE_DIR) +
                                               "/models/pix2stiffness.pt");
    if (!loaded.ok()) throw std::runtime_error(loaded.error().message);
    return std::make_shared<const models::StiffnessModel>(std::move(loaded).value());
  }();
  return model;
}

TEST(Strategies, AreRegisteredOnceByNameInOrderOfPreference) {
  std::set<std::string> names;
  for (const Strategy* s : Strategies()) {
    EXPECT_TRUE(names.insert(s->info().name).second) << s->info().name;
    EXPECT_EQ(FindStrategy(s->info().name), s);
  }
  EXPECT_EQ(FindStrategy("dexnet"), nullptr);
  EXPECT_EQ(FindStrategy(""), nullptr);
  const auto unknown = StrategyNamed("dexnet");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().field, "strategy");
  EXPECT_NE(unknown.error().message.find("'fge', 'gqcnn', 'stiffness' or 'deformability'"),
            std::string::npos)
      << unknown.error().message;
  EXPECT_STREQ(Strategies().front()->info().name, "fge");  // needs no model: always served
}

// Each room's field table: unique names across strategies, defaults inside their ranges, and a
// value written through a field reads back the same.
TEST(Strategies, FieldTablesHoldTheirDefaultsAndRoundTripValues) {
  std::set<std::string> names;
  for (const Strategy* s : Strategies()) {
    SCOPED_TRACE(s->info().name);
    const auto defaults = s->DefaultOptions();
    if (!s->fields().empty()) {
      ASSERT_NE(defaults, nullptr) << "fields without options";
    }
    for (const StrategyField& f : s->fields()) {
      SCOPED_TRACE(f.name);
      EXPECT_TRUE(names.insert(f.name).second) << "two strategies name a field alike";
      EXPECT_FALSE(f.doc.empty());
      const FieldValue value = f.get(*defaults);
      if (f.kind == StrategyField::Kind::kChoice) {
        EXPECT_LT(std::get<double>(value), static_cast<double>(f.choices.size()));
        auto changed = s->DefaultOptions();
        f.set(*changed, FieldValue(static_cast<double>(f.choices.size() - 1)));
        EXPECT_EQ(std::get<double>(f.get(*changed)), f.choices.size() - 1.0);
      } else if (f.kind == StrategyField::Kind::kNumberList) {
        for (double v : std::get<std::vector<double>>(value)) {
          EXPECT_GE(v, f.min);
          EXPECT_LE(v, f.max);
        }
      } else {
        EXPECT_GE(std::get<double>(value), f.min);
        EXPECT_LE(std::get<double>(value), f.max);
        auto changed = s->DefaultOptions();
        f.set(*changed, FieldValue(f.max));
        EXPECT_DOUBLE_EQ(std::get<double>(f.get(*changed)), f.max);
      }
    }
    EXPECT_FALSE(s->Validate(defaults.get(), PlanOptions{}, Scene().synth.camera).has_value());
  }
}

TEST(Strategies, TheDefaultIsTheLastOneTheLoadedModelsServe) {
  EXPECT_STREQ(DefaultStrategy({}).info().name, "fge");
  EXPECT_EQ(ServedStrategies({}), std::vector<std::string>{"fge"});
  const Models stiffness{ShippedStiffness(), nullptr, nullptr};
  EXPECT_STREQ(DefaultStrategy(stiffness).info().name, "stiffness");
  EXPECT_TRUE(Serves(stiffness, *FindStrategy("stiffness")));
  EXPECT_FALSE(Serves(stiffness, *FindStrategy("deformability")));
  PlanOptions unserved;
  unserved.strategy = "deformability";
  const auto why = PlanGrasps(Scene().synth.depth, Scene().synth.camera, unserved, stiffness);
  ASSERT_FALSE(why.ok());
  EXPECT_EQ(why.error().code, core::ErrorCode::kInvalidArgument);
  EXPECT_EQ(why.error().field, "strategy");
  EXPECT_NE(why.error().message.find("segmentation model"), std::string::npos)
      << why.error().message;
  EXPECT_NE(why.error().message.find("'fge' or 'stiffness'"), std::string::npos)
      << why.error().message;
}

TEST(PlanGrasps, FgeIsTheCorePlannerOnThePreprocessedScene) {
  const Plan plan = MustPlan({});
  auto scene = core::Preprocess(Scene().synth.depth, Scene().synth.camera);
  ASSERT_TRUE(scene.ok());
  const auto expected = core::DetectGraspsFge(scene.value(), Scene().synth.camera, {});
  ASSERT_FALSE(expected.empty());
  ASSERT_EQ(plan.grasps.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(plan.grasps[i].grasp.center_u_px, expected[i].center_u_px);
    EXPECT_EQ(plan.grasps[i].grasp.angle_rad, expected[i].angle_rad);
    EXPECT_EQ(plan.grasps[i].grasp.score, expected[i].score);
    EXPECT_TRUE(std::isnan(plan.grasps[i].grasp.mean_stiffness));
    EXPECT_FALSE(plan.grasps[i].instance_id.has_value());
    EXPECT_EQ(plan.grasps[i].details, nullptr);
  }
  EXPECT_EQ(plan.scene.floor.d, scene.value().floor.d);
  EXPECT_TRUE(plan.stiffness.empty());
  EXPECT_FALSE(plan.instances.has_value());
  EXPECT_EQ(plan.details, nullptr);
  EXPECT_EQ(plan.chosen_target_id, 0);
  EXPECT_FALSE(plan.timing.stiffness_ran);
  EXPECT_GT(plan.timing.detect_ms, 0.0);
  EXPECT_GE(plan.timing.total_ms, plan.timing.preprocess_ms + plan.timing.detect_ms);
}

TEST(PlanGrasps, AGivenStiffnessMapStandsInForTheModel) {
  PlanOptions options;
  options.strategy = "stiffness";
  options.stiffness_map = MapOf(0.2f, 0.9f);
  const Plan plan = MustPlan(options);  // no model loaded
  ASSERT_FALSE(plan.grasps.empty());
  EXPECT_EQ(BoxAt(plan.grasps.front().grasp), 2);
  EXPECT_NEAR(plan.grasps.front().grasp.mean_stiffness, 0.9, 1e-5);
  EXPECT_FALSE(plan.timing.stiffness_ran);
  // The other way round, the other box.
  options.stiffness_map = MapOf(0.9f, 0.2f);
  EXPECT_EQ(BoxAt(MustPlan(options).grasps.front().grasp), 1);
  // FGE reports the given map's mean over each contact surface on request.
  PlanOptions fge;
  fge.stiffness_map = MapOf(0.2f, 0.9f);
  fge.mean_stiffness = true;
  for (const PlannedGrasp& g : MustPlan(fge).grasps) {
    EXPECT_NEAR(g.grasp.mean_stiffness, BoxAt(g.grasp) == 2 ? 0.9 : 0.2, 1e-5);
  }
}

TEST(PlanGrasps, ContactsStayInTheRegionOfInterestAndBeyondTheMinimumDepth) {
  PlanOptions options;
  options.region_of_interest = cv::Mat1b(Scene().labels.size(), 0);
  options.region_of_interest.setTo(255, Scene().labels == 1);
  Plan plan = MustPlan(options);
  ASSERT_FALSE(plan.grasps.empty());
  for (const PlannedGrasp& g : plan.grasps) EXPECT_EQ(BoxAt(g.grasp), 1);
  // Box tops are 0.56 m from the camera: a working distance beyond them leaves no contact.
  PlanOptions near;
  near.min_depth_m = 0.58;
  EXPECT_TRUE(MustPlan(near).grasps.empty());
  near.min_depth_m = 0.5;
  EXPECT_FALSE(MustPlan(near).grasps.empty());
}

TEST(PlanGrasps, GivenLabelsNameTheTargetByIdOrByPixel) {
  PlanOptions options;
  options.instances.labels = Scene().labels;
  options.target_id = 2;
  Plan plan = MustPlan(options);
  ASSERT_FALSE(plan.grasps.empty());
  ASSERT_TRUE(plan.instances.has_value());
  EXPECT_STREQ(plan.instances->source, "labels");
  EXPECT_EQ(plan.instances->count, 2);
  for (const PlannedGrasp& g : plan.grasps) {
    EXPECT_EQ(BoxAt(g.grasp), 2);
    EXPECT_EQ(g.instance_id, 2);
    EXPECT_FALSE(g.instance_deformability.has_value());  // no segmentation model ran
  }
  // A click on box 1.
  options.target_id = 0;
  const cv::Point2d left = testing::ProjectTablePoint(Scene().spec, -0.08, 0.0, 0.04);
  options.target_px = cv::Point(static_cast<int>(left.x), static_cast<int>(left.y));
  plan = MustPlan(options);
  ASSERT_FALSE(plan.grasps.empty());
  EXPECT_FALSE(plan.target_not_found);
  EXPECT_EQ(plan.target_id, Scene().labels(options.target_px->y, options.target_px->x));
  EXPECT_GT(plan.target_id, 0);
  for (const PlannedGrasp& g : plan.grasps) EXPECT_EQ(BoxAt(g.grasp), 1);
  // A click on the table: no target, no grasps.
  options.target_px = cv::Point(5, 5);
  plan = MustPlan(options);
  EXPECT_TRUE(plan.target_not_found);
  EXPECT_EQ(plan.target_id, 0);
  EXPECT_TRUE(plan.grasps.empty());
}

TEST(PlanGrasps, MapsWithoutAPlan) {
  PlanOptions options;
  options.plan = false;
  options.stiffness_map = MapOf(0.2f, 0.9f);
  options.want_stiffness_map = true;
  const Plan plan = MustPlan(options);
  EXPECT_TRUE(plan.grasps.empty());
  EXPECT_EQ(plan.timing.detect_ms, 0.0);
  EXPECT_EQ(cv::norm(plan.stiffness, MapOf(0.2f, 0.9f), cv::NORM_INF), 0.0);
}

TEST(PlanGrasps, RefusesWhatTheCallerGotWrong) {
  const auto error = [](const PlanOptions& options, const Models& models = {}) {
    auto plan = PlanGrasps(Scene().synth.depth, Scene().synth.camera, options, models);
    EXPECT_FALSE(plan.ok());
    return plan.ok() ? core::Error{} : plan.error();
  };
  PlanOptions o;
  o.strategy = "stiffness";  // no model, no map
  EXPECT_EQ(error(o).field, "strategy");
  o.strategy = "deformability";
  EXPECT_EQ(error(o).field, "strategy");
  o.strategy = "gqcnn";
  EXPECT_EQ(error(o).field, "strategy");
  EXPECT_NE(error(o).message.find("GQ-CNN model"), std::string::npos) << error(o).message;
  EXPECT_NE(error(o).message.find("--gqcnn-model"), std::string::npos) << error(o).message;
  o = {};
  o.mean_stiffness = true;
  EXPECT_EQ(error(o).field, "mean_stiffness");
  o = {};
  o.region_of_interest = cv::Mat1b(10, 10, 255);
  EXPECT_EQ(error(o).code, core::ErrorCode::kUnprocessable);
  EXPECT_EQ(error(o).field, "segmask");
  o = {};
  o.stiffness_map = cv::Mat1f(10, 10, 0.5f);
  o.strategy = "stiffness";
  EXPECT_EQ(error(o).field, "stiffness_map");
  o = {};
  o.min_depth_m = -1;
  EXPECT_EQ(error(o).field, "min_depth_m");
  o = {};
  o.instances.labels = Scene().labels;
  o.target_id = 7;
  EXPECT_EQ(error(o).code, core::ErrorCode::kUnprocessable);
  EXPECT_EQ(error(o).field, "target");
  o = {};
  o.fge.num_angles = 0;  // the planner refuses it
  EXPECT_EQ(error(o).code, core::ErrorCode::kInvalidArgument);
  const NoMeasurements empty;
  auto plan = PlanGrasps(empty.depth, empty.camera, {}, {});
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, core::ErrorCode::kUnprocessable);
}

// Without a model the PCL baseline segments; each box is one instance, described with its size
// and height, and the stiffness model's mean when one is loaded.
TEST(Segment, FindsEachBoxAndDescribesIt) {
  SegmentOptions options;
  options.describe = true;
  auto found = Segment(Scene().synth.depth, Scene().synth.camera, options, {});
  ASSERT_TRUE(found.ok()) << found.error().message;
  const Segmentation& s = found.value();
  EXPECT_EQ(s.instances.method, segmentation::Method::kPcl);
  ASSERT_EQ(s.instances.masks.count(), 2);
  ASSERT_EQ(s.described.size(), 2u);
  std::set<int> boxes;
  for (const segmentation::InstanceInfo& info : s.described) {
    // Most of an instance's pixels lie on one box; the box's top is 40 mm above the table.
    const int box = Scene().synth.object_id(static_cast<int>(std::lround(info.centroid_px[1])),
                                            static_cast<int>(std::lround(info.centroid_px[0])));
    boxes.insert(box);
    EXPECT_NEAR(info.top_height_m, 0.04, 0.004);
    EXPECT_FALSE(info.mean_stiffness.has_value());
  }
  EXPECT_EQ(boxes, (std::set<int>{1, 2}));
  EXPECT_EQ(s.timing.stiffness_ms, 0.0);

  // Not described unless asked; the stiffness model runs only to describe.
  options.describe = false;
  auto bare = Segment(Scene().synth.depth, Scene().synth.camera, options,
                      {ShippedStiffness(), nullptr, nullptr});
  ASSERT_TRUE(bare.ok());
  EXPECT_TRUE(bare.value().described.empty());
  EXPECT_EQ(bare.value().timing.stiffness_ms, 0.0);
  options.describe = true;
  auto with_stiffness = Segment(Scene().synth.depth, Scene().synth.camera, options,
                                {ShippedStiffness(), nullptr, nullptr});
  ASSERT_TRUE(with_stiffness.ok());
  for (const auto& info : with_stiffness.value().described) {
    ASSERT_TRUE(info.mean_stiffness.has_value());
    EXPECT_GE(*info.mean_stiffness, 0.0);
    EXPECT_LE(*info.mean_stiffness, 1.0);
  }
  EXPECT_GT(with_stiffness.value().timing.stiffness_ms, 0.0);
}

TEST(Segment, RefusesTheModelWhenNoneIsLoadedAndAnUnusableImage) {
  SegmentOptions options;
  options.method = segmentation::Method::kModel;
  auto refused = Segment(Scene().synth.depth, Scene().synth.camera, options, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, core::ErrorCode::kUnavailable);
  EXPECT_EQ(refused.error().field, "method");

  const NoMeasurements empty;
  auto unusable = Segment(empty.depth, empty.camera, {}, {});
  ASSERT_FALSE(unusable.ok());
  EXPECT_EQ(unusable.error().code, core::ErrorCode::kUnprocessable);
}

}  // namespace
}  // namespace softgrasp::engine
