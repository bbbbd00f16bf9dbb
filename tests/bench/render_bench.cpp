// Simulated-scene rendering (docs/sim-rendering.md): building the Embree BVH of a bin with a
// dozen objects, and rendering its 640x480 SR305 views (depth, labels, stiffness) without and
// with the depth-noise model. Rendering is single-threaded; the BVH build may use Embree's TBB
// threads.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>

#include "sim/render/render.h"

namespace softgrasp::sim {
namespace {

// A sphere of radius r: a UV grid (rings x segments) closed by two pole fans, outward.
std::shared_ptr<const SimObject> Sphere(double radius_m, int rings, int segments, float stiffness) {
  auto object = std::make_shared<SimObject>();
  mesh::TriangleMesh& m = object->mesh_o;
  m.vertices.push_back({0, 0, radius_m});
  for (int r = 1; r < rings; ++r) {
    const double theta = M_PI * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2.0 * M_PI * s / segments;
      m.vertices.push_back({radius_m * std::sin(theta) * std::cos(phi),
                            radius_m * std::sin(theta) * std::sin(phi),
                            radius_m * std::cos(theta)});
    }
  }
  m.vertices.push_back({0, 0, -radius_m});
  const int south = static_cast<int>(m.vertices.size()) - 1;
  auto ring = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) m.faces.push_back({0, ring(1, s), ring(1, s + 1)});
  for (int r = 1; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      m.faces.push_back({ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
      m.faces.push_back({ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
    }
  }
  for (int s = 0; s < segments; ++s) {
    m.faces.push_back({south, ring(rings - 1, s + 1), ring(rings - 1, s)});
  }
  object->vertex_stiffness.assign(m.vertices.size(), stiffness);
  return object;
}

SimScene BinScene() {
  SimScene scene;
  for (int k = 0; k < 12; ++k) {
    const double radius_m = 0.02 + 0.003 * (k % 4);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(-0.15 + 0.1 * (k % 4), -0.1 + 0.1 * (k / 4), radius_m);
    scene.objects.push_back(
        {k + 1, Sphere(radius_m, 48, 96, QuantizeStiffness(0.1f + 0.08f * k)), pose});
  }
  return scene;
}

void BM_BuildRaycaster(benchmark::State& state) {
  const SimScene scene = BinScene();
  for (auto _ : state) {
    auto raycaster = SceneRaycaster::Build(scene);
    if (!raycaster.ok()) {
      state.SkipWithError(raycaster.error().message.c_str());
      break;
    }
    benchmark::DoNotOptimize(&raycaster.value());
  }
}
BENCHMARK(BM_BuildRaycaster)->Unit(benchmark::kMillisecond);

void BM_Render(benchmark::State& state) {
  auto raycaster = SceneRaycaster::Build(BinScene());
  if (!raycaster.ok()) {
    state.SkipWithError(raycaster.error().message.c_str());
    return;
  }
  RenderOptions options;
  options.noise.enabled = state.range(0) != 0;
  for (auto _ : state) {
    const RenderedViews views = Render(raycaster.value(), options);
    benchmark::DoNotOptimize(views.depth.depth_m.data);
  }
  state.counters["pixels_per_s"] = benchmark::Counter(
      640.0 * 480.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Render)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace softgrasp::sim
