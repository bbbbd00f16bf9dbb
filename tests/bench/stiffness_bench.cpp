// pix2stiffness inference and stiffness-aware FGE on a 640 x 480 clutter frame (docs/stiffness.md,
// "Speed"). Uses $SOFTGRASP_MODEL if set, else a freshly initialised network of the default size
// (same architecture, hence the same time). Two threads, as in the service.
//   build-models/tests/bench/stiffness_bench --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <stdexcept>

#include "service/core/fge.h"
#include "service/core/fge_stiffness.h"
#include "service/core/preprocess.h"
#include "service/models/network.h"
#include "service/models/stiffness_model.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/temp_dir.h"

namespace {

using namespace softgrasp;

struct Fixture {
  testing::SyntheticScene synth;
  core::Scene scene;
  std::unique_ptr<models::StiffnessModel> model;
};

Fixture& Get() {
  static Fixture* f = [] {
    auto* fx = new Fixture;
    fx->synth = testing::RenderScene(testing::ClutterSceneSpec());
    fx->scene = core::Preprocess(fx->synth.depth, fx->synth.camera).value();
    std::filesystem::path path;
    if (const char* env = std::getenv("SOFTGRASP_MODEL")) {
      path = env;
    } else {
      torch::manual_seed(1);
      models::NetworkConfig config;
      models::UNetGenerator g(config);
      models::InitWeights(*g);
      g->eval();
      static const testing::TempDir scratch("stiffness-bench");  // removed at exit
      path = scratch / "untrained.pt";
      models::SaveGenerator(path, g, config, models::kInputHeightRangeM);
    }
    auto m = models::StiffnessModel::Load(path);
    if (!m.ok()) throw std::runtime_error(m.error().message);
    fx->model = std::make_unique<models::StiffnessModel>(std::move(m.value()));
    return fx;
  }();
  return *f;
}

void SetThreads() {
  models::SetTorchThreads(2);
  cv::setNumThreads(2);
}

// Depth in, map out: Preprocess + resize to 256 + generator + resize back.
void BM_StiffnessPredict(benchmark::State& state) {
  SetThreads();
  Fixture& f = Get();
  for (auto _ : state) {
    auto map = f.model->Predict(f.synth.depth, f.synth.camera);
    benchmark::DoNotOptimize(map.value().data);
  }
}
BENCHMARK(BM_StiffnessPredict)->Unit(benchmark::kMillisecond);

// The generator alone at 256 x 256.
void BM_StiffnessGenerator256(benchmark::State& state) {
  SetThreads();
  Fixture& f = Get();
  const cv::Mat1f input = models::MakeModelInput(f.scene, f.model->input_size());
  for (auto _ : state) {
    const cv::Mat1f out = f.model->PredictModelInput(input);
    benchmark::DoNotOptimize(out.data);
  }
}
BENCHMARK(BM_StiffnessGenerator256)->Unit(benchmark::kMillisecond);

// Stiffness-aware FGE with a predicted map, and classic FGE on the same frame.
void BM_DetectGraspsStiffness(benchmark::State& state) {
  SetThreads();
  Fixture& f = Get();
  const cv::Mat1f map = f.model->PredictScene(f.scene);
  for (auto _ : state) {
    auto grasps = core::DetectGraspsStiffness(f.scene, f.synth.camera, map, core::Gripper{});
    benchmark::DoNotOptimize(grasps.data());
  }
}
BENCHMARK(BM_DetectGraspsStiffness)->Unit(benchmark::kMillisecond);

void BM_DetectGraspsFge(benchmark::State& state) {
  SetThreads();
  Fixture& f = Get();
  for (auto _ : state) {
    auto grasps = core::DetectGraspsFge(f.scene, f.synth.camera, core::Gripper{});
    benchmark::DoNotOptimize(grasps.data());
  }
}
BENCHMARK(BM_DetectGraspsFge)->Unit(benchmark::kMillisecond);

}  // namespace
