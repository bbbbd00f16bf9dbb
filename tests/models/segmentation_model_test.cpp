// The segmentation model's pieces: targets and grouping on hand-made label images (exact
// expectations), and the training pipeline on a tiny simulated dataset (checkpoints, resume,
// inference sizes, clear errors for bad model files).

#include "service/models/segmentation_model.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "service/core/preprocess.h"
#include "service/models/network.h"
#include "service/models/segmentation_grouping.h"
#include "service/models/segmentation_network.h"
#include "service/models/stiffness_model.h"
#include "sim/dataset/dataset.h"
#include "tests/support/temp_dir.h"
#include "train/dataset.h"
#include "train/segmentation_trainer.h"

namespace softgrasp::models {
namespace {

namespace fs = std::filesystem;

cv::Mat1w TwoRectangles() {
  cv::Mat1w labels(40, 60, std::uint16_t{0});
  labels(cv::Rect(5, 5, 10, 20)) = 3;    // centroid (9.5, 14.5)
  labels(cv::Rect(30, 10, 20, 10)) = 8;  // centroid (39.5, 14.5)
  return labels;
}

TEST(SegmentationTargets, CentresAndOffsetsPointAtTheCentroids) {
  const SegmentationTargets t = MakeSegmentationTargets(TwoRectangles(), 3.0);
  EXPECT_EQ(cv::countNonZero(t.foreground), 200 + 200);
  // The heatmap is exp(-d^2 / 18) around (9.5, 14.5): 0.5 px away from the nearest pixels.
  EXPECT_NEAR(t.centre(14, 9), std::exp(-0.5 / 18.0), 1e-5);
  EXPECT_NEAR(t.centre(14, 39), std::exp(-0.5 / 18.0), 1e-5);
  EXPECT_FLOAT_EQ(t.centre(35, 25), 0.0f);
  // Pixel (u=5, v=5) -> centroid (9.5, 14.5).
  EXPECT_NEAR(t.offset_u(5, 5) * kOffsetScalePx, 4.5, 1e-5);
  EXPECT_NEAR(t.offset_v(5, 5) * kOffsetScalePx, 9.5, 1e-5);
  EXPECT_FLOAT_EQ(t.offset_u(0, 0), 0.0f);  // background
}

TEST(GroupInstances, PerfectHeadsGiveTheLabelsBackAtTwiceTheSize) {
  const cv::Mat1w labels = TwoRectangles();
  const SegmentationTargets t = MakeSegmentationTargets(labels, 3.0);
  HeadMaps heads{t.foreground, t.centre, t.offset_u * kOffsetScalePx, t.offset_v * kOffsetScalePx};
  cv::Mat1f fg;
  const segmentation::InstanceMasks m = GroupInstances(heads, cv::Size(120, 80), {}, &fg);
  ASSERT_EQ(m.count(), 2);
  EXPECT_EQ(fg.size(), cv::Size(120, 80));
  cv::Mat1w expected;
  cv::resize(labels, expected, cv::Size(120, 80), 0, 0, cv::INTER_NEAREST);
  for (std::uint16_t old_id : {3, 8}) {
    const cv::Mat1b truth = expected == old_id;
    // The predicted id covering the truth's centre pixel, then the IoU of the two masks.
    cv::Moments mo = cv::moments(truth, true);
    const int u = static_cast<int>(mo.m10 / mo.m00), v = static_cast<int>(mo.m01 / mo.m00);
    const std::uint16_t id = m.labels(v, u);
    ASSERT_GT(id, 0);
    const cv::Mat1b pred = m.labels == id;
    const double iou =
        static_cast<double>(cv::countNonZero(pred & truth)) / cv::countNonZero(pred | truth);
    EXPECT_GT(iou, 0.9) << "instance " << old_id;  // bilinear edges cost a pixel ring
    EXPECT_GT(m.scores[id - 1u], 0.9f);
  }
}

// A foreground blob far from every centre (a real frame's image corner) whose pixels vote for
// themselves is not glued to the nearest object; without the limit it is.
TEST(GroupInstances, VotesFarFromEveryCentreJoinNothing) {
  cv::Mat1w labels(60, 100, std::uint16_t{0});
  labels(cv::Rect(10, 10, 20, 20)).setTo(1);
  const SegmentationTargets t = MakeSegmentationTargets(labels, 3.0);
  HeadMaps heads{t.foreground.clone(), t.centre, t.offset_u * kOffsetScalePx,
                 t.offset_v * kOffsetScalePx};
  const cv::Rect blob(80, 40, 10, 10);  // 64 model px from the object's centre
  heads.foreground(blob).setTo(1.0f);
  GroupingParams p;
  p.max_border_px = 0;
  p.min_area_px = 1;
  ASSERT_EQ(p.max_vote_distance_px, GroupingParams{}.max_vote_distance_px);
  ASSERT_GT(p.max_vote_distance_px, 0.0f);
  const segmentation::InstanceMasks capped = GroupInstances(heads, labels.size(), p);
  ASSERT_EQ(capped.count(), 1);
  EXPECT_EQ(cv::countNonZero(capped.labels(blob)), 0);
  EXPECT_EQ(cv::countNonZero(capped.labels == 1), 400);
  p.max_vote_distance_px = 0;  // plain Panoptic-DeepLab: every foreground pixel joins a centre
  const segmentation::InstanceMasks glued = GroupInstances(heads, labels.size(), p);
  ASSERT_EQ(glued.count(), 1);
  EXPECT_EQ(cv::countNonZero(glued.labels(blob)), 100);
}

TEST(GroupInstances, NoPeakMeansNoInstance) {
  HeadMaps heads{cv::Mat1f(20, 20, 1.0f), cv::Mat1f(20, 20, 0.05f), cv::Mat1f(20, 20, 0.0f),
                 cv::Mat1f(20, 20, 0.0f)};
  EXPECT_EQ(GroupInstances(heads, cv::Size(40, 40)).count(), 0);
  EXPECT_THROW(GroupInstances(heads, cv::Size(0, 40)), std::invalid_argument);
  heads.centre = cv::Mat1f(10, 10, 0.0f);
  EXPECT_THROW(GroupInstances(heads, cv::Size(40, 40)), std::invalid_argument);
}

class SegmentationPipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SetTorchThreads(1);
    root_ = new softgrasp::testing::TempDir("segmentation-test");
    sim::DatasetParams params;
    params.scenes = 3;
    params.seed = 5;
    params.out_dir = *root_ / "data";
    params.spec.min_objects = 2;
    params.spec.max_objects = 3;
    core::Camera& cam = params.spec.render.camera;  // 160 x 120 renders: fast
    cam.fx /= 4;
    cam.fy /= 4;
    cam.cx = (cam.cx + 0.5) / 4 - 0.5;
    cam.cy = (cam.cy + 0.5) / 4 - 0.5;
    cam.width /= 4;
    cam.height /= 4;
    auto index = sim::GenerateDataset(params);
    ASSERT_TRUE(index.ok()) << index.error().message;
    auto ds = SceneDataset::Open(*root_ / "data");
    ASSERT_TRUE(ds.ok()) << ds.error().message;
    std::vector<SceneDataset> sets;
    sets.push_back(std::move(ds.value()));
    auto set = BuildSegmentationSet(sets, cv::Size(64, 48));
    ASSERT_TRUE(set.ok()) << set.error().message;
    set_ = new SegmentationSet(std::move(set.value()));
  }
  static void TearDownTestSuite() {
    delete root_;
    delete set_;
  }
  static SegmentationTrainOptions Options(const std::string& name, int steps) {
    SegmentationTrainOptions o;
    o.out = *root_ / name / "segmentation.pt";
    o.steps = steps;
    o.batch = 2;
    o.seed = 3;
    o.checkpoint_every = 100;
    o.network = {.width = 64, .height = 48, .base_channels = 4, .levels = 3};
    return o;
  }
  static softgrasp::testing::TempDir* root_;
  static SegmentationSet* set_;
};
softgrasp::testing::TempDir* SegmentationPipelineTest::root_ = nullptr;
SegmentationSet* SegmentationPipelineTest::set_ = nullptr;

