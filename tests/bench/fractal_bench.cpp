// Seconds per ACCEPTED fractal model, rejected draws included, per thesis alpha, 10,000 points,
// one thread. One iteration = one model from a new seed (0, 1, 2, ...), so every run measures
// the same models. Counters: median / p90 / mean CPU seconds per model, draws per model, share
// of models whose alpha was raised, points left for the triangulation after merging, and draws
// rejected after their triangulation (the expensive rejections). See docs/fractals.md for the
// figures and the command.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <ctime>
#include <random>
#include <vector>

#include "service/mesh/alpha_shape.h"
#include "service/mesh/fractal.h"
#include "service/mesh/ifs.h"

namespace softgrasp {
namespace {

double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

void BM_FractalModel(benchmark::State& state) {
  const double alpha = static_cast<double>(state.range(0)) / 100.0;
  const double merge_fraction = static_cast<double>(state.range(1)) / 1000.0;
  std::uint64_t seed = 0;
  std::vector<double> cpu_seconds;
  double draws = 0.0, raised = 0.0, triangulated = 0.0, late_rejections = 0.0;
  for (auto _ : state) {
    mesh::FractalParams params;
    params.seed = seed++;
    params.alpha = alpha;
    params.num_points = 10000;
    params.merge_fraction = merge_fraction;
    const double start = ThreadCpuSeconds();
    auto model = mesh::GenerateFractal(params);
    cpu_seconds.push_back(ThreadCpuSeconds() - start);
    if (!model.ok()) {
      state.SkipWithError(model.error().message.c_str());
      break;
    }
    draws += model.value().attempts;
    triangulated += model.value().points_triangulated;
    // Draws rejected after their triangulation: the expensive ones.
    late_rejections += model.value().rejections.no_solid +
                       model.value().rejections.float_collision +
                       model.value().rejections.self_intersecting;
    raised += model.value().alpha_raised ? 1.0 : 0.0;
    benchmark::DoNotOptimize(model.value().mesh.faces.data());
  }
  const double n = static_cast<double>(std::max<std::size_t>(cpu_seconds.size(), 1));
  double total = 0.0;
  for (const double s : cpu_seconds) total += s;
  state.counters["median_s"] = Quantile(cpu_seconds, 0.5);
  state.counters["p90_s"] = Quantile(cpu_seconds, 0.9);
  state.counters["mean_s"] = total / n;
  state.counters["draws_per_model"] = draws / n;
  state.counters["raised_share"] = raised / n;
  state.counters["points_triangulated"] = triangulated / n;
  state.counters["late_rejections"] = late_rejections / n;
}
// 60 models per alpha (seeds 0..59): args (alpha * 100, merge_fraction * 1000). The default
// merge_fraction (0.05) per thesis alpha, then alpha 0.3 without merging as the in-run baseline.
BENCHMARK(BM_FractalModel)
    ->Args({6, 50})
    ->Args({30, 50})
    ->Args({70, 50})
    ->Args({30, 0})
    ->Iterations(60)
    ->Unit(benchmark::kMillisecond);

// Yardstick for the machine: the Delaunay triangulation (plus alpha classification) of 10,000
// uniform random points, the floor under every model above.
void BM_DelaunayYardstick(benchmark::State& state) {
  std::mt19937_64 rng(1);
  std::vector<std::array<double, 3>> points(10000);
  for (auto& p : points) {
    for (double& x : p) x = 2.0 * mesh::UnitDouble(rng()) - 1.0;
  }
  for (auto _ : state) {
    auto facets = mesh::RawAlphaShapeFacets(points, 0.3);
    benchmark::DoNotOptimize(facets.value().data());
  }
}
BENCHMARK(BM_DelaunayYardstick)->Iterations(20)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace softgrasp
