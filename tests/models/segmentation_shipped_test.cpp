// Holds the shipped segmentation model (models/segmentation.pt) to the scores recorded beside it
// in models/segmentation.json ("quality_test"): mask AP50 and AP (all instances count, none
// ignored), deformability RMSE (0-255) and MSSIM, on validation scenes (shapes never seen in
// training) generated here with fixed seeds, sparse bins and dense bins; and the PCL baseline on
// the same scenes, which the model must beat.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "service/core/metrics.h"
#include "service/core/preprocess.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/segmentation/instance_metrics.h"
#include "service/segmentation/pcl_segmenter.h"
#include "sim/dataset/dataset.h"
#include "sim/dataset/scene_gen.h"

namespace softgrasp::models {
namespace {

namespace fs = std::filesystem;

TEST(ShippedSegmentationModel, MeetsItsRecordedScoresAndBeatsPcl) {
  const fs::path model_path = fs::path(SOFTGRASP_SOURCE_DIR) / "models" / "segmentation.pt";
  const fs::path card_path = fs::path(SOFTGRASP_SOURCE_DIR) / "models" / "segmentation.json";
  if (!fs::exists(model_path)) GTEST_SKIP() << "no shipped model at " << model_path;
  ASSERT_TRUE(fs::exists(card_path)) << "the shipped model needs its scores in " << card_path;
  EXPECT_LE(fs::file_size(model_path), 20u * 1024 * 1024);
  std::ifstream in(card_path);
  const nlohmann::json q = nlohmann::json::parse(in).at("quality_test");

  SetTorchThreads(2);
  auto model = SegmentationModel::Load(model_path);
  ASSERT_TRUE(model.ok()) << model.error().message;

  segmentation::MaskEvaluator model_eval, pcl_eval;
  double rmse_sum = 0, mssim_sum = 0;
  int n = 0;
  for (const auto& part : q.at("parts")) {
    sim::SceneSpec spec;  // softgrasp-sim generate defaults: bin, noise on
    spec.split = sim::ShapeSplit::kVal;
    spec.render.noise.enabled = true;
    spec.min_objects = part.at("objects")[0].get<int>();
    spec.max_objects = part.at("objects")[1].get<int>();
    const auto seed = part.at("seed").get<std::uint64_t>();
    for (int i = 0; i < part.at("scenes").get<int>(); ++i) {
      auto g = sim::GenerateScene(spec, sim::SceneSeed(seed, i, spec.split));
      ASSERT_TRUE(g.ok()) << g.error().message;
      // The dataset encodings, so the figures match `evaluate-segmentation` on disk.
      core::DepthImage depth;
      sim::DepthToMillimetres(g.value().views.depth.depth_m).convertTo(depth.depth_m, CV_32F, 1e-3);
      depth.depth_m.setTo(std::nanf(""), depth.depth_m == 0);
      cv::Mat1f deformability;
      sim::UnitToByte(g.value().views.deformability).convertTo(deformability, CV_32F, 1.0 / 255);
      auto scene = core::Preprocess(depth, spec.render.camera);
      if (!scene.ok()) continue;
      const segmentation::TruthImage truth{g.value().views.labels, {}, {}};
      const SegmentationOutput out = model.value().SegmentScene(scene.value());
      model_eval.Add(truth, out.instances);
      auto pcl = segmentation::SegmentPcl(scene.value(), spec.render.camera);
      ASSERT_TRUE(pcl.ok()) << pcl.error().message;
      pcl_eval.Add(truth, pcl.value());
      rmse_sum += core::StiffnessRmse255(deformability, out.deformability).value();
      mssim_sum += core::StiffnessMssim(deformability, out.deformability).value();
      ++n;
    }
  }
  ASSERT_GT(n, 0);
  const segmentation::MaskScores m = model_eval.Compute(), p = pcl_eval.Compute();
  const double rmse = rmse_sum / n, mssim = mssim_sum / n;
  std::printf(
      "shipped segmentation model on %d val scenes: AP50 %.3f AP %.3f AR %.3f (PCL AP50 "
      "%.3f AP %.3f AR %.3f); deformability RMSE %.2f MSSIM %.4f\n",
      n, m.ap50, m.ap, m.ar, p.ap50, p.ap, p.ar, rmse, mssim);
  const double margin = q.value("ap_margin", 0.03);
  EXPECT_GE(m.ap50, q.at("ap50").get<double>() - margin);
  EXPECT_GE(m.ap, q.at("ap").get<double>() - margin);
  EXPECT_GT(m.ap50, p.ap50) << "the model must beat the PCL baseline";
  EXPECT_LE(rmse, q.at("rmse_255").get<double>() + q.value("rmse_margin", 1.0));
  EXPECT_GE(mssim, q.at("mssim").get<double>() - q.value("mssim_margin", 0.01));
}

}  // namespace
}  // namespace softgrasp::models
