// GQ-CNN dataset generation (docs/gqcnn-dataset.md): one rendered image with its crops, as the
// generator makes it (the window the crops read, table computed per pixel, object by Embree,
// noise, crops) against the baseline in the same run (the full 600 x 600 image, then the same
// crops); one crop alone; and the per-object mesh analysis (preparation, 100 grasps, 25 robust
// samples), which is excluded from the per-image figure. Objects: a fractal at alpha 0.3 (seed 7)
// (after the Dex-Net rescale to a 4 cm smallest extent), each of its stable poses in turn;
// single-threaded.
#include <benchmark/benchmark.h>

#include <array>
#include <memory>
#include <stdexcept>

#include "service/gqcnn/crop.h"
#include "service/mesh/fractal.h"
#include "service/mesh/mesh_prepare.h"
#include "service/mesh_grasps/mesh_grasp_analysis.h"
#include "sim/gqcnn/gqcnn_dataset.h"

namespace softgrasp::sim {
namespace {

struct Prepared {
  mesh::TriangleMesh mesh;
  mesh::MeshGraspAnalysis analysis;
};

mesh::TriangleMesh FractalMesh() {
  mesh::FractalParams params;
  params.seed = 7;
  params.alpha = 0.3;
  auto model = mesh::GenerateFractal(params);
  if (!model.ok()) throw std::runtime_error(model.error().message);
  mesh::PrepareOptions prepare;
  prepare.rescale_min_extent_m = 0.04;
  auto prepared = mesh::PrepareMesh(std::move(model.value().mesh), prepare);
  if (!prepared.ok()) throw std::runtime_error(prepared.error().message);
  return std::move(prepared.value().mesh);
}

Prepared Analysed(int robust_samples) {
  Prepared p;
  p.mesh = FractalMesh();
  mesh::MeshGraspOptions options = DefaultGqcnnDatasetParams().analysis;
  options.robust_samples = robust_samples;
  options.seed = 7;
  auto analysis = mesh::AnalyseMeshGrasps(p.mesh, options);
  if (!analysis.ok()) throw std::runtime_error(analysis.error().message);
  p.analysis = std::move(analysis.value());
  return p;
}

const Prepared& Shared() {
  static const Prepared prepared = Analysed(5);  // labels do not matter for the timing
  return prepared;
}

void RenderImages(benchmark::State& state, bool full_image) {
  // Every stable pose in turn, as the generator renders them.
  const Prepared& p = Shared();
  std::vector<GqcnnPoseScene> scenes;
  for (int pose = 0; pose < static_cast<int>(p.analysis.poses.size()); ++pose) {
    auto scene = MakePoseScene(p.mesh, p.analysis, pose);
    if (!scene.ok()) throw std::runtime_error(scene.error().message);
    scenes.push_back(std::move(scene.value()));
  }
  const GqcnnDatasetParams params = DefaultGqcnnDatasetParams();
  std::uint64_t seed = 1;
  std::int64_t pixels = 0;
  std::size_t datapoints = 0;
  std::vector<gqcnn::GraspDatapoint> out;
  for (auto _ : state) {
    out.clear();
    const GqcnnPoseScene& scene = scenes[seed % scenes.size()];
    pixels += scene.RenderImage(params, seed++, full_image, &out);
    datapoints += out.size();
    benchmark::DoNotOptimize(out.data());
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["pixels_per_image"] = static_cast<double>(pixels) / n;
  state.counters["crops_per_image"] = static_cast<double>(datapoints) / n;
}

/// What the generator does per image: the crops' window only.
void BM_ImageWithCrops(benchmark::State& state) { RenderImages(state, false); }
BENCHMARK(BM_ImageWithCrops)->Unit(benchmark::kMillisecond);

/// Baseline: the whole 600 x 600 image, then the same crops.
void BM_FullImageWithCrops(benchmark::State& state) { RenderImages(state, true); }
BENCHMARK(BM_FullImageWithCrops)->Unit(benchmark::kMillisecond);

void BM_OneCrop(benchmark::State& state) {
  core::DepthImage depth;
  depth.depth_m = cv::Mat1f(300, 300, 0.7F);
  for (int v = 100; v < 200; ++v) {
    for (int u = 120; u < 180; ++u) depth.depth_m(v, u) = 0.66F;
  }
  std::array<float, gqcnn::kCropPixels> crop{};
  double angle = 0.0;
  for (auto _ : state) {
    gqcnn::CropGrasp(depth, {150.0, 150.0, angle, 0.68, 40.0}, crop.data());
    angle += 0.1;
    benchmark::DoNotOptimize(crop.data());
  }
}
BENCHMARK(BM_OneCrop)->Unit(benchmark::kMicrosecond);

/// The per-object analysis the generator runs before rendering (not in the per-image figure).
void BM_ObjectAnalysis(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(Analysed(25).analysis.grasps.size());
}
BENCHMARK(BM_ObjectAnalysis)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace softgrasp::sim
