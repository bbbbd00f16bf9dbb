// Whole POST /v1/grasps on loopback: a real server in this process, a real socket per request,
// a real 640x480 float32 NPY (Primesense frame). Baseline in the same run: GET /healthz over the
// same path, so the ratio separates HTTP cost from grasp detection. With the shipped pix2stiffness
// model: the stiffness strategy (the default then), classic FGE with mean stiffness, and the map
// alone (POST /v1/stiffness). With both shipped models (the server's default): the
// deformability strategy (segmentation model + Algorithm 1 on one target), the default then.
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>

#include "service/io/depth_codec.h"
#include "service/models/stiffness_model.h"
#include "tests/rest/server_fixture.h"
#include "tests/support/synthetic_scene.h"

namespace softgrasp::rest {
namespace {

// softgrasp-server's thread settings, applied before the first server starts: one OpenCV thread
// for the engine, as the FGE goal states; libtorch one thread per CPU. (Its allocator setting
// comes from bench_main.cpp, as for every benchmark.)
bool ServerThreads() {
  static const bool applied = [] {
    cv::setNumThreads(1);
    models::SetTorchThreads(0);
    return true;
  }();
  return applied;
}

testing::RunningServer& Server() {
  ServerThreads();
  static testing::RunningServer server;
  return server;
}

testing::RunningServer& ServerWithModel() {
  ServerThreads();
  static testing::RunningServer server({}, nullptr, nullptr, testing::ShippedStiffnessModel());
  return server;
}

testing::RunningServer& ServerWithBothModels() {
  ServerThreads();
  static testing::RunningServer server({}, nullptr, nullptr, testing::ShippedStiffnessModel(),
                                       testing::ShippedSegmentationModel());
  return server;
}

std::string PrimesenseUpload(const std::string& target,
                             std::vector<testing::FormPart> fields = {}) {
  std::vector<testing::FormPart> parts = {
      {"depth", testing::ReadFileBytes(testing::TestData("gqcnn/primesense/single_depth_0.npy")),
       "d.npy"},
      {"intrinsics", testing::ReadFileBytes(testing::TestData("gqcnn/primesense/primesense.intr")),
       "p.intr"}};
  parts.insert(parts.end(), fields.begin(), fields.end());
  return testing::MultipartRequest(target, parts);
}

void Run(benchmark::State& state, testing::RunningServer& server, const std::string& request) {
  for (auto _ : state) {
    const auto reply = server.Send(request);
    if (reply.status != 200) state.SkipWithError("the request did not answer 200");
    benchmark::DoNotOptimize(reply.body.data());
  }
}

void BM_PostGraspsPrimesenseNpy(benchmark::State& state) {
  Run(state, Server(), PrimesenseUpload("/v1/grasps"));
}
BENCHMARK(BM_PostGraspsPrimesenseNpy)->Unit(benchmark::kMillisecond)->UseRealTime();

// Model map + stiffness-aware FGE (the default strategy with a model).
void BM_PostGraspsStiffnessStrategy(benchmark::State& state) {
  Run(state, ServerWithModel(), PrimesenseUpload("/v1/grasps", {{"strategy", "stiffness", ""}}));
}
BENCHMARK(BM_PostGraspsStiffnessStrategy)->Unit(benchmark::kMillisecond)->UseRealTime();

// Classic FGE plus the model map for each grasp's mean_stiffness.
void BM_PostGraspsFgeWithModel(benchmark::State& state) {
  Run(state, ServerWithModel(), PrimesenseUpload("/v1/grasps", {{"strategy", "fge", ""}}));
}
BENCHMARK(BM_PostGraspsFgeWithModel)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same on a 640 x 480 clutter frame (the synthetic clutter scene of stiffness_bench), where
// the planners have the most candidates: the budget's hard case.
void BM_PostGraspsStiffnessClutter(benchmark::State& state) {
  const ::softgrasp::testing::SyntheticScene clutter =
      ::softgrasp::testing::RenderScene(::softgrasp::testing::ClutterSceneSpec());
  const core::Camera& c = clutter.camera;
  const std::string target = "/v1/grasps?strategy=stiffness&fx=" + std::to_string(c.fx) +
                             "&fy=" + std::to_string(c.fy) + "&cx=" + std::to_string(c.cx) +
                             "&cy=" + std::to_string(c.cy);
  Run(state, ServerWithModel(),
      testing::RawRequest("POST", target, "application/x-npy",
                          io::EncodeNpy(clutter.depth.depth_m)));
}
BENCHMARK(BM_PostGraspsStiffnessClutter)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_PostGraspsFgeClutter(benchmark::State& state) {
  const ::softgrasp::testing::SyntheticScene clutter =
      ::softgrasp::testing::RenderScene(::softgrasp::testing::ClutterSceneSpec());
  const core::Camera& c = clutter.camera;
  const std::string target = "/v1/grasps?fx=" + std::to_string(c.fx) +
                             "&fy=" + std::to_string(c.fy) + "&cx=" + std::to_string(c.cx) +
                             "&cy=" + std::to_string(c.cy);
  Run(state, Server(),
      testing::RawRequest("POST", target, "application/x-npy",
                          io::EncodeNpy(clutter.depth.depth_m)));
}
BENCHMARK(BM_PostGraspsFgeClutter)->Unit(benchmark::kMillisecond)->UseRealTime();

// Segmentation model + Algorithm 1 on the highest confident object (the default with both models).
void BM_PostGraspsDeformabilityStrategy(benchmark::State& state) {
  Run(state, ServerWithBothModels(), PrimesenseUpload("/v1/grasps"));
}
BENCHMARK(BM_PostGraspsDeformabilityStrategy)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_PostGraspsDeformabilityLeastDeformableClutter(benchmark::State& state) {
  const ::softgrasp::testing::SyntheticScene clutter =
      ::softgrasp::testing::RenderScene(::softgrasp::testing::ClutterSceneSpec());
  const core::Camera& c = clutter.camera;
  const std::string target =
      "/v1/grasps?strategy=deformability&target_policy=least_deformable&fx=" +
      std::to_string(c.fx) + "&fy=" + std::to_string(c.fy) + "&cx=" + std::to_string(c.cx) +
      "&cy=" + std::to_string(c.cy);
  Run(state, ServerWithBothModels(),
      testing::RawRequest("POST", target, "application/x-npy",
                          io::EncodeNpy(clutter.depth.depth_m)));
}
BENCHMARK(BM_PostGraspsDeformabilityLeastDeformableClutter)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The map alone as an 8-bit PNG.
void BM_PostStiffnessPng8(benchmark::State& state) {
  Run(state, ServerWithModel(), PrimesenseUpload("/v1/stiffness"));
}
BENCHMARK(BM_PostStiffnessPng8)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GetHealthz(benchmark::State& state) {
  const std::string request = testing::RawRequest("GET", "/healthz");
  for (auto _ : state) {
    const auto reply = Server().Send(request);
    if (reply.status != 200) state.SkipWithError("GET /healthz did not answer 200");
  }
}
BENCHMARK(BM_GetHealthz)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace softgrasp::rest
