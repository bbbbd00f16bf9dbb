// The pix2stiffness pipeline on a tiny simulated dataset: reading, training steps, checkpoints
// and resuming, inference sizes and ranges, and clear errors for bad files.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "service/models/network.h"
#include "service/models/stiffness_model.h"
#include "sim/dataset/dataset.h"
#include "tests/support/temp_dir.h"
#include "train/dataset.h"
#include "train/trainer.h"

namespace softgrasp::models {
namespace {

namespace fs = std::filesystem;

// Small on purpose: 160 x 120 renders, a 64 px network with 4 levels.
NetworkConfig TinyNetwork() {
  NetworkConfig c;
  c.input_size = 64;
  c.base_channels = 4;
  c.levels = 4;
  c.disc_channels = 4;
  return c;
}

class PipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SetTorchThreads(1);
    root_ = new softgrasp::testing::TempDir("models-test");
    sim::DatasetParams params;
    params.scenes = 4;
    params.seed = 5;
    params.out_dir = *root_ / "data";
    params.spec.min_objects = 2;
    params.spec.max_objects = 3;
    params.spec.render.noise.enabled = true;
    core::Camera& cam = params.spec.render.camera;
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
    auto set = BuildTrainingSet(ds.value(), TinyNetwork().input_size);
    ASSERT_TRUE(set.ok()) << set.error().message;
    set_ = new TrainingSet(std::move(set.value()));
  }
  static void TearDownTestSuite() {
    delete root_;
    delete set_;
  }

  static TrainOptions Options(const std::string& name, int steps) {
    TrainOptions o;
    o.out = *root_ / name / "model.pt";
    o.steps = steps;
    o.seed = 7;
    o.batch = 2;
    o.checkpoint_every = 100;
    o.learning_rate = 1e-3;
    o.network = TinyNetwork();
    return o;
  }

  static softgrasp::testing::TempDir* root_;
  static TrainingSet* set_;
};

softgrasp::testing::TempDir* PipelineTest::root_ = nullptr;
TrainingSet* PipelineTest::set_ = nullptr;

std::vector<torch::Tensor> Parameters(const fs::path& model) {
  auto loaded = LoadGenerator(model);
  EXPECT_TRUE(loaded.ok()) << (loaded.ok() ? "" : loaded.error().message);
  std::vector<torch::Tensor> out;
  if (loaded.ok()) {
    for (const auto& p : loaded.value().generator->parameters()) out.push_back(p.detach().clone());
  }
  return out;
}

TEST_F(PipelineTest, DatasetReadsScenesWithCameraAndMaps) {
  auto ds = SceneDataset::Open(*root_ / "data");
  ASSERT_TRUE(ds.ok());
  EXPECT_EQ(ds.value().size(), 4);
  auto s = ds.value().Load(0);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s.value().depth.width(), 160);
  EXPECT_EQ(s.value().depth.height(), 120);
  EXPECT_EQ(s.value().camera.width, 160);
  double min_s = 0, max_s = 0;
  cv::minMaxLoc(s.value().stiffness, &min_s, &max_s);
  EXPECT_GE(min_s, 0.0);
  EXPECT_LE(max_s, 1.0);
  EXPECT_GE(max_s, 0.1);  // some object is in view
  EXPECT_EQ(set_->size(), 4);
  EXPECT_GT(set_->mean_target, 0.0);
  EXPECT_LT(set_->mean_target, 1.0);
}

TEST_F(PipelineTest, TrainingStepsLowerTheL1LossAndWriteAllFiles) {
  const TrainOptions o = Options("train", 30);
  auto report = Train(o, *set_);
  ASSERT_TRUE(report.ok()) << report.error().message;
  const auto& h = report.value().history;
  ASSERT_EQ(h.size(), 30u);
  for (const LossRecord& r : h) {
    EXPECT_TRUE(std::isfinite(r.d_loss) && std::isfinite(r.g_gan) && std::isfinite(r.g_l1));
  }
  // From a sigmoid output near 0.5 against mostly-background targets, L1 falls fast.
  const double first = (h[0].g_l1 + h[1].g_l1 + h[2].g_l1) / 3;
  const double last = (h[27].g_l1 + h[28].g_l1 + h[29].g_l1) / 3;
  EXPECT_LT(last, 0.8 * first) << "first " << first << " last " << last;
  EXPECT_TRUE(fs::exists(o.out));
  EXPECT_TRUE(fs::exists(CheckpointPath(o.out)));
  EXPECT_TRUE(fs::exists(LossCsvPath(o.out)));
  EXPECT_TRUE(fs::exists(LossPngPath(o.out)));
  std::ifstream csv(LossCsvPath(o.out));
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 31);  // header + one row per step
}

TEST_F(PipelineTest, ObjectWeightChangesOnlyTheL1Weighting) {
  // Same seed, same initial network, same first batch: the first step's L1 differs only by the
  // weighting. The untrained output is ~0.5 everywhere, so object pixels (targets 0.1 ... 1) are
  // closer to it than background (0) and weighting them up lowers the mean.
  TrainOptions plain = Options("plain_weight", 1);
  TrainOptions weighted = Options("object_weight", 1);
  weighted.object_weight = 5;
  auto a = Train(plain, *set_);
  auto b = Train(weighted, *set_);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_LT(b.value().history[0].g_l1, a.value().history[0].g_l1);
  EXPECT_GT(b.value().history[0].g_l1, 0.0);
  weighted.object_weight = -1;
  auto bad = Train(weighted, *set_);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "object_weight");
}

