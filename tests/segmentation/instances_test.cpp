// The common instance type: compaction order and the per-instance statistics on an analytic scene.
#include "service/segmentation/instances.h"

#include <gtest/gtest.h>

#include "service/core/preprocess.h"
#include "tests/support/synthetic_scene.h"

namespace softgrasp::segmentation {
namespace {

TEST(Compact, OrdersByScoreThenAreaAndDropsSmallIds) {
  cv::Mat1w labels(10, 10, std::uint16_t{0});
  labels(cv::Rect(0, 0, 3, 3)) = 7;    // 9 px, score 0.2
  labels(cv::Rect(5, 5, 4, 4)) = 300;  // 16 px, score 0.9
  labels(cv::Rect(0, 6, 2, 2)) = 5;    // 4 px, score 0.9 (ties 300 on score, smaller)
  labels(9, 9) = 9;                    // 1 px: dropped
  const InstanceMasks m = Compact(labels, 2, [](int id) { return id == 7 ? 0.2 : 0.9; });
  ASSERT_EQ(m.count(), 3);
  EXPECT_EQ(m.labels(6, 6), 1);  // old 300
  EXPECT_EQ(m.labels(7, 0), 2);  // old 5
  EXPECT_EQ(m.labels(1, 1), 3);  // old 7
  EXPECT_EQ(m.labels(9, 9), 0);
  EXPECT_FLOAT_EQ(m.scores[0], 0.9f);
  EXPECT_FLOAT_EQ(m.scores[2], 0.2f);
}

TEST(DescribeInstances, MatchesTheAnalyticBox) {
  testing::SceneSpec spec;
  spec.camera_height_m = 0.6;
  spec.boxes = {{.x_m = 0.05,
                 .y_m = -0.02,
                 .size_x_m = 0.04,
                 .size_y_m = 0.06,
                 .height_m = 0.05,
                 .yaw_rad = 0,
                 .id = 1}};
  const testing::SyntheticScene synthetic = testing::RenderScene(spec);
  auto scene = core::Preprocess(synthetic.depth, synthetic.camera);
  ASSERT_TRUE(scene.ok());
  InstanceMasks masks;
  masks.labels = cv::Mat1w(synthetic.object_id.size(), std::uint16_t{0});
  masks.labels.setTo(1, synthetic.object_id == 1);
  masks.scores = {0.75f};
  cv::Mat1f deformability(masks.labels.size(), 0.0f);
  deformability.setTo(0.25f, masks.labels == 1);
  const auto infos = DescribeInstances(masks, scene.value(), synthetic.camera, deformability);
  ASSERT_EQ(infos.size(), 1u);
  const InstanceInfo& box = infos[0];
  EXPECT_EQ(box.id, 1);
  EXPECT_FLOAT_EQ(box.score, 0.75f);
  EXPECT_EQ(box.area_px, cv::countNonZero(masks.labels));
  // The top face is 0.55 m from the camera: 0.04 x 0.06 m -> about 38 x 57 px at f = 525.
  EXPECT_NEAR(box.bbox_px.width, 0.04 * 525 / 0.55, 3);
  EXPECT_NEAR(box.bbox_px.height, 0.06 * 525 / 0.55, 3);
  const cv::Point3d centre = testing::TableToCamera(spec, 0.05, -0.02, 0.05);
  EXPECT_NEAR(box.centroid_m[0], centre.x, 0.002);
  EXPECT_NEAR(box.centroid_m[1], centre.y, 0.002);
  EXPECT_NEAR(box.centroid_m[2], centre.z, 0.002);
  EXPECT_NEAR(box.top_height_m, 0.05, 0.002);
  ASSERT_TRUE(box.mean_deformability.has_value());
  EXPECT_NEAR(*box.mean_deformability, 0.25, 1e-6);
  EXPECT_FALSE(box.mean_stiffness.has_value());
}

TEST(DescribeInstances, RejectsMapsOfAnotherSize) {
  testing::SceneSpec spec;
  const testing::SyntheticScene synthetic = testing::RenderScene(spec);
  auto scene = core::Preprocess(synthetic.depth, synthetic.camera);
  ASSERT_TRUE(scene.ok());
  InstanceMasks masks;
  masks.labels = cv::Mat1w(synthetic.depth.depth_m.size(), std::uint16_t{0});
  EXPECT_THROW(DescribeInstances(masks, scene.value(), synthetic.camera, cv::Mat1f(3, 3, 0.0f)),
               std::invalid_argument);
}

TEST(DropCutByBorder, DropsInstancesOnTheEdgeAndKeepsOrderAndScores) {
  InstanceMasks m;
  m.labels = cv::Mat1w(20, 30, std::uint16_t{0});
  m.labels(cv::Rect(0, 5, 4, 6)) = 1;    // 6 px on the left column
  m.labels(cv::Rect(10, 5, 5, 5)) = 2;   // inside
  m.labels(cv::Rect(20, 17, 6, 3)) = 3;  // 6 px on the bottom row
  m.labels(cv::Rect(5, 0, 2, 2)) = 4;    // 2 px on the top row: below the limit
  m.scores = {0.9f, 0.8f, 0.7f, 0.6f};
  const InstanceMasks out = DropCutByBorder(m, 5);
  ASSERT_EQ(out.count(), 2);
  EXPECT_EQ(out.labels(7, 12), 1);
  EXPECT_EQ(out.labels(0, 5), 2);
  EXPECT_EQ(out.labels(7, 1), 0);
  EXPECT_EQ(out.labels(18, 22), 0);
  EXPECT_FLOAT_EQ(out.scores[0], 0.8f);
  EXPECT_FLOAT_EQ(out.scores[1], 0.6f);
  EXPECT_EQ(DropCutByBorder(m, 0).count(), 4);
}

}  // namespace
}  // namespace softgrasp::segmentation
