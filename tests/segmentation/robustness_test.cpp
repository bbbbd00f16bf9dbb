// Odd inputs the service may be sent: tiny, thin, constant, noisy and mostly missing depth images
// of many sizes (fixed seeds). The PCL segmenter must answer every preprocessable one with a
// well-formed result (labels of the input's size, dense ids, scores in [0, 1]) and never crash.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "service/core/preprocess.h"
#include "service/segmentation/pcl_segmenter.h"

namespace softgrasp::segmentation {
namespace {

void ExpectWellFormed(const InstanceMasks& m, cv::Size size) {
  ASSERT_EQ(m.labels.size(), size);
  double max_id = 0;
  cv::minMaxLoc(m.labels, nullptr, &max_id);
  EXPECT_EQ(static_cast<int>(max_id), m.count());
  for (int id = 1; id <= m.count(); ++id) EXPECT_GT(cv::countNonZero(m.labels == id), 0) << id;
  for (float s : m.scores) EXPECT_TRUE(s >= 0.0f && s <= 1.0f);
}

core::DepthImage Make(cv::Size size, int kind, std::mt19937& rng) {
  core::DepthImage d{cv::Mat1f(size, 0.6f)};
  std::uniform_real_distribution<float> noise(-0.05f, 0.05f);
  std::bernoulli_distribution missing(0.7);
  for (int v = 0; v < size.height; ++v) {
    for (int u = 0; u < size.width; ++u) {
      float& z = d.depth_m(v, u);
      switch (kind) {
        case 0:
          break;  // constant: a bare table
        case 1:
          z += noise(rng);
          break;  // noise: no structure at all
        case 2:
          if (missing(rng)) z = NAN;
          break;  // mostly missing
        case 3:
          z = (u / 4 + v / 4) % 2 ? 0.5f : 0.6f;
          break;  // a 4 px checkerboard of blocks
        default:
          z = 0.3f + 0.001f * u;
          break;  // a steep ramp
      }
    }
  }
  return d;
}

TEST(SegmentPclRobustness, OddImagesGiveWellFormedResults) {
  std::mt19937 rng(7);
  int segmented = 0;
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(2, 3), cv::Size(1, 64), cv::Size(64, 1),
                              cv::Size(16, 16), cv::Size(97, 31), cv::Size(320, 240)}) {
    for (int kind = 0; kind < 5; ++kind) {
      const core::DepthImage depth = Make(size, kind, rng);
      core::Camera camera{.fx = 500,
                          .fy = 500,
                          .cx = (size.width - 1) / 2.0,
                          .cy = (size.height - 1) / 2.0,
                          .width = size.width,
                          .height = size.height};
      auto scene = core::Preprocess(depth, camera);
      if (!scene.ok()) continue;  // the service answers these 422 before segmenting
      auto masks = SegmentPcl(scene.value(), camera);
      ASSERT_TRUE(masks.ok()) << size << " kind " << kind << ": " << masks.error().message;
      ExpectWellFormed(masks.value(), size);
      if (kind == 0) {
        EXPECT_EQ(masks.value().count(), 0) << size;  // a bare table
      }
      ++segmented;
    }
  }
  EXPECT_GT(segmented, 10);
}

}  // namespace
}  // namespace softgrasp::segmentation
