// FuseInstances on hand-made label images: which PCL instances become objects, which pixels
// they take, their scores and ids.

#include "service/segmentation/fuse.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace softgrasp::segmentation {
namespace {

InstanceMasks Masks(const cv::Size& size, std::vector<std::pair<cv::Rect, float>> boxes) {
  InstanceMasks out;
  out.labels = cv::Mat1w(size, std::uint16_t{0});
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    out.labels(boxes[i].first).setTo(static_cast<int>(i + 1));
    out.scores.push_back(boxes[i].second);
  }
  return out;
}

const cv::Size kSize(640, 480);

TEST(FuseInstances, AddsWhatOnlyTheGeometryFoundAndKeepsTheModelsInstances) {
  // Model: a confident box A and an unconfident box B. PCL: A (a little wider), B, and C which
  // the model missed entirely.
  const InstanceMasks model =
      Masks(kSize, {{cv::Rect(100, 100, 60, 60), 0.8f}, {cv::Rect(300, 100, 40, 40), 0.1f}});
  const InstanceMasks pcl = Masks(kSize, {{cv::Rect(98, 98, 64, 64), 0.9f},
                                          {cv::Rect(300, 100, 40, 40), 0.9f},
                                          {cv::Rect(400, 300, 50, 30), 0.9f}});
  FuseParams params;
  std::vector<bool> from_geometry;
  const InstanceMasks fused = FuseInstances(model, pcl, params, &from_geometry);
  // A stays the model's (id 1, its own pixels only); B and C come from the geometry with the
  // geometry's score, B's pixels taken from the unconfident model instance.
  ASSERT_EQ(fused.count(), 3);
  EXPECT_EQ(fused.scores, (std::vector<float>{0.8f, params.geometry_score, params.geometry_score}));
  EXPECT_EQ(from_geometry, (std::vector<bool>{false, true, true}));
  EXPECT_EQ(cv::countNonZero(fused.labels == 1), 60 * 60);
  EXPECT_EQ(cv::countNonZero(fused.labels(cv::Rect(100, 100, 60, 60)) == 1), 60 * 60);
  // Equal scores: the larger area first (B, 1600 px, before C, 1500 px).
  EXPECT_EQ(cv::countNonZero(fused.labels == 2), 40 * 40);
  EXPECT_EQ(cv::countNonZero(fused.labels(cv::Rect(300, 100, 40, 40)) == 2), 40 * 40);
  EXPECT_EQ(cv::countNonZero(fused.labels == 3), 50 * 30);
  // The ring PCL adds around A (A covers 88 % of that PCL instance) is not an object.
  EXPECT_EQ(cv::countNonZero(fused.labels(cv::Rect(98, 98, 64, 64)) == 0), 64 * 64 - 60 * 60);
}

TEST(FuseInstances, APclInstanceMostlyInsideAConfidentOneAddsNothing) {
  // PCL merges the confident A with a neighbour: 1/3 of it is A (above the 0.2 limit).
  const InstanceMasks model = Masks(kSize, {{cv::Rect(100, 100, 40, 60), 0.9f}});
  const InstanceMasks pcl = Masks(kSize, {{cv::Rect(100, 100, 120, 60), 0.5f}});
  const InstanceMasks fused = FuseInstances(model, pcl);
  ASSERT_EQ(fused.count(), 1);
  EXPECT_EQ(cv::countNonZero(fused.labels == 1), 40 * 60);
  // With a looser limit the neighbour's 2/3 become an object of their own.
  FuseParams loose;
  loose.max_covered_fraction = 0.4;
  const InstanceMasks more = FuseInstances(model, pcl, loose);
  ASSERT_EQ(more.count(), 2);
  EXPECT_EQ(cv::countNonZero(more.labels == 2), 80 * 60);
}

TEST(FuseInstances, AgreementRuleAndSmallLeftovers) {
  // Model: unconfident instance over half of PCL's C. PCL: C alone.
  const InstanceMasks model = Masks(kSize, {{cv::Rect(400, 300, 25, 30), 0.1f}});
  const InstanceMasks pcl = Masks(kSize, {{cv::Rect(400, 300, 50, 30), 0.7f}});
  FuseParams agree;
  agree.min_model_iou = 0.6;  // IoU is 0.5: both methods must see it, they do not enough
  EXPECT_EQ(FuseInstances(model, pcl, agree).scores, std::vector<float>{0.1f});
  agree.min_model_iou = 0.5;
  EXPECT_EQ(FuseInstances(model, pcl, agree).scores, std::vector<float>{agree.geometry_score});
  // An unconfident model instance left with fewer than min_area_px pixels disappears.
  const InstanceMasks sliver =
      Masks(kSize, {{cv::Rect(400, 300, 52, 30), 0.1f}});  // 60 px stick out of C
  const InstanceMasks fused = FuseInstances(sliver, pcl);
  ASSERT_EQ(fused.count(), 1);
  EXPECT_EQ(cv::countNonZero(fused.labels == 1), 50 * 30);
}

TEST(FuseInstances, NoInstancesAndBadInput) {
  const InstanceMasks empty = Masks(kSize, {});
  EXPECT_EQ(FuseInstances(empty, empty).count(), 0);
  const InstanceMasks pcl = Masks(kSize, {{cv::Rect(10, 10, 50, 50), 0.7f}});
  EXPECT_EQ(FuseInstances(empty, pcl).count(), 1);  // the geometry alone
  EXPECT_THROW(FuseInstances(Masks(cv::Size(320, 240), {}), pcl), std::invalid_argument);
  InstanceMasks bad = pcl;
  bad.scores.clear();  // label 1 without a score
  EXPECT_THROW(FuseInstances(empty, bad), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::segmentation