TEST_F(SegmentationPipelineTest, SetHoldsLabelsAndDeformabilityAtModelSize) {
  ASSERT_EQ(set_->count(), 3);
  EXPECT_EQ(set_->labels[0].size(), 64u * 48u);
  // Deformability lives on objects only and is 1 - stiffness, so in [0, 0.9] there.
  int objects = 0;
  for (std::size_t k = 0; k < set_->labels[0].size(); ++k) {
    if (set_->labels[0][k] > 0)
      ++objects;
    else
      EXPECT_LE(set_->deformability[0][k], 255 / 2);  // only mixed edge pixels are non-zero
  }
  EXPECT_GT(objects, 20);
  EXPECT_GT(set_->mean_object_deformability, 0.0);
  EXPECT_LT(set_->mean_object_deformability, 0.95);
}

TEST_F(SegmentationPipelineTest, ResumingGivesTheSameLossesAsOneRun) {
  auto whole = TrainSegmentation(Options("whole", 4), *set_);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  SegmentationTrainOptions first = Options("split", 4);
  first.stop_after_step = 2;
  ASSERT_TRUE(TrainSegmentation(first, *set_).ok());
  SegmentationTrainOptions second = Options("split", 4);
  second.resume = true;
  auto rest = TrainSegmentation(second, *set_);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  EXPECT_EQ(rest.value().start_step, 2);
  ASSERT_EQ(rest.value().history.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_DOUBLE_EQ(rest.value().history[i].total, whole.value().history[i].total) << i;
    EXPECT_TRUE(std::isfinite(whole.value().history[i].total));
  }
  EXPECT_TRUE(fs::exists(*root_ / "whole" / "segmentation_loss.png"));
}

