// Whole POST /v1/grasps on loopback: a real server in this process, a real socket per request,
// a real 640x480 float32 NPY (Primesense frame). Baseline in the same run: GET /healthz over the
// same path, so the ratio separates HTTP cost from grasp detection.
#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>

#include "tests/rest/server_fixture.h"

namespace softgrasp::rest {
namespace {

testing::RunningServer& Server() {
  static testing::RunningServer server;
  return server;
}

void BM_PostGraspsPrimesenseNpy(benchmark::State& state) {
  const std::string request = testing::MultipartRequest(
      "/v1/grasps",
      {{"depth", testing::ReadFileBytes(testing::SharedData("gqcnn/primesense/single_depth_0.npy")), "d.npy"},
       {"intrinsics", testing::ReadFileBytes(testing::SharedData("gqcnn/primesense/primesense.intr")), "p.intr"}});
  for (auto _ : state) {
    const auto reply = Server().Send(request);
    if (reply.status != 200) state.SkipWithError("POST /v1/grasps did not answer 200");
    benchmark::DoNotOptimize(reply.body.data());
  }
}
BENCHMARK(BM_PostGraspsPrimesenseNpy)->Unit(benchmark::kMillisecond)->UseRealTime();

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

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core for the engine, as the goal states
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
