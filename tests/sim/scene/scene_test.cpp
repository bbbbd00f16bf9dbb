#include "sim/scene/scene.h"

#include <gtest/gtest.h>

#include "service/mesh/mesh_check.h"

namespace softgrasp::sim {
namespace {

TEST(QuantizeStiffness, RoundsToTenLevelsAndClamps) {
  EXPECT_FLOAT_EQ(QuantizeStiffness(0.0f), 0.1f);
  EXPECT_FLOAT_EQ(QuantizeStiffness(0.14f), 0.1f);
  EXPECT_FLOAT_EQ(QuantizeStiffness(0.16f), 0.2f);
  EXPECT_FLOAT_EQ(QuantizeStiffness(0.94f), 0.9f);
  EXPECT_FLOAT_EQ(QuantizeStiffness(7.0f), 1.0f);
  EXPECT_FLOAT_EQ(QuantizeStiffness(std::nanf("")), 0.1f);
}

TEST(SupportMesh, TableIsOneClosedBoxWithTopAtZeroAndBinStandsOnATable) {
  Support table;
  table.kind = Support::Kind::kTable;
  const mesh::TriangleMesh t = SupportMesh(table);
  ASSERT_EQ(t.faces.size(), 12u);
  EXPECT_TRUE(mesh::CheckMesh(t).ok());
  double top = -1.0;
  for (const auto& v : t.vertices) top = std::max(top, v[2]);
  EXPECT_DOUBLE_EQ(top, 0.0);

  Support bin;
  const std::vector<SupportBox> boxes = SupportBoxes(bin);
  ASSERT_EQ(boxes.size(), 6u);
  EXPECT_DOUBLE_EQ(boxes[0].max_w.z(), -bin.thickness_m);  // table top under the bin
  EXPECT_DOUBLE_EQ(boxes[1].max_w.z(), 0.0);               // bin floor
  const mesh::TriangleMesh b = SupportMesh(bin);
  EXPECT_EQ(b.faces.size(), 6u * 12u);
  double wall_top = -1.0;
  for (const auto& v : b.vertices) wall_top = std::max(wall_top, v[2]);
  EXPECT_DOUBLE_EQ(wall_top, bin.wall_height_m);
  // The walls enclose the floor: every wall's inner face lies on the floor's border.
  EXPECT_DOUBLE_EQ(boxes[2].max_w.x(), -bin.inner_size_x_m / 2);
  EXPECT_DOUBLE_EQ(boxes[3].min_w.x(), bin.inner_size_x_m / 2);
  EXPECT_DOUBLE_EQ(boxes[4].max_w.y(), -bin.inner_size_y_m / 2);
  EXPECT_DOUBLE_EQ(boxes[5].min_w.y(), bin.inner_size_y_m / 2);
}

TEST(SimScene, FindAndRemoveByInstanceId) {
  SimScene scene;
  auto obj = std::make_shared<SimObject>();
  obj->category = "block";
  for (int id : {1, 2, 3}) scene.objects.push_back({id, obj, Eigen::Isometry3d::Identity()});
  ASSERT_NE(scene.Find(2), nullptr);
  EXPECT_TRUE(scene.Remove(2));
  EXPECT_EQ(scene.Find(2), nullptr);
  EXPECT_FALSE(scene.Remove(2));
  EXPECT_EQ(scene.objects.size(), 2u);
}

TEST(PlacedObjectToJson, WritesPoseAsPositionAndUnitQuaternion) {
  auto obj = std::make_shared<SimObject>();
  obj->category = "can";
  obj->mass_kg = 0.25;
  PlacedObject p{4, obj, Eigen::Isometry3d::Identity()};
  p.world_from_object.translate(Eigen::Vector3d(0.1, -0.2, 0.05));
  p.world_from_object.rotate(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  const nlohmann::json j = PlacedObjectToJson(p);
  EXPECT_EQ(j["instance_id"], 4);
  EXPECT_EQ(j["category"], "can");
  EXPECT_DOUBLE_EQ(j["position_m"][1].get<double>(), -0.2);
  EXPECT_NEAR(j["quaternion_xyzw"][2].get<double>(), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(j["quaternion_xyzw"][3].get<double>(), std::sqrt(0.5), 1e-12);
}

}  // namespace
}  // namespace softgrasp::sim
