// Visibility marks of dataset scenes (docs/simulator.md): visible and amodal pixel counts, the
// visible fraction and the mostly-hidden flag, on a hand-built stack of boxes and on a dense bin.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "sim/dataset/dataset.h"
#include "sim/dataset/scene_gen.h"
#include "sim/render/render.h"
#include "tests/support/box_mesh.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;

PlacedObject PlaceBox(int id, double x_m, double y_m, double z_m, const Eigen::Vector3d& at_w) {
  const Eigen::Vector3d half_m = Eigen::Vector3d(x_m, y_m, z_m) / 2.0;
  auto object = MakeMeshObject(testing::CentredBoxMesh(half_m), {}, 0.5f, 500.0, "box");
  EXPECT_TRUE(object.ok()) << object.error().message;
  PlacedObject placed;
  placed.instance_id = id;
  placed.object = std::make_shared<const SimObject>(std::move(object).value());
  placed.world_from_object = Eigen::Isometry3d::Identity();
  placed.world_from_object.translation() = at_w;
  return placed;
}

// Renders `scene` as GenerateScene does (noise off: labels are the truth either way).
GeneratedScene RenderScene(SimScene scene, const RenderOptions& render) {
  GeneratedScene g;
  g.scene = std::move(scene);
  auto raycaster = SceneRaycaster::Build(g.scene);
  EXPECT_TRUE(raycaster.ok()) << raycaster.error().message;
  g.views = Render(raycaster.value(), render);
  return g;
}

void ExpectConsistent(const std::vector<ObjectVisibility>& visibility) {
  for (const ObjectVisibility& v : visibility) {
    EXPECT_GE(v.visible_fraction, 0.0) << "id " << v.instance_id;
    EXPECT_LE(v.visible_fraction, 1.0) << "id " << v.instance_id;
    EXPECT_LE(v.visible_px, v.amodal_px) << "id " << v.instance_id;
    EXPECT_EQ(v.mostly_hidden, v.visible_fraction < kMostlyHiddenVisibleFraction)
        << "id " << v.instance_id;
    if (v.amodal_px > 0) {
      EXPECT_DOUBLE_EQ(v.visible_fraction, static_cast<double>(v.visible_px) / v.amodal_px);
    }
  }
}

// Three boxes in the bin, the camera 0.55 m above: A (10 x 8 x 4 cm) on the floor, B (6 x 6 x
// 4 cm) resting on A's centre, and C (2 cm cube) inside A. B is seen whole; B's footprint
// (36 cm^2 at 0.47 m, nearer than A's top, 80 cm^2 at 0.51 m) hides about half of A; C is seen
// nowhere.
TEST(MeasureVisibility, StackedBoxesHideWhatIsBelow) {
  SimScene scene;
  scene.objects = {PlaceBox(1, 0.10, 0.08, 0.04, {0, 0, 0.02}),
                   PlaceBox(2, 0.06, 0.06, 0.04, {0, 0, 0.06}),
                   PlaceBox(3, 0.02, 0.02, 0.02, {0, 0, 0.02})};
  const RenderOptions render;
  const GeneratedScene g = RenderScene(scene, render);
  auto measured = MeasureVisibility(g, render);
  ASSERT_TRUE(measured.ok()) << measured.error().message;
  const std::vector<ObjectVisibility>& v = measured.value();
  ASSERT_EQ(v.size(), 3u);
  ExpectConsistent(v);
  const ObjectVisibility &a = v[0], &b = v[1], &c = v[2];
  EXPECT_EQ(a.instance_id, 1);
  // B: fully visible, isolated from above.
  EXPECT_GT(b.visible_px, 1000);
  EXPECT_EQ(b.visible_px, b.amodal_px);
  EXPECT_GE(b.visible_fraction, 0.97);
  EXPECT_FALSE(b.mostly_hidden);
  // A: B covers its middle. The top alone: 1 - (36 / 0.47^2) / (80 / 0.51^2) = 0.47; A's sides
  // (seen in perspective) add a little visible area.
  EXPECT_GT(a.amodal_px, b.amodal_px);
  EXPECT_GT(a.visible_fraction, 0.40);
  EXPECT_LT(a.visible_fraction, 0.60);
  EXPECT_FALSE(a.mostly_hidden);
  // C: inside A, never seen, yet it has an amodal extent (A is not in its solo render).
  EXPECT_EQ(c.visible_px, 0);
  EXPECT_GT(c.amodal_px, 100);
  EXPECT_EQ(c.visible_fraction, 0.0);
  EXPECT_TRUE(c.mostly_hidden);
}

