// The deformability planner alone (core::DetectGraspsDeformability, Algorithm 1 with its passes,
// openings and the 3-D finger check) on the shipped segmentation model's instances, as
// strategy=deformability plans in /v1/grasps after segmenting: the 640x480 synthetic clutter
// frame (8 boxes, the frame of grasps_api_bench's least_deformable case) with both target
// policies, and the real Primesense frame. Baseline in the same run: classic FGE on the same
// scenes. The segmentation itself is timed by segmentation_bench; docs/performance.md has the
// figures (build/tests/bench/deformability_plan_bench, 5 repetitions, aggregates only).
#include <benchmark/benchmark.h>

#include <memory>
#include <stdexcept>
#include <string>

#include "service/core/fge.h"
#include "service/core/fge_deformability.h"
#include "service/core/preprocess.h"
#include "service/engine/instances.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_data.h"

namespace softgrasp::engine {
namespace {

struct Prepared {
  core::Scene scene;
  core::Camera camera;
  core::ObjectMaps objects;
};

const models::SegmentationModel& ShippedModel() {
  static const auto model = [] {
    models::SetTorchThreads(2);
    auto m = models::SegmentationModel::Load(std::string(SOFTGRASP_SOURCE_DIR) +
                                             "/models/segmentation.pt");
    if (!m.ok()) throw std::runtime_error(m.error().message);
    return std::move(m).value();
  }();
  return model;
}

Prepared Prepare(const core::DepthImage& depth, const core::Camera& camera) {
  auto scene = core::Preprocess(depth, camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  Prepared p{std::move(scene).value(), camera, {}};
  auto instances = InstancesForPlan({}, p.scene, camera, &ShippedModel());
  if (!instances.ok()) throw std::runtime_error(instances.error().message);
  p.objects = {instances.value().labels, instances.value().scores, instances.value().deformability,
               instances.value().foreground};
  return p;
}

const Prepared& Clutter() {
  static const Prepared p = [] {
    const testing::SyntheticScene s = testing::RenderScene(testing::ClutterSceneSpec());
    return Prepare(s.depth, s.camera);
  }();
  return p;
}

const Prepared& Primesense() {
  static const Prepared p = Prepare(core::DepthImage{testing::LoadNpyFloat32(
                                        testing::TestData("gqcnn/primesense/single_depth_0.npy"))},
                                    core::Camera{525.0, 525.0, 319.5, 239.5, 640, 480});
  return p;
}

void Plan(benchmark::State& state, const Prepared& p, core::TargetPolicy policy) {
  core::DeformabilityParams params;
  params.policy = policy;
  std::size_t grasps = 0;
  for (auto _ : state) {
    const auto result =
        core::DetectGraspsDeformability(p.scene, p.camera, p.objects, core::Gripper{}, params);
    grasps = result.grasps.size();
    benchmark::DoNotOptimize(grasps);
  }
  state.counters["grasps"] = static_cast<double>(grasps);
}

void Fge(benchmark::State& state, const Prepared& p) {
  for (auto _ : state) {
    const auto grasps = core::DetectGraspsFge(p.scene, p.camera, core::Gripper{});
    benchmark::DoNotOptimize(grasps.data());
  }
}

void BM_PlanClutterLeastDeformable(benchmark::State& state) {
  Plan(state, Clutter(), core::TargetPolicy::kLeastDeformable);
}
BENCHMARK(BM_PlanClutterLeastDeformable)->Unit(benchmark::kMillisecond);

void BM_PlanClutterHighest(benchmark::State& state) {
  Plan(state, Clutter(), core::TargetPolicy::kHighest);
}
BENCHMARK(BM_PlanClutterHighest)->Unit(benchmark::kMillisecond);

void BM_PlanPrimesenseHighest(benchmark::State& state) {
  Plan(state, Primesense(), core::TargetPolicy::kHighest);
}
BENCHMARK(BM_PlanPrimesenseHighest)->Unit(benchmark::kMillisecond);

void BM_FgeClutter(benchmark::State& state) { Fge(state, Clutter()); }
BENCHMARK(BM_FgeClutter)->Unit(benchmark::kMillisecond);

void BM_FgePrimesense(benchmark::State& state) { Fge(state, Primesense()); }
BENCHMARK(BM_FgePrimesense)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace softgrasp::engine
