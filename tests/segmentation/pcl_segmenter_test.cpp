// The PCL baseline segmenter: analytic boxes on a table, simulated bins (walls and rim must stay
// support), the real GQ-CNN frames, and its errors. Measured numbers are printed; with
// SOFTGRASP_SEGMENTATION_DUMP_DIR set, overlays of the results are written there as PNGs.
#include "service/segmentation/pcl_segmenter.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "service/core/preprocess.h"
#include "sim/dataset/scene_gen.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_data.h"

namespace softgrasp::segmentation {
namespace {

const std::string kData = testing::TestData("gqcnn");

core::Scene Prepare(const core::DepthImage& depth, const core::Camera& camera) {
  auto scene = core::Preprocess(depth, camera);
  if (!scene.ok()) throw std::runtime_error(scene.error().message);
  return std::move(scene).value();
}

InstanceMasks Segment(const core::Scene& scene, const core::Camera& camera,
                      const PclParams& params = {}) {
  auto masks = SegmentPcl(scene, camera, params);
  if (!masks.ok()) throw std::runtime_error(masks.error().message);
  return std::move(masks).value();
}

double Iou(const cv::Mat1b& a, const cv::Mat1b& b) {
  const int inter = cv::countNonZero(a & b);
  const int uni = cv::countNonZero(a | b);
  return uni == 0 ? 0.0 : static_cast<double>(inter) / uni;
}

// The best IoU of each ground-truth id (> 0) with any predicted instance.
std::map<int, double> BestIous(const cv::Mat1i& truth, const InstanceMasks& masks) {
  std::map<int, double> best;
  for (int v = 0; v < truth.rows; ++v) {
    for (int u = 0; u < truth.cols; ++u) {
      if (truth(v, u) > 0) best[truth(v, u)] = 0.0;
    }
  }
  for (auto& [id, iou] : best) {
    const cv::Mat1b gt = truth == id;
    for (int k = 1; k <= masks.count(); ++k) iou = std::max(iou, Iou(gt, masks.labels == k));
  }
  return best;
}

void CheckValid(const InstanceMasks& masks, const cv::Size& size) {
  ASSERT_EQ(masks.labels.size(), size);
  for (int k = 1; k <= masks.count(); ++k) {
    EXPECT_GT(cv::countNonZero(masks.labels == k), 0) << "id " << k << " is empty";
    EXPECT_GE(masks.scores[static_cast<std::size_t>(k - 1)], 0.0f);
    EXPECT_LE(masks.scores[static_cast<std::size_t>(k - 1)], 1.0f);
  }
  double max_label = 0;
  cv::minMaxLoc(masks.labels, nullptr, &max_label);
  EXPECT_EQ(static_cast<int>(max_label), masks.count());
}

// Instances in colour over the grey depth; outlines of `truth` (non-zero) in white.
void Dump(const std::string& name, const core::Scene& scene, const InstanceMasks& masks,
          const cv::Mat1b& truth = {}) {
  const char* dir = std::getenv("SOFTGRASP_SEGMENTATION_DUMP_DIR");
  if (!dir) return;
  double lo = 0, hi = 0;
  cv::minMaxLoc(scene.depth_filled_m, &lo, &hi);
  cv::Mat1b grey;
  scene.depth_filled_m.convertTo(grey, CV_8U, -200.0 / (hi - lo), 220.0 + 200.0 * lo / (hi - lo));
  cv::Mat3b out;
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  out.setTo(cv::Scalar(0, 0, 0), scene.missing_mask);
  for (int v = 0; v < out.rows; ++v) {
    for (int u = 0; u < out.cols; ++u) {
      const int id = masks.labels(v, u);
      if (!id) continue;
      cv::Mat3b hsv(1, 1, cv::Vec3b(static_cast<std::uint8_t>((id * 47) % 180), 220, 255));
      cv::Mat3b bgr;
      cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
      out(v, u) = 0.35 * out(v, u) + 0.65 * bgr(0, 0);
    }
  }
  if (!truth.empty()) {
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(truth.clone(), contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    cv::drawContours(out, contours, -1, cv::Scalar(255, 255, 255), 1);
  }
  cv::imwrite(std::string(dir) + "/" + name + ".png", out);
}

// ---- analytic scenes ----

testing::SceneSpec TableSpec(std::vector<testing::Box> boxes) {
  testing::SceneSpec spec;
  spec.camera_height_m = 0.6;
  spec.boxes = std::move(boxes);
  return spec;
}

TEST(SegmentPclAnalytic, SeparatedBoxesGiveOneInstanceEach) {
  const auto spec = TableSpec({
      {.x_m = -0.10, .y_m = -0.06, .size_x_m = 0.04, .size_y_m = 0.08, .height_m = 0.05, .id = 1},
      {.x_m = 0.08,
       .y_m = -0.05,
       .size_x_m = 0.06,
       .size_y_m = 0.05,
       .height_m = 0.03,
       .yaw_rad = 0.5,
       .id = 2},
      {.x_m = 0.0,
       .y_m = 0.08,
       .size_x_m = 0.03,
       .size_y_m = 0.10,
       .height_m = 0.02,
       .yaw_rad = 1.2,
       .id = 3},
      {.x_m = 0.15, .y_m = 0.10, .size_x_m = 0.05, .size_y_m = 0.05, .height_m = 0.08, .id = 4},
  });
  const auto synthetic = testing::RenderScene(spec);
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  const InstanceMasks masks = Segment(scene, synthetic.camera);
  CheckValid(masks, synthetic.object_id.size());
  Dump("analytic_boxes", scene, masks, synthetic.object_id > 0);
  EXPECT_EQ(masks.count(), 4);
  for (const auto& [id, iou] : BestIous(synthetic.object_id, masks)) {
    std::cout << "[ measured ] analytic box " << id << " IoU " << iou << "\n";
    EXPECT_GE(iou, 0.9) << "box " << id;
  }
}

TEST(SegmentPclAnalytic, EmptyTableGivesNoInstances) {
  auto spec = TableSpec({});
  spec.table_tilt_rad = 0.2;
  const auto synthetic = testing::RenderScene(spec);
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  const InstanceMasks masks = Segment(scene, synthetic.camera);
  EXPECT_EQ(masks.count(), 0);
  EXPECT_EQ(cv::countNonZero(masks.labels), 0);
}

// Touching boxes of different heights: the lower box's top meets the taller box's side, which
// the camera (straight above) hardly sees, so the clusters stay apart by their height difference.
TEST(SegmentPclAnalytic, TouchingBoxesOfDifferentHeights) {
  const auto spec = TableSpec({
      {.x_m = -0.03, .y_m = 0.0, .size_x_m = 0.06, .size_y_m = 0.08, .height_m = 0.06, .id = 1},
      {.x_m = 0.03, .y_m = 0.0, .size_x_m = 0.06, .size_y_m = 0.08, .height_m = 0.03, .id = 2},
  });
  const auto synthetic = testing::RenderScene(spec);
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  const InstanceMasks masks = Segment(scene, synthetic.camera);
  CheckValid(masks, synthetic.object_id.size());
  Dump("analytic_touching", scene, masks, synthetic.object_id > 0);
  EXPECT_EQ(masks.count(), 2);
  for (const auto& [id, iou] : BestIous(synthetic.object_id, masks)) {
    std::cout << "[ measured ] touching box " << id << " IoU " << iou << "\n";
    EXPECT_GE(iou, 0.85) << "box " << id;
  }
}

// Same height and touching: one surface, so one instance (the baseline's known weakness).
TEST(SegmentPclAnalytic, TouchingBoxesOfEqualHeightMerge) {
  const auto spec = TableSpec({
      {.x_m = -0.03, .y_m = 0.0, .size_x_m = 0.06, .size_y_m = 0.08, .height_m = 0.04, .id = 1},
      {.x_m = 0.03, .y_m = 0.0, .size_x_m = 0.06, .size_y_m = 0.08, .height_m = 0.04, .id = 2},
  });
  const auto synthetic = testing::RenderScene(spec);
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  const InstanceMasks masks = Segment(scene, synthetic.camera);
  EXPECT_EQ(masks.count(), 1);
}

TEST(SegmentPclAnalytic, SameInputSameOutputAndStrideKeepsTheResult) {
  const auto synthetic = testing::RenderScene(testing::ClutterSceneSpec());
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  const InstanceMasks a = Segment(scene, synthetic.camera);
  const InstanceMasks b = Segment(scene, synthetic.camera);
  ASSERT_EQ(a.count(), b.count());
  EXPECT_EQ(cv::countNonZero(a.labels != b.labels), 0);
  EXPECT_EQ(a.scores, b.scores);
  PclParams strided;
  strided.stride_px = 2;
  const InstanceMasks c = Segment(scene, synthetic.camera, strided);
  EXPECT_EQ(c.count(), a.count());
  EXPECT_GT(Iou(a.labels > 0, c.labels > 0), 0.97);
}

TEST(SegmentPclErrors, SizeMismatchIsInvalidArgument) {
  const auto synthetic = testing::RenderScene(TableSpec({}));
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  core::Camera camera = synthetic.camera;
  camera.width = 320;
  camera.height = 240;
  auto masks = SegmentPcl(scene, camera);
  ASSERT_FALSE(masks.ok());
  EXPECT_EQ(masks.error().code, core::ErrorCode::kInvalidArgument);
  PclParams bad;
  bad.stride_px = 0;
  auto masks2 = SegmentPcl(scene, synthetic.camera, bad);
  ASSERT_FALSE(masks2.ok());
  EXPECT_EQ(masks2.error().code, core::ErrorCode::kInvalidArgument);
}

TEST(SegmentPclErrors, FloorMarginBoundsOutOfOrderAreInvalidArgument) {
  const auto synthetic = testing::RenderScene(TableSpec({}));
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  PclParams bad;
  bad.min_height_lowest_m = 0.008;  // above min_height_m (6 mm)
  auto masks = SegmentPcl(scene, synthetic.camera, bad);
  ASSERT_FALSE(masks.ok());
  EXPECT_EQ(masks.error().code, core::ErrorCode::kInvalidArgument);
  bad = PclParams{};
  bad.floor_noise_sigmas = -1;
  ASSERT_FALSE(SegmentPcl(scene, synthetic.camera, bad).ok());
}

// ---- the floor margin follows the frame's floor noise ----

// A 640 x 480 scene whose heights are normal noise of sigma_m about the floor (fixed seed).
core::Scene NoisyFloor(double sigma_m) {
  core::Scene scene;
  scene.height_m.create(480, 640);
  cv::RNG rng(7);
  rng.fill(scene.height_m, cv::RNG::NORMAL, 0.0, sigma_m);
  scene.missing_mask = cv::Mat1b(480, 640, std::uint8_t{0});
  return scene;
}

TEST(FloorMargin, FourSigmasOfTheFloorNoiseWithinItsBounds) {
  const PclParams params;  // 4 sigma, clamped to [2.5 mm, 6 mm]
  EXPECT_NEAR(FloorMarginM(NoisyFloor(0.001), params), 0.004, 0.0002);
  EXPECT_NEAR(FloorMarginM(NoisyFloor(0.0012), params), 0.0048, 0.0002);
  EXPECT_DOUBLE_EQ(FloorMarginM(NoisyFloor(0.0002), params), 0.0025);  // a flat table
  EXPECT_DOUBLE_EQ(FloorMarginM(NoisyFloor(0.003), params), 0.006);    // a noisy one
  PclParams fixed;
  fixed.floor_noise_sigmas = 0;
  EXPECT_DOUBLE_EQ(FloorMarginM(NoisyFloor(0.001), fixed), 0.006);
}

TEST(FloorMargin, MissingPixelsAndRaisedSurfacesDoNotCount) {
  core::Scene scene = NoisyFloor(0.001);
  // The left half: noisier, but not measured.
  cv::Mat1f left = scene.height_m.colRange(0, 320);
  left *= 3.0;
  scene.missing_mask.colRange(0, 320).setTo(255);
  // A raised object on the right: 5 cm up, no floor pixels.
  scene.height_m(cv::Rect(400, 100, 100, 100)).setTo(0.05);
  EXPECT_NEAR(FloorMarginM(scene, PclParams{}), 0.004, 0.0003);
  // No floor at all: the largest margin.
  scene.height_m.setTo(0.05);
  EXPECT_DOUBLE_EQ(FloorMarginM(scene, PclParams{}), 0.006);
}

// A mat 4 mm thick on a flat table (the Primesense frame 1 case: a flat rim standing 3-12 mm
// over a table flat to 0.3 mm). A fixed 6 mm margin takes it for the table; the margin from
// the frame's noise (2.5 mm here) finds it, and the box beside it either way.
TEST(FloorMargin, AThinObjectOnAFlatTableIsFound) {
  const auto spec = TableSpec({
      {.x_m = -0.06, .y_m = 0.0, .size_x_m = 0.08, .size_y_m = 0.10, .height_m = 0.004, .id = 1},
      {.x_m = 0.08, .y_m = 0.0, .size_x_m = 0.05, .size_y_m = 0.05, .height_m = 0.04, .id = 2},
  });
  const auto synthetic = testing::RenderScene(spec);
  const core::Scene scene = Prepare(synthetic.depth, synthetic.camera);
  EXPECT_DOUBLE_EQ(FloorMarginM(scene, PclParams{}), 0.0025);
  const std::map<int, double> adaptive =
      BestIous(synthetic.object_id, Segment(scene, synthetic.camera));
  PclParams fixed;
  fixed.floor_noise_sigmas = 0;
  const std::map<int, double> fixed_6mm =
      BestIous(synthetic.object_id, Segment(scene, synthetic.camera, fixed));
  std::cout << "[ measured ] thin mat IoU " << adaptive.at(1) << " (fixed 6 mm: " << fixed_6mm.at(1)
            << "), box " << adaptive.at(2) << "\n";
  EXPECT_GE(adaptive.at(1), 0.85);
  EXPECT_LT(fixed_6mm.at(1), 0.1);
  EXPECT_GE(adaptive.at(2), 0.9);
  EXPECT_GE(fixed_6mm.at(2), 0.9);
}

// ---- simulated bins ----

struct SimCase {
  int min_objects;
  int max_objects;
  std::uint64_t seed;
  double min_mean_best_iou;  // measured, with margin (docs/segmentation-pcl.md)
};

class SegmentPclSimBin : public ::testing::TestWithParam<SimCase> {};

TEST_P(SegmentPclSimBin, NothingOnTheSupportAndObjectsFound) {
  const SimCase c = GetParam();
  sim::SceneSpec spec;
  spec.min_objects = c.min_objects;
  spec.max_objects = c.max_objects;
  spec.render.noise.enabled = true;
  auto generated = sim::GenerateScene(spec, c.seed);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  const sim::RenderedViews& views = generated.value().views;
  const core::Camera& camera = spec.render.camera;
  const core::Scene scene = Prepare(views.depth, camera);
  const InstanceMasks masks = Segment(scene, camera);
  CheckValid(masks, views.labels.size());
  cv::Mat1i truth;
  views.labels.convertTo(truth, CV_32S);
  Dump("sim_bin_seed" + std::to_string(c.seed), scene, masks, views.labels > 0);

  const cv::Mat1b predicted = masks.labels > 0;
  const int on_support = cv::countNonZero(predicted & (views.labels == 0));
  const int predicted_px = cv::countNonZero(predicted);
  const double support_fraction =
      predicted_px == 0 ? 0.0 : static_cast<double>(on_support) / predicted_px;
  // Ground-truth objects that are visible enough to count (at least min_cluster_px pixels).
  double sum = 0;
  int n = 0;
  for (const auto& [id, iou] : BestIous(truth, masks)) {
    if (cv::countNonZero(truth == id) < PclParams{}.min_cluster_px) continue;
    sum += iou;
    ++n;
  }
  const double mean_best_iou = n == 0 ? 0.0 : sum / n;
  std::cout << "[ measured ] sim seed " << c.seed << ": " << n << " objects, " << masks.count()
            << " instances, mean best IoU " << mean_best_iou << ", on support " << support_fraction
            << "\n";
  EXPECT_LT(support_fraction, 0.02);
  ASSERT_GT(n, 0);
  EXPECT_GE(mean_best_iou, c.min_mean_best_iou);
}

INSTANTIATE_TEST_SUITE_P(Scenes, SegmentPclSimBin,
                         // Measured mean best IoU: 0.92, 0.63 (two objects touch and merge),
                         // 0.85; dense: 0.37 (touching objects merge).
                         ::testing::Values(SimCase{3, 8, 101, 0.8}, SimCase{3, 8, 102, 0.5},
                                           SimCase{3, 8, 103, 0.7}, SimCase{15, 30, 201, 0.25}));

// ---- real frames ----

core::Camera Primesense() { return core::Camera{525.0, 525.0, 319.5, 239.5, 640, 480}; }
core::Camera Phoxi() { return core::Camera{552.5, 552.5, 255.5, 191.75, 516, 386}; }

struct RealResult {
  double union_iou = 0;
  double outside_fraction = 0;  // predicted pixels outside the given segmask
  int count = 0;
};

RealResult SegmentReal(const std::string& depth_npy, const std::string& segmask_png,
                       const core::Camera& camera, const std::string& dump_name) {
  const core::DepthImage depth{testing::LoadNpyFloat32(depth_npy)};
  const core::Scene scene = Prepare(depth, camera);
  const InstanceMasks masks = Segment(scene, camera);
  CheckValid(masks, scene.height_m.size());
  const cv::Mat1b segmask = cv::imread(segmask_png, cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(segmask.size(), masks.labels.size());
  Dump(dump_name, scene, masks, segmask > 0);
  const cv::Mat1b predicted = masks.labels > 0;
  RealResult r;
  r.union_iou = Iou(predicted, segmask > 0);
  const int predicted_px = cv::countNonZero(predicted);
  r.outside_fraction =
      predicted_px == 0
          ? 0.0
          : static_cast<double>(cv::countNonZero(predicted & (segmask == 0))) / predicted_px;
  r.count = masks.count();
  std::cout << "[ measured ] " << dump_name << ": " << r.count << " instances, union IoU "
            << r.union_iou << ", outside segmask " << r.outside_fraction << "\n";
  return r;
}

class SegmentPclPrimesense : public ::testing::TestWithParam<int> {};

TEST_P(SegmentPclPrimesense, OneObjectOnTheTable) {
  const int i = GetParam();
  const std::string stem = kData + "/primesense/single_";
  const RealResult r = SegmentReal(stem + "depth_" + std::to_string(i) + ".npy",
                                   stem + "segmask_" + std::to_string(i) + ".png", Primesense(),
                                   "primesense_" + std::to_string(i));
  // Measured: one instance each; union IoU 0.83, 0.73, 0.88 (frame 1: 0.57 with a fixed 6 mm
  // floor margin, under which the object's flat bar lay; this table is flat to 0.3 mm, so the
  // margin is 2.5 mm); outside the segmask 0.17, 0.14, 0.10 (the GQ-CNN segmask is tighter than
  // the object's depth footprint and frames 1 and 2 lie 3 rows below it; no instance is on the
  // table or on the gripper fingers in the bottom corners).
  EXPECT_EQ(r.count, 1);
  EXPECT_GE(r.union_iou, 0.70);
  EXPECT_LT(r.outside_fraction, 0.25);
}

INSTANTIATE_TEST_SUITE_P(Frames, SegmentPclPrimesense, ::testing::Values(0, 1, 2));

TEST(SegmentPclPhoxi, ClutterHeapInABin) {
  const RealResult r = SegmentReal(kData + "/phoxi/clutter_depth_0.npy",
                                   kData + "/phoxi/clutter_segmask_0.png", Phoxi(), "phoxi_0");
  // Measured: 16 instances, union IoU 0.96, 3 % of the predicted pixels outside the segmask
  // (the bin's vertical walls, its sloped side walls and its rim are support).
  EXPECT_GE(r.count, 8);
  EXPECT_GE(r.union_iou, 0.85);
  EXPECT_LT(r.outside_fraction, 0.1);
}

}  // namespace
}  // namespace softgrasp::segmentation
