// End-to-end checks of the simulator on real catalogue objects: stiffness read off
// rendered pixels (not mesh vertices), and grasps executed on a catalogue bottle.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "sim/catalogue/catalogue.h"
#include "sim/grasp/execute.h"
#include "sim/render/render.h"

namespace softgrasp::sim {
namespace {

struct Upright {
  SimScene scene;
  std::shared_ptr<const SimObject> object;
  double bottom_z_o = 0.0;  ///< lowest vertex z in the object frame
};

// One catalogue object standing on a table at W's origin (bottom at z = 0), no physics.
Upright StandUpright(const std::string& category, std::uint64_t seed) {
  auto made = MakeCatalogueObject(category, ShapeSplit::kTrain, seed);
  EXPECT_TRUE(made.ok());
  Upright out;
  out.object = std::make_shared<const SimObject>(std::move(made).value());
  out.bottom_z_o = 1e9;
  for (const auto& v : out.object->mesh_o.vertices) out.bottom_z_o = std::min(out.bottom_z_o, v[2]);
  out.scene.support.kind = Support::Kind::kTable;
  PlacedObject placed{1, out.object, Eigen::Isometry3d::Identity()};
  placed.world_from_object.translation() = Eigen::Vector3d(0, 0, -out.bottom_z_o);
  out.scene.objects.push_back(placed);
  return out;
}

// A camera at `eye_w` looking along +y of W (image +u = +x, +v = -z).
Eigen::Isometry3d SideCamera(const Eigen::Vector3d& eye_w) {
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d::UnitX();   // x_C
  r.col(1) = -Eigen::Vector3d::UnitZ();  // y_C (image down)
  r.col(2) = Eigen::Vector3d::UnitY();   // z_C (optical axis)
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = r;
  pose.translation() = eye_w;
  return pose;
}

RenderedViews RenderScene(const SimScene& scene, const Eigen::Isometry3d& world_from_camera) {
  auto raycaster = SceneRaycaster::Build(scene);
  EXPECT_TRUE(raycaster.ok());
  RenderOptions options;
  options.world_from_camera = world_from_camera;
  return Render(raycaster.value(), options);
}

TEST(CatalogueScene, BottleCapPixelsAreHardAndBodyCentreIsSoft) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Upright bottle = StandUpright("bottle", seed);
    const auto& shape = bottle.object->shape;
    const double height = shape["height_m"].get<double>();

    // From above: the image centre sees the cap's top.
    const RenderedViews top = RenderScene(bottle.scene, OverheadCameraPose(0.55));
    const int cu = top.labels.cols / 2;
    const int cv = top.labels.rows / 2;
    ASSERT_EQ(top.labels(cv, cu), 1);
    EXPECT_GE(top.stiffness(cv, cu), 0.9f) << "seed " << seed;
    EXPECT_NEAR(top.depth.depth_m(cv, cu), 0.55 - height, 1e-4);

    // From the side at the body's mid height: the image centre sees the body's middle.
    const double mid = shape["body_mid_height_m"].get<double>();
    const RenderedViews side = RenderScene(bottle.scene, SideCamera({0, -0.4, mid}));
    ASSERT_EQ(side.labels(side.labels.rows / 2, side.labels.cols / 2), 1);
    EXPECT_LE(side.stiffness(side.labels.rows / 2, side.labels.cols / 2), 0.5f) << "seed " << seed;
  }
}

TEST(CatalogueScene, BoxFaceCentreIsSofterThanNearItsEdges) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Upright box = StandUpright("box", seed);
    const RenderedViews top = RenderScene(box.scene, OverheadCameraPose(0.55));
    const int cu = top.labels.cols / 2;
    const int cv = top.labels.rows / 2;
    ASSERT_EQ(top.labels(cv, cu), 1);
    // Walk right from the centre to the last pixel of the box's top face: 2 px in from the
    // edge is stiffer than the face centre.
    int edge_u = cu;
    while (edge_u + 1 < top.labels.cols && top.labels(cv, edge_u + 1) == 1) ++edge_u;
    ASSERT_GT(edge_u - cu, 5);
    EXPECT_LT(top.stiffness(cv, cu), top.stiffness(cv, edge_u - 2)) << "seed " << seed;
  }
}

TEST(CatalogueScene, SqueezingABottleBodyDeformsMoreThanItsCap) {
  core::Gripper gripper;
  gripper.opening_stroke_m = 0.09;  // wide enough for every bottle body (35-70 mm)
  gripper.closing_force_n = 10.0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Upright bottle = StandUpright("bottle", seed);
    const auto& shape = bottle.object->shape;
    auto raycaster = SceneRaycaster::Build(bottle.scene);
    ASSERT_TRUE(raycaster.ok());
    SimGrasp body{0.0, 0.0, shape["body_mid_height_m"].get<double>(), 0.0, 0.085};
    SimGrasp cap = body;
    cap.fingertip_height_m =
        shape["height_m"].get<double>() - shape["cap_height_m"].get<double>() / 2;
    cap.opening_m = 0.05;
    // Finger pads 15 mm tall: the contact patch stays inside the straight body (or the cap).
    gripper.finger_length_m = 0.015;
    auto on_body = ExecuteGrasp(bottle.scene, raycaster.value(), body, gripper);
    auto on_cap = ExecuteGrasp(bottle.scene, raycaster.value(), cap, gripper);
    ASSERT_TRUE(on_body.ok() && on_cap.ok());
    ASSERT_EQ(on_body.value().instance_id, 1) << on_body.value().reason;
    ASSERT_EQ(on_cap.value().instance_id, 1) << on_cap.value().reason;
    EXPECT_NEAR(on_body.value().contact_width_m, shape["body_diameter_m"].get<double>(), 1.5e-3);
    EXPECT_GT(on_body.value().deformation_rate, 10 * on_cap.value().deformation_rate)
        << "seed " << seed;
    EXPECT_GE(on_cap.value().stiffness_left, 0.9f);
    EXPECT_LE(on_body.value().stiffness_left, 0.5f);
  }
}

}  // namespace
}  // namespace softgrasp::sim
