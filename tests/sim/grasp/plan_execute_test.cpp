// Planning and execution share one gripper (core::Gripper, SI units): a grasp the planner opens
// to the gripper's stroke is one the simulator accepts and executes with that same gripper.
#include <gtest/gtest.h>

#include <memory>

#include "service/core/fge.h"
#include "service/core/preprocess.h"
#include "sim/grasp/execute.h"
#include "sim/render/render.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::sim {
namespace {

// A rigid 60 mm x 60 mm x 50 mm block on a table under the overhead camera: too wide for the
// default 50 mm stroke in every direction, graspable with an 85 mm one.
struct BlockScene {
  SimScene scene;
  RenderOptions render;
  RenderedViews views;
};

BlockScene MakeBlockScene() {
  BlockScene b;
  b.scene.support.kind = Support::Kind::kTable;
  auto block = std::make_shared<SimObject>();
  block->category = "block";
  block->mesh_o = testing::CentredBoxMesh(Eigen::Vector3d(0.03, 0.03, 0.025));
  block->vertex_stiffness.assign(block->mesh_o.vertices.size(), 1.0f);
  block->mass_kg = 0.1;
  PlacedObject placed;
  placed.instance_id = 1;
  placed.object = block;
  placed.world_from_object.translation() = Eigen::Vector3d(0.0, 0.0, 0.025);
  b.scene.objects.push_back(placed);
  auto raycaster = SceneRaycaster::Build(b.scene);
  EXPECT_TRUE(raycaster.ok());
  b.views = Render(raycaster.value(), b.render);
  return b;
}

TEST(PlanAndExecute, OneGripperForPlanningAndExecution) {
  const BlockScene b = MakeBlockScene();
  auto scene = core::Preprocess(b.views.depth, b.render.camera);
  ASSERT_TRUE(scene.ok()) << scene.error().message;

  const core::Gripper narrow;  // 50 mm stroke
  EXPECT_TRUE(core::DetectGraspsFge(scene.value(), b.render.camera, narrow).empty());

  core::Gripper wide;
  wide.opening_stroke_m = 0.085;
  const auto grasps = core::DetectGraspsFge(scene.value(), b.render.camera, wide);
  ASSERT_FALSE(grasps.empty());
  EXPECT_DOUBLE_EQ(grasps.front().opening_m, wide.opening_stroke_m);

  const SimGrasp grasp = SimGraspFromCamera(grasps.front(), b.render.world_from_camera);
  auto raycaster = SceneRaycaster::Build(b.scene);
  ASSERT_TRUE(raycaster.ok());
  auto executed = ExecuteGrasp(b.scene, raycaster.value(), grasp, wide);
  ASSERT_TRUE(executed.ok()) << executed.error().message;
  EXPECT_TRUE(executed.value().succeeded()) << executed.value().reason;
  EXPECT_NEAR(executed.value().contact_width_m, 0.06, 0.002);
  // The same grasp with another gripper is refused, not silently executed.
  EXPECT_FALSE(ExecuteGrasp(b.scene, raycaster.value(), grasp, narrow).ok());
}

}  // namespace
}  // namespace softgrasp::sim