TEST_F(SegmentationPipelineTest, FineTuningStartsFromTheGivenModelsWeights) {
  ASSERT_TRUE(TrainSegmentation(Options("base", 3), *set_).ok());
  auto fresh = TrainSegmentation(Options("fresh", 1), *set_);
  ASSERT_TRUE(fresh.ok());
  SegmentationTrainOptions tune = Options("tuned", 1);
  tune.init = *root_ / "base" / "segmentation.pt";
  tune.learning_rate = 1e-12;  // so the tuned file keeps the base weights
  auto tuned = TrainSegmentation(tune, *set_);
  ASSERT_TRUE(tuned.ok()) << tuned.error().message;
  // Same seed and batch as the fresh run; only the starting weights differ.
  EXPECT_EQ(tuned.value().start_step, 0);
  EXPECT_NE(tuned.value().history[0].total, fresh.value().history[0].total);
  auto base = SegmentationModel::Load(*root_ / "base" / "segmentation.pt");
  auto after = SegmentationModel::Load(*root_ / "tuned" / "segmentation.pt");
  ASSERT_TRUE(base.ok() && after.ok());
  auto ds = SceneDataset::Open(*root_ / "data");
  auto sample = ds.value().Load(1);
  ASSERT_TRUE(sample.ok());
  auto scene = core::Preprocess(sample.value().depth, sample.value().camera);
  ASSERT_TRUE(scene.ok());
  const cv::Mat a = base.value().SegmentScene(scene.value()).deformability;
  const cv::Mat b = after.value().SegmentScene(scene.value()).deformability;
  EXPECT_LT(cv::norm(a, b, cv::NORM_INF), 1e-5);

  SegmentationTrainOptions other = Options("other", 1);
  other.network.base_channels = 8;
  other.init = tune.init;
  auto mismatch = TrainSegmentation(other, *set_);
  ASSERT_FALSE(mismatch.ok());
  EXPECT_EQ(mismatch.error().code, core::ErrorCode::kInvalidArgument);
  EXPECT_NE(mismatch.error().message.find("another network config"), std::string::npos);
  other.init = *root_ / "no-such-model.pt";
  other.network.base_channels = 4;
  EXPECT_EQ(TrainSegmentation(other, *set_).error().code, core::ErrorCode::kNotFound);
}

TEST_F(SegmentationPipelineTest, TrainedFileLoadsAndSegmentsAtTheInputSize) {
  ASSERT_TRUE(TrainSegmentation(Options("infer", 2), *set_).ok());
  auto model = SegmentationModel::Load(*root_ / "infer" / "segmentation.pt");
  ASSERT_TRUE(model.ok()) << model.error().message;
  EXPECT_EQ(model.value().input_width(), 64);
  EXPECT_GT(model.value().parameter_count(), 0);
  auto ds = SceneDataset::Open(*root_ / "data");
  auto sample = ds.value().Load(0);
  ASSERT_TRUE(sample.ok());
  auto scene = core::Preprocess(sample.value().depth, sample.value().camera);
  ASSERT_TRUE(scene.ok());
  const SegmentationOutput out = model.value().SegmentScene(scene.value());
  EXPECT_EQ(out.instances.labels.size(), sample.value().depth.depth_m.size());
  EXPECT_EQ(out.deformability.size(), sample.value().depth.depth_m.size());
  double lo = 0, hi = 0;
  cv::minMaxLoc(out.deformability, &lo, &hi);
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 1.0);
  for (float s : out.instances.scores) EXPECT_TRUE(s >= 0 && s <= 1);
}

TEST_F(SegmentationPipelineTest, BadModelFilesGiveClearErrors) {
  auto missing = SegmentationModel::Load(*root_ / "nope.pt");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, core::ErrorCode::kNotFound);
  const fs::path junk = *root_ / "junk.pt";
  std::ofstream(junk) << "not a model";
  auto bad = SegmentationModel::Load(junk);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, core::ErrorCode::kUnprocessable);
  EXPECT_NE(bad.error().message.find(junk.string()), std::string::npos);
  // A stiffness model is a libtorch archive too, but not a segmentation model.
  NetworkConfig c{.input_size = 32, .base_channels = 2, .levels = 3, .disc_channels = 2};
  UNetGenerator g(c);
  const fs::path stiffness = *root_ / "stiffness.pt";
  SaveGenerator(stiffness, g, c, kInputHeightRangeM);
  auto wrong = SegmentationModel::Load(stiffness);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("not a segmentation model"), std::string::npos);
  // Truncated: half of a real file.
  ASSERT_TRUE(TrainSegmentation(Options("cut", 1), *set_).ok());
  const fs::path whole = *root_ / "cut" / "segmentation.pt";
  std::string bytes(fs::file_size(whole), '\0');
  std::ifstream(whole, std::ios::binary)
      .read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  const fs::path cut = *root_ / "cut.pt";
  std::ofstream(cut, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  auto truncated = SegmentationModel::Load(cut);
  ASSERT_FALSE(truncated.ok());
  EXPECT_EQ(truncated.error().code, core::ErrorCode::kUnprocessable);
}

}  // namespace
}  // namespace softgrasp::models
