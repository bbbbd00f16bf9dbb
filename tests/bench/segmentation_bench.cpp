// Segmentation on simulated 640x480 SR305 bin scenes with sensor noise, a usual bin (3-8 objects)
// and a dense one (15-30 objects): the shipped model (network + grouping, models/segmentation.pt)
// and, beside it in the same run, the PCL baseline (service/segmentation/pcl_segmenter.h) at
// stride 1 (every pixel in the cloud, the default) and stride 2, and the two fused
// (segmentation::FuseInstances, method=fused). Scenes are generated and
// preprocessed once, outside the timed loop.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <stdexcept>

#include "service/core/preprocess.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/segmentation/fuse.h"
#include "service/segmentation/pcl_segmenter.h"
#include "sim/dataset/scene_gen.h"

namespace softgrasp::segmentation {
namespace {

struct Prepared {
  core::Scene scene;
  core::Camera camera;
  int objects = 0;
};

Prepared MakeBin(int min_objects, int max_objects, std::uint64_t seed) {
  sim::SceneSpec spec;
  spec.min_objects = min_objects;
  spec.max_objects = max_objects;
  spec.render.noise.enabled = true;
  auto generated = sim::GenerateScene(spec, seed);
  if (!generated.ok()) throw std::runtime_error(generated.error().message);
  auto scene = core::Preprocess(generated.value().views.depth, spec.render.camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  return {std::move(scene).value(), spec.render.camera,
          static_cast<int>(generated.value().scene.objects.size())};
}

void Run(benchmark::State& state, const Prepared& bin) {
  PclParams params;
  params.stride_px = static_cast<int>(state.range(0));
  int instances = 0;
  for (auto _ : state) {
    auto masks = SegmentPcl(bin.scene, bin.camera, params);
    if (!masks.ok()) state.SkipWithError(masks.error().message.c_str());
    instances = masks.ok() ? masks.value().count() : 0;
    benchmark::DoNotOptimize(instances);
  }
  state.counters["objects"] = bin.objects;
  state.counters["instances"] = instances;
}

void BM_SegmentPclBin(benchmark::State& state) {
  static const Prepared bin = MakeBin(3, 8, 101);
  Run(state, bin);
}
BENCHMARK(BM_SegmentPclBin)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_SegmentPclDenseBin(benchmark::State& state) {
  static const Prepared bin = MakeBin(15, 30, 201);
  Run(state, bin);
}
BENCHMARK(BM_SegmentPclDenseBin)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

const models::SegmentationModel* ShippedModel() {
  static const auto model = [] {
    models::SetTorchThreads(2);
    return models::SegmentationModel::Load(std::string(SOFTGRASP_SOURCE_DIR) +
                                           "/models/segmentation.pt");
  }();
  return model.ok() ? &model.value() : nullptr;
}

// Times `segment(model)` (returning the instance count) with the shipped model.
template <class Segment>
void RunWithModel(benchmark::State& state, const Prepared& bin, Segment&& segment) {
  const models::SegmentationModel* model = ShippedModel();
  if (!model) {
    state.SkipWithError("no shipped segmentation model");
    return;
  }
  int instances = 0;
  for (auto _ : state) {
    instances = segment(*model);
    benchmark::DoNotOptimize(instances);
  }
  state.counters["objects"] = bin.objects;
  state.counters["instances"] = instances;
}

void RunModel(benchmark::State& state, const Prepared& bin) {
  RunWithModel(state, bin, [&](const models::SegmentationModel& model) {
    return model.SegmentScene(bin.scene).instances.count();
  });
}

void BM_SegmentModelBin(benchmark::State& state) {
  static const Prepared bin = MakeBin(3, 8, 101);
  RunModel(state, bin);
}
BENCHMARK(BM_SegmentModelBin)->Unit(benchmark::kMillisecond);

void BM_SegmentModelDenseBin(benchmark::State& state) {
  static const Prepared bin = MakeBin(15, 30, 201);
  RunModel(state, bin);
}
BENCHMARK(BM_SegmentModelDenseBin)->Unit(benchmark::kMillisecond);

// method=fused as the service runs it: the model, the PCL baseline at its default stride 1, and
// FuseInstances.
void RunFused(benchmark::State& state, const Prepared& bin) {
  RunWithModel(state, bin, [&](const models::SegmentationModel& model) {
    const models::SegmentationOutput out = model.SegmentScene(bin.scene);
    auto pcl = SegmentPcl(bin.scene, bin.camera);
    if (!pcl.ok()) {
      state.SkipWithError(pcl.error().message.c_str());
      return 0;
    }
    return FuseInstances(out.instances, pcl.value()).count();
  });
}

void BM_SegmentFusedBin(benchmark::State& state) {
  static const Prepared bin = MakeBin(3, 8, 101);
  RunFused(state, bin);
}
BENCHMARK(BM_SegmentFusedBin)->Unit(benchmark::kMillisecond);

void BM_SegmentFusedDenseBin(benchmark::State& state) {
  static const Prepared bin = MakeBin(15, 30, 201);
  RunFused(state, bin);
}
BENCHMARK(BM_SegmentFusedDenseBin)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace softgrasp::segmentation
