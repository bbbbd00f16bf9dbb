// Holds the shipped GQ-CNN (models/gqcnn.pt) to the score recorded in its card
// (models/gqcnn.json, "quality_test"): balanced accuracy on grasps of a real object it never saw,
// the Dex-Net bar clamp (tests/data/meshes), labelled and cropped here by the dataset generator
// with a fixed seed; and the card's hand-feature logistic baseline on the same grasps, which the
// network must beat.

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "service/models/gqcnn_model.h"
#include "service/models/stiffness_model.h"
#include "sim/gqcnn/gqcnn_dataset.h"
#include "tests/support/temp_dir.h"
#include "tests/support/test_data.h"
#include "tools/train/gqcnn_metrics.h"
#include "train/gqcnn_trainer.h"

namespace softgrasp::models {
namespace {

namespace fs = std::filesystem;

double BalancedAccuracy(const GqcnnSet& set, const std::vector<float>& probabilities) {
  return tools::ComputeGqcnnMetrics({set.labels, probabilities, set.object_keys, set.image_keys},
                                    0.5)
      .balanced_accuracy;
}

TEST(ShippedGqcnn, MeetsItsRecordedScoreOnTheBarClampAndBeatsTheBaseline) {
  const fs::path model_path = fs::path(SOFTGRASP_SOURCE_DIR) / "models" / "gqcnn.pt";
  const fs::path card_path = fs::path(SOFTGRASP_SOURCE_DIR) / "models" / "gqcnn.json";
  if (!fs::exists(model_path)) GTEST_SKIP() << "no shipped model at " << model_path;
  ASSERT_TRUE(fs::exists(card_path)) << "the shipped model needs its card " << card_path;
  EXPECT_LE(fs::file_size(model_path), 20u * 1024 * 1024);
  std::ifstream in(card_path);
  const nlohmann::json card = nlohmann::json::parse(in);
  const nlohmann::json& q = card.at("quality_test");

  SetTorchThreads(2);
  auto model = GqcnnModel::Load(model_path);
  ASSERT_TRUE(model.ok()) << model.error().message;

  // The bar clamp alone in a folder, as `softgrasp-sim gqcnn-dataset --source meshes` reads it.
  testing::TempDir dir("gqcnn-shipped");
  fs::create_directories(dir / "meshes");
  fs::copy_file(testing::TestData("meshes/dexnet_bar_clamp.obj"),
                dir / "meshes" / "dexnet_bar_clamp.obj");
  sim::GqcnnDatasetParams params = sim::DefaultGqcnnDatasetParams();
  params.source = sim::GqcnnMeshSource::kMeshes;
  params.meshes_dir = dir / "meshes";
  params.objects = 1;
  params.seed = q.at("seed").get<std::uint64_t>();
  params.images_per_object = q.at("images").get<int>();
  params.out_dir = dir / "data";
  auto generated = sim::GenerateGqcnnDataset(params);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  auto set = LoadGqcnnSet({params.out_dir});
  ASSERT_TRUE(set.ok()) << set.error().message;
  const GqcnnSet& s = set.value();
  EXPECT_EQ(static_cast<std::int64_t>(s.size()), q.at("grasps").get<std::int64_t>());
  ASSERT_GT(s.positives, 0u);
  ASSERT_LT(s.positives, s.size());

  ASSERT_TRUE(s.clearances_measured);
  const std::vector<float> net = model.value().Predict(s.crops_depth_m, s.grasp_depths_m,
                                                       model.value().takes_clearances()
                                                           ? std::span<const float>(s.clearances_m)
                                                           : std::span<const float>());
  auto baseline = LogisticBaseline::FromJson(card.at("baseline"));
  ASSERT_TRUE(baseline.ok()) << baseline.error().message;
  std::vector<float> logistic(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    logistic[i] = static_cast<float>(
        baseline.value().Predict(GqcnnHandFeatures(s.crop(i), s.grasp_depths_m[i], s.width_px[i])));
  }
  const double net_ba = BalancedAccuracy(s, net);
  const double logistic_ba = BalancedAccuracy(s, logistic);
  std::printf(
      "shipped GQ-CNN on the bar clamp (%zu grasps, %llu positive): balanced accuracy "
      "%.4f, logistic baseline %.4f\n",
      s.size(), static_cast<unsigned long long>(s.positives), net_ba, logistic_ba);
  EXPECT_GE(net_ba, q.at("balanced_accuracy").get<double>() - q.at("margin").get<double>());
  EXPECT_GT(net_ba, logistic_ba);
}

}  // namespace
}  // namespace softgrasp::models