// A single object dropped into the bin is fully visible.
TEST(MeasureVisibility, AnIsolatedObjectIsFullyVisible) {
  SceneSpec spec;
  spec.min_objects = 1;
  spec.max_objects = 1;
  auto generated = GenerateScene(spec, 7);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  ASSERT_EQ(generated.value().scene.objects.size(), 1u);
  auto measured = MeasureVisibility(generated.value(), spec.render);
  ASSERT_TRUE(measured.ok()) << measured.error().message;
  ASSERT_EQ(measured.value().size(), 1u);
  const ObjectVisibility& v = measured.value()[0];
  EXPECT_GT(v.visible_px, 500);
  EXPECT_GE(v.visible_fraction, 0.97);
  EXPECT_FALSE(v.mostly_hidden);
  ExpectConsistent(measured.value());
}

// A dense bin (24 objects, the scene of DenseBinsHeapUpAgainstTheWalls): objects hide each
// other. Visible counts equal the label histogram; several objects are partly hidden. Prints
// the cost of the measurement next to the cost of the scene.
TEST(MeasureVisibility, DenseBinObjectsHideEachOther) {
  SceneSpec spec;
  spec.min_objects = 24;
  spec.max_objects = 24;
  const auto t0 = std::chrono::steady_clock::now();
  auto generated = GenerateScene(spec, 11);
  const auto t1 = std::chrono::steady_clock::now();
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  const GeneratedScene& g = generated.value();
  auto measured = MeasureVisibility(g, spec.render);
  const auto t2 = std::chrono::steady_clock::now();
  ASSERT_TRUE(measured.ok()) << measured.error().message;
  const std::vector<ObjectVisibility>& v = measured.value();
  ASSERT_EQ(v.size(), g.scene.objects.size());
  ExpectConsistent(v);
  int partly_hidden = 0, mostly_hidden = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const int id = g.scene.objects[i].instance_id;
    EXPECT_EQ(v[i].instance_id, id);
    EXPECT_EQ(v[i].visible_px, cv::countNonZero(g.views.labels == id));
    partly_hidden += v[i].visible_fraction < 0.9 ? 1 : 0;
    mostly_hidden += v[i].mostly_hidden ? 1 : 0;
  }
  EXPECT_GE(partly_hidden, 3);
  const double scene_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
  const double measure_ms = std::chrono::duration<double, std::milli>(t2 - t1).count();
  std::printf(
      "dense scene: %zu objects, %d partly (< 0.9), %d mostly hidden; GenerateScene %.0f ms,"
      " MeasureVisibility %.0f ms\n",
      v.size(), partly_hidden, mostly_hidden, scene_ms, measure_ms);
  // Same scene, same counts.
  auto again = MeasureVisibility(g, spec.render);
  ASSERT_TRUE(again.ok());
  for (std::size_t i = 0; i < v.size(); ++i) {
    EXPECT_EQ(again.value()[i].amodal_px, v[i].amodal_px);
  }
}

// The manifest carries the marks per object, plus the threshold.
TEST(WriteSceneFiles, ManifestListsVisibilityPerObject) {
  SimScene scene;
  scene.objects = {PlaceBox(1, 0.10, 0.08, 0.04, {0, 0, 0.02}),
                   PlaceBox(2, 0.06, 0.06, 0.04, {0, 0, 0.06}),
                   PlaceBox(3, 0.02, 0.02, 0.02, {0, 0, 0.02})};
  SceneSpec spec;
  const GeneratedScene g = RenderScene(scene, spec.render);
  const softgrasp::testing::TempDir temp("visibility-manifest");
  const fs::path& dir = temp.path();
  ASSERT_FALSE(WriteSceneFiles(spec, g, dir, "scene").has_value());
  std::ifstream in(dir / "scene.json");
  const nlohmann::json manifest = nlohmann::json::parse(in);
  EXPECT_DOUBLE_EQ(manifest.at("visibility").at("mostly_hidden_below_fraction").get<double>(),
                   kMostlyHiddenVisibleFraction);
  const nlohmann::json& objects = manifest.at("objects");
  ASSERT_EQ(objects.size(), 3u);
  for (const nlohmann::json& o : objects) {
    const int id = o.at("instance_id").get<int>();
    const int visible = o.at("visible_px").get<int>();
    const int amodal = o.at("amodal_px").get<int>();
    EXPECT_EQ(visible, cv::countNonZero(g.views.labels == id));
    EXPECT_GE(amodal, visible);
    EXPECT_DOUBLE_EQ(o.at("visible_fraction").get<double>(),
                     amodal > 0 ? static_cast<double>(visible) / amodal : 0.0);
    EXPECT_EQ(o.at("mostly_hidden").get<bool>(), id == 3);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace softgrasp::sim
