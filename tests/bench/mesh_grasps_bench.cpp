// The mesh grasp analysis per mesh, one thread: stable poses, 100 antipodal grasps, their robust
// Ferrari-Canny quality (25 samples each) and the whole of it (ray caster, poses, grasps,
// quality), on the Dex-Net bar clamp (476 triangles, welded) and on the same clamp subdivided
// 5 x 5 per triangle (11,900 triangles, same surface); and the service's whole analysis
// (AnalyseMeshGrasps: also the gripper collisions in every pose) with and without the robust
// samples, the baseline that says what the robust metric costs. Argument: the subdivision n.
// Figures and the command: docs/mesh-grasps.md.
#include <benchmark/benchmark.h>

#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "service/mesh/mesh_io.h"
#include "service/mesh_grasps/antipodal.h"
#include "service/mesh_grasps/grasp_quality.h"
#include "service/mesh_grasps/mesh_grasp_analysis.h"
#include "service/mesh_grasps/stable_poses.h"
#include "service/raycast/raycast.h"
#include "tests/support/subdivided_mesh.h"

namespace softgrasp {
namespace {

using Wrenches = Eigen::Matrix<double, 6, Eigen::Dynamic>;

mesh::TriangleMesh LoadBarClamp() {
  std::ifstream in(std::string(SOFTGRASP_TEST_DATA_DIR) + "/meshes/dexnet_bar_clamp.obj",
                   std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  auto mesh = mesh::ReadMesh(bytes.str());
  if (!mesh.ok()) throw std::runtime_error(mesh.error().message);
  return std::move(mesh).value();
}

raycast::MeshRaycaster CasterFor(const mesh::TriangleMesh& mesh) {
  const std::vector<raycast::Surface> surfaces{{1, &mesh, Eigen::Isometry3d::Identity()}};
  auto caster = raycast::MeshRaycaster::Build(surfaces);
  if (!caster.ok()) throw std::runtime_error(caster.error().message);
  return std::move(caster).value();
}

/// The grasp service's per-mesh defaults (docs/mesh-grasps.md).
mesh::AntipodalParams SamplerParams() { return mesh::AntipodalParams{}; }
mesh::RobustParams RobustFor(std::size_t grasp) {
  mesh::RobustParams robust;
  robust.seed = grasp;
  return robust;
}

mesh::ContactQuery JawQuery(const raycast::MeshRaycaster& caster) {
  return [&caster](const Eigen::Vector3d& center, const Eigen::Vector3d& axis, double width) {
    return mesh::CloseJaws(caster, center, axis, width);
  };
}

/// Everything the phases need, built once per subdivision.
struct Subject {
  mesh::TriangleMesh mesh;
  raycast::MeshRaycaster caster;
  Eigen::Vector3d com;
  std::vector<mesh::JawGrasp> grasps;
};

const Subject& SubjectFor(int n) {
  static std::map<int, std::unique_ptr<Subject>> cache;
  auto& slot = cache[n];
  if (!slot) {
    mesh::TriangleMesh m = testing::SubdivideMesh(LoadBarClamp(), n);
    raycast::MeshRaycaster caster = CasterFor(m);
    const Eigen::Vector3d com = mesh::VolumeCentroid(m);
    auto grasps = mesh::SampleAntipodalGrasps(m, caster, SamplerParams());
    if (!grasps.ok()) throw std::runtime_error(grasps.error().message);
    slot = std::make_unique<Subject>(
        Subject{std::move(m), std::move(caster), com, std::move(grasps).value()});
  }
  return *slot;
}

using RobustFn = mesh::RobustQuality (*)(const Eigen::Vector3d&, const Eigen::Vector3d&, double,
                                         const mesh::ContactQuery&, const Eigen::Vector3d&,
                                         const mesh::QualityParams&, const mesh::RobustParams&);

/// The robust quality of every grasp; returns the sum of the means, counts zero samples.
double RobustAll(const Subject& s, const raycast::MeshRaycaster& caster, RobustFn robust,
                 double* zero_samples = nullptr) {
  const mesh::ContactQuery query = JawQuery(caster);
  const double width = SamplerParams().max_width_m;
  double sum = 0.0;
  for (std::size_t i = 0; i < s.grasps.size(); ++i) {
    const auto& g = s.grasps[i];
    const auto q = robust(g.center_m, g.axis, width, query, s.com, {}, RobustFor(i));
    sum += q.mean;
    if (zero_samples != nullptr) {
      for (const double x : q.samples) *zero_samples += x == 0.0 ? 1.0 : 0.0;
    }
  }
  return sum;
}

void SetMeshCounters(benchmark::State& state, const Subject& s) {
  state.counters["triangles"] = static_cast<double>(s.mesh.faces.size());
  state.counters["grasps"] = static_cast<double>(s.grasps.size());
}

void BM_CasterBuild(benchmark::State& state) {
  const Subject& s = SubjectFor(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto caster = CasterFor(s.mesh);
    benchmark::DoNotOptimize(&caster);
  }
  SetMeshCounters(state, s);
}

void BM_StablePoses(benchmark::State& state) {
  const Subject& s = SubjectFor(static_cast<int>(state.range(0)));
  std::size_t poses = 0;
  for (auto _ : state) {
    auto result = mesh::ComputeStablePoses(s.mesh);
    if (!result.ok()) {
      state.SkipWithError(result.error().message.c_str());
      break;
    }
    poses = result.value().size();
    benchmark::DoNotOptimize(result.value().data());
  }
  SetMeshCounters(state, s);
  state.counters["poses"] = static_cast<double>(poses);
}

void BM_SampleGrasps(benchmark::State& state) {
  const Subject& s = SubjectFor(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto grasps = mesh::SampleAntipodalGrasps(s.mesh, s.caster, SamplerParams());
    benchmark::DoNotOptimize(grasps.value().data());
  }
  SetMeshCounters(state, s);
}

void RobustQualityOfGrasps(benchmark::State& state, RobustFn robust) {
  const Subject& s = SubjectFor(static_cast<int>(state.range(0)));
  double zero_samples = 0.0;
  const double sum = RobustAll(s, s.caster, robust, &zero_samples);
  for (auto _ : state) benchmark::DoNotOptimize(RobustAll(s, s.caster, robust));
  SetMeshCounters(state, s);
  state.counters["mean_quality"] = sum / static_cast<double>(s.grasps.size());
  state.counters["zero_share"] = zero_samples / (25.0 * static_cast<double>(s.grasps.size()));
}
void BM_RobustQuality(benchmark::State& state) {
  RobustQualityOfGrasps(state, &mesh::RobustFerrariCannyL1);
}

/// The Ferrari-Canny L1 of each grasp's nominal wrenches alone (no noise, no ray queries).
template <double (*Quality)(const Wrenches&)>
void FerrariCannyOfGrasps(benchmark::State& state) {
  const Subject& s = SubjectFor(static_cast<int>(state.range(0)));
  std::vector<Wrenches> all;
  for (const auto& g : s.grasps) all.push_back(mesh::GraspMatrix(g.a, g.b, s.com, {}));
  for (auto _ : state) {
    double sum = 0.0;
    for (const auto& w : all) sum += Quality(w);
    benchmark::DoNotOptimize(sum);
  }
  state.counters["hulls"] = static_cast<double>(all.size());
}
double LibraryFerrariCanny(const Wrenches& w) { return mesh::FerrariCannyL1(w); }
void BM_FerrariCanny(benchmark::State& state) { FerrariCannyOfGrasps<&LibraryFerrariCanny>(state); }

/// One mesh from scratch: ray caster, stable poses, 100 grasps, their robust quality.
void WholeMesh(benchmark::State& state, RobustFn robust) {
  const Subject& s = SubjectFor(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    const raycast::MeshRaycaster caster = CasterFor(s.mesh);
    auto poses = mesh::ComputeStablePoses(s.mesh);
    auto grasps = mesh::SampleAntipodalGrasps(s.mesh, caster, SamplerParams());
    if (!poses.ok() || !grasps.ok()) {
      state.SkipWithError("stable poses or sampling failed");
      break;
    }
    const mesh::ContactQuery query = JawQuery(caster);
    const Eigen::Vector3d com = mesh::VolumeCentroid(s.mesh);
    double sum = 0.0;
    for (std::size_t i = 0; i < grasps.value().size(); ++i) {
      const auto& g = grasps.value()[i];
      sum += robust(g.center_m, g.axis, SamplerParams().max_width_m, query, com, {}, RobustFor(i))
                 .mean;
    }
    benchmark::DoNotOptimize(sum);
  }
  SetMeshCounters(state, s);
}
void BM_WholeMesh(benchmark::State& state) { WholeMesh(state, &mesh::RobustFerrariCannyL1); }

/// POST /v1/meshes/grasps' analysis of a prepared mesh: stable poses, 100 grasps, nominal and
/// (range(1) samples) robust quality, collisions of the gripper in every pose.
void BM_AnalyseMeshGrasps(benchmark::State& state) {
  const Subject& s = SubjectFor(static_cast<int>(state.range(0)));
  mesh::MeshGraspOptions options;
  options.robust_samples = static_cast<int>(state.range(1));
  mesh::MeshGraspTiming timing;
  for (auto _ : state) {
    auto analysis = mesh::AnalyseMeshGrasps(s.mesh, options);
    if (!analysis.ok()) {
      state.SkipWithError(analysis.error().message.c_str());
      break;
    }
    timing = analysis.value().timing;
  }
  SetMeshCounters(state, s);
  state.counters["quality_ms"] = timing.quality_ms;
  state.counters["collisions_ms"] = timing.collisions_ms;
}

// n = 1: the bar clamp as it is (476 triangles); n = 5: 11,900 triangles.
BENCHMARK(BM_CasterBuild)->Arg(1)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StablePoses)->Arg(1)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SampleGrasps)->Arg(1)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FerrariCanny)->Arg(1)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RobustQuality)->Arg(1)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WholeMesh)->Arg(1)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AnalyseMeshGrasps)
    ->Args({1, 0})
    ->Args({1, 25})
    ->Args({5, 0})
    ->Args({5, 25})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace softgrasp
