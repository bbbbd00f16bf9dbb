// FGE and preprocessing timings on one core. See docs/fge.md for the figures and the command.
#include <benchmark/benchmark.h>

#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "service/core/fge.h"
#include "service/core/fge_geometry.h"
#include "service/core/preprocess.h"
#include "tests/support/fge_reference.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_data.h"

namespace softgrasp {
namespace {

struct Frame {
  core::DepthImage depth;
  core::Camera camera;
  core::Scene scene;
};

Frame Prepared(core::DepthImage depth, const core::Camera& camera) {
  cv::setNumThreads(1);
  Frame f{std::move(depth), camera, {}};
  f.scene = core::Preprocess(f.depth, f.camera).value();
  return f;
}

const Frame& Clutter() {
  static const Frame frame = [] {
    const auto synth = testing::RenderScene(testing::ClutterSceneSpec());
    return Prepared(synth.depth, synth.camera);
  }();
  return frame;
}

const Frame& Primesense() {
  static const Frame frame = [] {
    core::DepthImage depth{
        testing::LoadNpyFloat32(testing::TestData("gqcnn/primesense/single_depth_0.npy"))};
    return Prepared(depth, core::Camera{525.0, 525.0, 319.5, 239.5, 640, 480});
  }();
  return frame;
}

const Frame& Phoxi() {
  static const Frame frame = [] {
    core::DepthImage depth{
        testing::LoadNpyFloat32(testing::TestData("gqcnn/phoxi/clutter_depth_0.npy"))};
    return Prepared(depth, core::Camera{552.5, 552.5, 255.5, 191.75, 516, 386});
  }();
  return frame;
}

// The clutter scene with 31 % of its pixels missing, in blobs and speckle like a real sensor.
const Frame& ClutterWithHoles() {
  static const Frame frame = [] {
    auto synth = testing::RenderScene(testing::ClutterSceneSpec());
    cv::Mat1b holes = cv::Mat1b::zeros(synth.depth.depth_m.size());
    cv::RNG rng(7);
    while (cv::countNonZero(holes) < 0.31 * static_cast<double>(holes.total())) {
      const cv::Point c(rng.uniform(0, holes.cols), rng.uniform(0, holes.rows));
      if (rng.uniform(0, 4) == 0) {
        cv::ellipse(holes, c, cv::Size(rng.uniform(5, 40), rng.uniform(5, 40)), rng.uniform(0, 180),
                    0, 360, 255, cv::FILLED);
      } else {
        holes(c) = 255;
      }
    }
    synth.depth.depth_m.setTo(0.0f, holes);
    return Prepared(synth.depth, synth.camera);
  }();
  return frame;
}

const Frame& FrameOf(const benchmark::State& state) {
  switch (state.range(0)) {
    case 1:
      return Primesense();
    case 2:
      return Phoxi();
    case 3:
      return ClutterWithHoles();
    default:
      return Clutter();
  }
}

void SetLabel(benchmark::State& state) {
  static const char* kNames[] = {"synthetic clutter 640x480", "primesense 640x480",
                                 "phoxi 516x386 (31% missing)",
                                 "synthetic clutter 640x480 (31% missing)"};
  state.SetLabel(kNames[state.range(0)]);
}

// Everything DetectGraspsFge does: slice search, 16 angles x 5 heights, peaks, NMS, contact
// checks, poses; range(1) = 1 also the 3-D finger clearance of every kept candidate (the
// default), 0 without it (the baseline in the same run).
void BM_FgeFast(benchmark::State& state) {
  const Frame& f = FrameOf(state);
  cv::setNumThreads(1);
  core::FgeParams params;
  params.check_finger_clearance = state.range(1) != 0;
  for (auto _ : state) {
    auto grasps = core::DetectGraspsFge(f.scene, f.camera, core::Gripper{}, params);
    benchmark::DoNotOptimize(grasps);
  }
  SetLabel(state);
}

// The reference maps (cv::filter2D with rotated templates) for the same angles and heights.
void BM_FgeFilter2D(benchmark::State& state) {
  const Frame& f = FrameOf(state);
  const core::FgeParams params;
  // The first batch of slices: the one the fast search covers when it finds top_k grasps there.
  auto slices =
      core::fge_detail::SearchSlices(f.scene.height_m, f.scene.contact_allowed,
                                     core::fge_detail::PxPerMetre(f.scene.floor, f.camera, 0),
                                     core::Gripper{}, params)
          .slices;
  slices.resize(std::min(slices.size(), static_cast<std::size_t>(params.num_height_steps)));
  cv::setNumThreads(1);
  for (auto _ : state) {
    for (int a = 0; a < params.num_angles; ++a) {
      for (const auto& s : slices) {
        auto maps = core::ComputeFgeMapsReference(f.scene, f.camera, core::Gripper{}, params,
                                                  std::numbers::pi * a / params.num_angles,
                                                  s.contact_height_m);
        benchmark::DoNotOptimize(maps);
      }
    }
  }
  state.counters["maps"] = static_cast<double>(params.num_angles * slices.size());
  SetLabel(state);
}

void BM_Preprocess(benchmark::State& state) {
  const Frame& f = FrameOf(state);
  cv::setNumThreads(1);
  for (auto _ : state) {
    auto scene = core::Preprocess(f.depth, f.camera);
    benchmark::DoNotOptimize(scene);
  }
  state.counters["missing_%"] = 100 * f.scene.missing_fraction;
  SetLabel(state);
}

BENCHMARK(BM_FgeFast)->ArgsProduct({{0, 1, 2}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FgeFilter2D)->DenseRange(0, 1)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Preprocess)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace softgrasp
