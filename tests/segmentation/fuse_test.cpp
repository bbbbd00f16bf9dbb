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
  // A stays the model's (id 1), grown to PCL's footprint of it (a 2 px ring); B and C come from
  // the geometry with the geometry's score, B's pixels taken from the unconfident model
  // instance.
  ASSERT_EQ(fused.count(), 3);
  EXPECT_EQ(fused.scores, (std::vector<float>{0.8f, params.geometry_score, params.geometry_score}));
  EXPECT_EQ(from_geometry, (std::vector<bool>{false, true, true}));
  EXPECT_EQ(cv::countNonZero(fused.labels == 1), 64 * 64);
  EXPECT_EQ(cv::countNonZero(fused.labels(cv::Rect(98, 98, 64, 64)) == 1), 64 * 64);
  // Equal scores: the larger area first (B, 1600 px, before C, 1500 px).
  EXPECT_EQ(cv::countNonZero(fused.labels == 2), 40 * 40);
  EXPECT_EQ(cv::countNonZero(fused.labels(cv::Rect(300, 100, 40, 40)) == 2), 40 * 40);
  EXPECT_EQ(cv::countNonZero(fused.labels == 3), 50 * 30);
  // Without the extension the ring PCL adds around A (A covers 88 % of that PCL instance) is
  // not an object of its own.
  FuseParams no_extension;
  no_extension.extend_min_inside_fraction = 2.0;
  const InstanceMasks plain = FuseInstances(model, pcl, no_extension);
  ASSERT_EQ(plain.count(), 3);
  EXPECT_EQ(cv::countNonZero(plain.labels == 1), 60 * 60);
  EXPECT_EQ(cv::countNonZero(plain.labels(cv::Rect(98, 98, 64, 64)) == 0), 64 * 64 - 60 * 60);
}

TEST(FuseInstances, APclInstanceMostlyInsideAConfidentOneAddsNothing) {
  // PCL merges the confident A with a neighbour: 1/3 of it is A (above the 0.2 limit).
  const InstanceMasks model = Masks(kSize, {{cv::Rect(100, 100, 40, 60), 0.9f}});
  const InstanceMasks pcl = Masks(kSize, {{cv::Rect(100, 100, 120, 60), 0.5f}});
  FuseParams params;
  params.extend_min_inside_fraction = 2.0;  // extension off: next test
  const InstanceMasks fused = FuseInstances(model, pcl, params);
  ASSERT_EQ(fused.count(), 1);
  EXPECT_EQ(cv::countNonZero(fused.labels == 1), 40 * 60);
  // With a looser limit the neighbour's 2/3 become an object of their own.
  FuseParams loose = params;
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

TEST(FuseInstances, APclInstanceAroundOneConfidentInstanceExtendsIt) {
  // The model found the raised middle (40 x 20) of an object whose PCL footprint is 80 x 40; an
  // unconfident model instance sits on part of the footprint and keeps its pixels.
  const InstanceMasks model =
      Masks(kSize, {{cv::Rect(220, 210, 40, 20), 0.7f}, {cv::Rect(200, 200, 10, 10), 0.1f}});
  const InstanceMasks pcl = Masks(kSize, {{cv::Rect(200, 200, 80, 40), 0.9f}});
  const InstanceMasks fused = FuseInstances(model, pcl);
  ASSERT_EQ(fused.count(), 1);  // the unconfident one (100 px) is below min_area_px
  EXPECT_EQ(fused.scores[0], 0.7f);
  EXPECT_EQ(cv::countNonZero(fused.labels == 1), 80 * 40 - 10 * 10);
  // Off: the model's instance as it was.
  FuseParams off;
  off.extend_min_inside_fraction = 2.0;
  EXPECT_EQ(cv::countNonZero(FuseInstances(model, pcl, off).labels == 1), 40 * 20);
  // A PCL cluster over two confident instances (two touching objects) extends neither.
  const InstanceMasks two =
      Masks(kSize, {{cv::Rect(200, 200, 30, 40), 0.7f}, {cv::Rect(250, 200, 30, 40), 0.6f}});
  const InstanceMasks merged = FuseInstances(two, pcl);
  EXPECT_EQ(cv::countNonZero(merged.labels == 1), 30 * 40);
  EXPECT_EQ(cv::countNonZero(merged.labels == 2), 30 * 40);
  // The price: a neighbour the model does not see at all, merged by PCL with a confident
  // instance (more than max_covered_fraction of the cluster), joins that instance.
  const InstanceMasks beside = Masks(kSize, {{cv::Rect(200, 200, 40, 40), 0.7f}});
  EXPECT_EQ(cv::countNonZero(FuseInstances(beside, pcl).labels == 1), 80 * 40);
  // A PCL instance holding only part of the confident instance extends nothing.
  const InstanceMasks half = Masks(kSize, {{cv::Rect(260, 210, 40, 20), 0.7f}});
  EXPECT_EQ(cv::countNonZero(FuseInstances(half, pcl).labels == 1), 40 * 20);
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