TEST_F(PipelineTest, ResumedRunMatchesAnUninterruptedOne) {
  const TrainOptions straight = Options("straight", 6);
  ASSERT_TRUE(Train(straight, *set_).ok());

  TrainOptions first = Options("resumed", 6);
  first.stop_after_step = 3;  // as if killed after the checkpoint of step 3
  ASSERT_TRUE(Train(first, *set_).ok());
  TrainOptions second = Options("resumed", 6);
  second.resume = true;
  auto report = Train(second, *set_);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report.value().start_step, 3);
  EXPECT_EQ(report.value().end_step, 6);
  EXPECT_EQ(report.value().history.size(), 6u);

  const auto a = Parameters(straight.out);
  const auto b = Parameters(second.out);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_FALSE(a.empty());
  // Batches, flips and dropout are seeded per step and Adam's moments are checkpointed, so the
  // runs agree; CPU kernels are deterministic at a fixed thread count (1 here).
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_TRUE(torch::allclose(a[i], b[i], 1e-5, 1e-6)) << "parameter " << i;
  }
  // Resuming at the end does nothing more.
  auto again = Train(second, *set_);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.value().start_step, 6);
  EXPECT_EQ(again.value().end_step, 6);
}

TEST_F(PipelineTest, InferenceKeepsTheInputSizeAndRange) {
  const TrainOptions o = Options("infer", 2);
  ASSERT_TRUE(Train(o, *set_).ok());
  auto model = StiffnessModel::Load(o.out);
  ASSERT_TRUE(model.ok()) << model.error().message;
  EXPECT_EQ(model.value().input_size(), 64);
  EXPECT_GT(model.value().parameter_count(), 0);
  auto ds = SceneDataset::Open(*root_ / "data");
  auto s = ds.value().Load(1);
  ASSERT_TRUE(s.ok());
  auto map = model.value().Predict(s.value().depth, s.value().camera);
  ASSERT_TRUE(map.ok()) << map.error().message;
  EXPECT_EQ(map.value().size(), s.value().depth.depth_m.size());
  double lo = 0, hi = 0;
  cv::minMaxLoc(map.value(), &lo, &hi);
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 1.0);
  EXPECT_TRUE(cv::checkRange(map.value()));
  // An odd size also comes back at its own size (stretch to the model side and back).
  core::DepthImage odd;
  cv::resize(s.value().depth.depth_m, odd.depth_m, cv::Size(101, 77), 0, 0, cv::INTER_NEAREST);
  core::Camera cam = s.value().camera;
  cam.fx *= 101.0 / 160;
  cam.fy *= 77.0 / 120;
  cam.cx *= 101.0 / 160;
  cam.cy *= 77.0 / 120;
  auto odd_map = model.value().Predict(odd, cam);
  ASSERT_TRUE(odd_map.ok()) << odd_map.error().message;
  EXPECT_EQ(odd_map.value().size(), cv::Size(101, 77));
  // Unusable depth: the preprocessing error comes through.
  core::DepthImage missing;
  missing.depth_m = cv::Mat1f(120, 160, std::nanf(""));
  auto bad = model.value().Predict(missing, s.value().camera);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, core::ErrorCode::kUnprocessable);
}

TEST_F(PipelineTest, MissingOrCorruptedModelFilesGiveClearErrors) {
  auto missing = StiffnessModel::Load(*root_ / "nope.pt");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, core::ErrorCode::kNotFound);
  EXPECT_NE(missing.error().message.find("nope.pt"), std::string::npos);

  const fs::path garbage = *root_ / "garbage.pt";
  std::ofstream(garbage) << "this is not a model";
  auto g = StiffnessModel::Load(garbage);
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.error().code, core::ErrorCode::kUnprocessable);

  const TrainOptions o = Options("corrupt", 1);
  ASSERT_TRUE(Train(o, *set_).ok());
  const auto size = fs::file_size(o.out);
  const fs::path truncated = *root_ / "truncated.pt";
  fs::copy_file(o.out, truncated);
  fs::resize_file(truncated, size / 2);
  auto t = StiffnessModel::Load(truncated);
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, core::ErrorCode::kUnprocessable);

  // A checkpoint is a libtorch archive, but not a model file.
  auto c = StiffnessModel::Load(CheckpointPath(o.out));
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, core::ErrorCode::kUnprocessable);
}

TEST_F(PipelineTest, BadDatasetsAndOptionsAreRejected) {
  auto none = SceneDataset::Open(*root_ / "no_such_dir");
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, core::ErrorCode::kNotFound);
  const fs::path bad = *root_ / "bad_index";
  fs::create_directories(bad);
  std::ofstream(bad / "index.json") << "{\"entries\": 3}";
  auto b = SceneDataset::Open(bad);
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().code, core::ErrorCode::kUnprocessable);
  std::ofstream(bad / "index.json") << "{\"entries\": [{\"manifest\": \"x/scene.json\"}]}";
  auto missing_files = SceneDataset::Open(bad);
  ASSERT_TRUE(missing_files.ok());
  EXPECT_FALSE(missing_files.value().Load(0).ok());

  TrainOptions o = Options("bad", 0);
  auto r = Train(o, *set_);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "steps");
  o = Options("bad", 2);
  o.network.input_size = 128;  // the set is 64 px
  EXPECT_FALSE(Train(o, *set_).ok());
  // Resuming from a checkpoint of another network size fails clearly.
  const TrainOptions small = Options("mismatch", 1);
  ASSERT_TRUE(Train(small, *set_).ok());
  TrainOptions other = small;
  other.network.base_channels = 8;
  other.resume = true;
  other.steps = 2;
  auto m = Train(other, *set_);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().field, "resume");
}

}  // namespace
}  // namespace softgrasp::models
