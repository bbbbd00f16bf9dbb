// strategy=gqcnn against classic FGE in the same run, whole plans as /v1/grasps makes them
// (engine::PlanGrasps: preprocessing, planning, ranking; the upload's decoding not included) on
// the real frames in tests/data: the 640x480 Primesense frame of a single object and the 516x386
// PhoXi heap. The GQ-CNN is the shipped model (models/gqcnn.pt), with torch on 2 threads as the
// server runs it; Dex-Net's 250 seed candidates and 3 CEM rounds of 50. docs/gqcnn.md has the
// figures and the command (build/tests/bench/gqcnn_plan_bench, 5 repetitions, aggregates only).
#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "service/engine/engine.h"
#include "service/engine/strategies/gqcnn.h"
#include "service/models/gqcnn_model.h"
#include "service/models/stiffness_model.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_data.h"

namespace softgrasp::engine {
namespace {

struct Frame {
  core::DepthImage depth;
  core::Camera camera;
};

const Frame& Primesense() {
  static const Frame frame{core::DepthImage{testing::LoadNpyFloat32(
                               testing::TestData("gqcnn/primesense/single_depth_0.npy"))},
                           core::Camera{525.0, 525.0, 319.5, 239.5, 640, 480}};
  return frame;
}

const Frame& Phoxi() {
  static const Frame frame{core::DepthImage{testing::LoadNpyFloat32(
                               testing::TestData("gqcnn/phoxi/clutter_depth_0.npy"))},
                           core::Camera{552.5, 552.5, 255.5, 191.75, 516, 386}};
  return frame;
}

const Models* ShippedGqcnn() {
  static const std::unique_ptr<Models> models = [] {
    models::SetTorchThreads(2);
    auto model = models::GqcnnModel::Load(std::string(SOFTGRASP_SOURCE_DIR) + "/models/gqcnn.pt");
    if (!model.ok()) return std::unique_ptr<Models>();
    auto m = std::make_unique<Models>();
    m->gqcnn = std::make_shared<const models::GqcnnModel>(std::move(model).value());
    return m;
  }();
  return models.get();
}

void Run(benchmark::State& state, const Frame& frame, const std::string& strategy) {
  const Models* models = ShippedGqcnn();
  if (strategy == "gqcnn" && models == nullptr) {
    state.SkipWithError("no shipped GQ-CNN model (models/gqcnn.pt)");
    return;
  }
  PlanOptions options;
  options.strategy = strategy;
  options.fge.top_k = 10;
  std::size_t grasps = 0;
  int crops = 0;
  for (auto _ : state) {
    auto plan = PlanGrasps(frame.depth, frame.camera, options, models ? *models : Models{});
    if (!plan.ok()) {
      state.SkipWithError(plan.error().message.c_str());
      return;
    }
    grasps = plan.value().grasps.size();
    const GqcnnStats* stats = GqcnnStatsOf(plan.value());
    crops = stats ? stats->evaluated : 0;
    benchmark::DoNotOptimize(grasps);
  }
  state.counters["grasps"] = static_cast<double>(grasps);
  state.counters["crops"] = crops;
}

void BM_PrimesenseFge(benchmark::State& state) { Run(state, Primesense(), "fge"); }
void BM_PrimesenseGqcnn(benchmark::State& state) { Run(state, Primesense(), "gqcnn"); }
void BM_PhoxiFge(benchmark::State& state) { Run(state, Phoxi(), "fge"); }
void BM_PhoxiGqcnn(benchmark::State& state) { Run(state, Phoxi(), "gqcnn"); }
// Wall time: torch runs on 2 threads, so CPU time would count both cores.
BENCHMARK(BM_PrimesenseFge)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PrimesenseGqcnn)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PhoxiFge)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PhoxiGqcnn)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace softgrasp::engine
