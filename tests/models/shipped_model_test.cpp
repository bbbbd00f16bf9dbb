// Holds the shipped model (models/pix2stiffness.pt) to the scores recorded beside it in
// models/pix2stiffness.json ("quality_test"): RMSE (0-255) and MSSIM on a small validation set
// generated here with a fixed seed, exactly as `softgrasp-sim generate --split val` writes it
// (depth rounded to millimetres, stiffness to 8 bits).

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "service/core/metrics.h"
#include "service/models/stiffness_model.h"
#include "sim/dataset/dataset.h"
#include "sim/dataset/scene_gen.h"

namespace softgrasp::models {
namespace {

namespace fs = std::filesystem;

TEST(ShippedModel, MeetsItsRecordedScores) {
  const fs::path model_path = fs::path(SOFTGRASP_SOURCE_DIR) / "models" / "pix2stiffness.pt";
  const fs::path card_path = fs::path(SOFTGRASP_SOURCE_DIR) / "models" / "pix2stiffness.json";
  if (!fs::exists(model_path)) GTEST_SKIP() << "no shipped model at " << model_path;
  ASSERT_TRUE(fs::exists(card_path)) << "the shipped model needs its scores in " << card_path;
  std::ifstream in(card_path);
  const nlohmann::json card = nlohmann::json::parse(in);
  const nlohmann::json& q = card.at("quality_test");
  const int scenes = q.at("scenes").get<int>();
  const std::uint64_t seed = q.at("seed").get<std::uint64_t>();
  const double rmse_recorded = q.at("rmse_255").get<double>();
  const double mssim_recorded = q.at("mssim").get<double>();
  const double rmse_margin = q.value("rmse_margin", 1.0);
  const double mssim_margin = q.value("mssim_margin", 0.01);

  SetTorchThreads(2);
  auto model = StiffnessModel::Load(model_path);
  ASSERT_TRUE(model.ok()) << model.error().message;
  EXPECT_LE(fs::file_size(model_path), 20u * 1024 * 1024);

  sim::SceneSpec spec;  // softgrasp-sim generate defaults: 3-8 objects, bin, noise on
  spec.split = sim::ShapeSplit::kVal;
  spec.render.noise.enabled = true;
  double rmse_sum = 0, mssim_sum = 0;
  int n = 0;
  for (int i = 0; i < scenes; ++i) {
    auto g = sim::GenerateScene(spec, sim::SceneSeed(seed, i, spec.split));
    ASSERT_TRUE(g.ok()) << g.error().message;
    // Round-trip through the dataset encodings so the figures match `evaluate` on disk.
    core::DepthImage depth;
    sim::DepthToMillimetres(g.value().views.depth.depth_m).convertTo(depth.depth_m, CV_32F, 1e-3);
    depth.depth_m.setTo(std::nanf(""), depth.depth_m == 0);
    cv::Mat1f truth;
    sim::UnitToByte(g.value().views.stiffness).convertTo(truth, CV_32F, 1.0 / 255);
    auto predicted = model.value().Predict(depth, spec.render.camera);
    if (!predicted.ok()) continue;  // `evaluate` skips unusable frames the same way
    rmse_sum += core::StiffnessRmse255(truth, predicted.value()).value();
    mssim_sum += core::StiffnessMssim(truth, predicted.value()).value();
    ++n;
  }
  ASSERT_GT(n, 0);
  const double rmse = rmse_sum / n, mssim = mssim_sum / n;
  RecordProperty("rmse_255", std::to_string(rmse));
  RecordProperty("mssim", std::to_string(mssim));
  std::printf("shipped model on %d val scenes (seed %llu): RMSE %.3f MSSIM %.4f\n", n,
              static_cast<unsigned long long>(seed), rmse, mssim);
  EXPECT_LE(rmse, rmse_recorded + rmse_margin);
  EXPECT_GE(mssim, mssim_recorded - mssim_margin);
}

}  // namespace
}  // namespace softgrasp::models
