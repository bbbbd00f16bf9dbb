#include "sim/dataset/dataset.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "sim/dataset/user_objects.h"
#include "sim/render/render.h"
#include "tests/support/temp_dir.h"
#include "tests/support/test_data.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Every regular file under `dir`, relative path -> bytes.
std::map<std::string, std::string> Snapshot(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = ReadAll(e.path());
  }
  return files;
}

// What a test writes goes under one scratch folder of this process, removed at exit.
const softgrasp::testing::TempDir& Scratch() {
  static const softgrasp::testing::TempDir dir("dataset-test");
  return dir;
}

// A folder that does not exist yet.
fs::path FreshDir(const std::string& name) { return Scratch() / ("dataset_" + name); }

SceneSpec SmallSpec() {
  SceneSpec spec;
  spec.min_objects = 2;
  spec.max_objects = 3;
  return spec;
}

bool SameMat(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

TEST(GenerateScene, SameSeedSameSceneDifferentSeedDifferentScene) {
  const SceneSpec spec = SmallSpec();
  auto a = GenerateScene(spec, 11);
  auto b = GenerateScene(spec, 11);
  auto c = GenerateScene(spec, 12);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok() && c.ok());
  EXPECT_TRUE(SameMat(a.value().views.depth.depth_m, b.value().views.depth.depth_m));
  EXPECT_TRUE(SameMat(a.value().views.labels, b.value().views.labels));
  ASSERT_EQ(a.value().scene.objects.size(), b.value().scene.objects.size());
  for (std::size_t i = 0; i < a.value().scene.objects.size(); ++i) {
    EXPECT_TRUE(a.value().scene.objects[i].world_from_object.matrix() ==
                b.value().scene.objects[i].world_from_object.matrix());
  }
  EXPECT_FALSE(SameMat(a.value().views.labels, c.value().views.labels));
}

TEST(GenerateScene, MapsAgreeWithTheObjectsInTheScene) {
  auto generated = GenerateScene(SmallSpec(), 5);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  const GeneratedScene& g = generated.value();
  ASSERT_GE(g.scene.objects.size(), 1u);
  int object_pixels = 0;
  for (int v = 0; v < g.views.labels.rows; ++v) {
    for (int u = 0; u < g.views.labels.cols; ++u) {
      const int id = g.views.labels(v, u);
      const float s = g.views.stiffness(v, u);
      if (id == 0) {
        EXPECT_EQ(s, 0.0f);
        EXPECT_EQ(g.views.deformability(v, u), 0.0f);
        continue;
      }
      ++object_pixels;
      ASSERT_NE(g.scene.Find(id), nullptr) << "label " << id << " is not an object in the scene";
      EXPECT_GE(s, kMinStiffness);
      EXPECT_LE(s, kMaxStiffness);
      EXPECT_FLOAT_EQ(g.views.deformability(v, u), 1.0f - s);
    }
  }
  EXPECT_GT(object_pixels, 500);  // objects of a few centimetres at 0.55 m cover many pixels
  // Objects rest in the bin, below the camera: every object pixel is nearer than the bin floor.
  const double floor_depth_m = 0.55;
  for (int v = 0; v < g.views.labels.rows; v += 7) {
    for (int u = 0; u < g.views.labels.cols; u += 7) {
      if (g.views.labels(v, u) != 0) {
        EXPECT_LT(g.views.depth.depth_m(v, u), floor_depth_m);
      }
    }
  }
}

TEST(GenerateScene, NoiseTouchesDepthOnlyAndMakesHoles) {
  SceneSpec clean = SmallSpec();
  SceneSpec noisy = clean;
  noisy.render.noise.enabled = true;
  auto a = GenerateScene(clean, 3);
  auto b = GenerateScene(noisy, 3);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(SameMat(a.value().views.labels, b.value().views.labels));
  EXPECT_TRUE(SameMat(a.value().views.stiffness, b.value().views.stiffness));
  EXPECT_FALSE(SameMat(a.value().views.depth.depth_m, b.value().views.depth.depth_m));
  const cv::Mat1f& d = b.value().views.depth.depth_m;
  int missing = 0;
  for (const float z : d) missing += std::isnan(z) ? 1 : 0;
  EXPECT_GT(missing, 0);
}

TEST(GenerateScene, FractalObjectsCarryTheirConstantStiffness) {
  SceneSpec spec;
  spec.min_objects = 1;
  spec.max_objects = 2;
  spec.fractal_probability = 1.0;
  spec.fractal_stiffness = 0.7f;
  spec.fractal.num_points = 3000;
  auto generated = GenerateScene(spec, 21);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  const GeneratedScene& g = generated.value();
  ASSERT_GE(g.scene.objects.size(), 1u);
  for (const PlacedObject& p : g.scene.objects) EXPECT_EQ(p.object->category, "fractal");
  int seen = 0;
  for (int v = 0; v < g.views.labels.rows; ++v) {
    for (int u = 0; u < g.views.labels.cols; ++u) {
      if (g.views.labels(v, u) == 0) continue;
      ++seen;
      EXPECT_FLOAT_EQ(g.views.stiffness(v, u), 0.7f);
    }
  }
  EXPECT_GT(seen, 0);
}

// Dense bins: 15-30 objects heap up until the pile reaches the walls. With 24 objects in the
// default 0.40 x 0.30 m bin, most stay in the bin, objects rest against each of the four walls,
// and the heap rises above the 0.10 m walls. (Five objects reach two walls in this scene.)
TEST(GenerateScene, DenseBinsHeapUpAgainstTheWalls) {
  SceneSpec spec;
  spec.min_objects = 24;
  spec.max_objects = 24;
  const auto generated = GenerateScene(spec, 11);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  const SimScene& scene = generated.value().scene;
  EXPECT_GE(scene.objects.size(), 15u);
  const double half_x = spec.support.inner_size_x_m / 2, half_y = spec.support.inner_size_y_m / 2;
  constexpr double kTouchM = 0.01;     // a vertex this close to a wall's inner face rests on it
  std::array<bool, 4> wall_touched{};  // -x, +x, -y, +y
  double top_m = 0;
  for (const PlacedObject& p : scene.objects) {
    for (const auto& v : p.object->mesh_o.vertices) {
      const Eigen::Vector3d w = p.world_from_object * Eigen::Vector3d(v[0], v[1], v[2]);
      wall_touched[0] = wall_touched[0] || w.x() < -half_x + kTouchM;
      wall_touched[1] = wall_touched[1] || w.x() > half_x - kTouchM;
      wall_touched[2] = wall_touched[2] || w.y() < -half_y + kTouchM;
      wall_touched[3] = wall_touched[3] || w.y() > half_y - kTouchM;
      top_m = std::max(top_m, w.z());
    }
  }
  for (int i = 0; i < 4; ++i)
    EXPECT_TRUE(wall_touched[static_cast<std::size_t>(i)]) << "wall " << i;
  EXPECT_GT(top_m, 0.12) << "no heap";
}

TEST(ValidateSceneSpec, NamesTheFieldAtFault) {
  SceneSpec spec;
  spec.max_objects = kMaxObjectsPerScene + 1;
  ASSERT_TRUE(ValidateSceneSpec(spec));
  EXPECT_EQ(ValidateSceneSpec(spec)->field, "objects");
  spec = SceneSpec{};
  spec.fractal_probability = 1.5;
  EXPECT_EQ(ValidateSceneSpec(spec)->field, "fractal_probability");
  spec = SceneSpec{};
  spec.fractal_stiffness = 0.0f;
  EXPECT_EQ(ValidateSceneSpec(spec)->field, "fractal_stiffness");
  spec = SceneSpec{};
  spec.categories = {"bottle", "teapot"};
  EXPECT_EQ(ValidateSceneSpec(spec)->field, "categories");
  EXPECT_FALSE(GenerateScene(spec, 1).ok());
}

TEST(SceneSeed, TrainAndValStreamsDiffer) {
  EXPECT_EQ(SceneSeed(7, 0, ShapeSplit::kTrain), SceneSeed(7, 0, ShapeSplit::kTrain));
  EXPECT_NE(SceneSeed(7, 0, ShapeSplit::kTrain), SceneSeed(7, 0, ShapeSplit::kVal));
  EXPECT_NE(SceneSeed(7, 0, ShapeSplit::kTrain), SceneSeed(7, 1, ShapeSplit::kTrain));
}

TEST(Encodings, DepthInMillimetresAndUnitMapsInBytes) {
  cv::Mat1f depth(1, 5);
  depth << 0.5554f, std::nanf(""), 0.0f, 70.0f, 1.0f;
  const cv::Mat1w mm = DepthToMillimetres(depth);
  EXPECT_EQ(mm(0, 0), 555);
  EXPECT_EQ(mm(0, 1), 0);
  EXPECT_EQ(mm(0, 2), 0);
  EXPECT_EQ(mm(0, 3), 0);
  EXPECT_EQ(mm(0, 4), 1000);
  cv::Mat1f unit(1, 4);
  unit << 0.0f, 0.5f, 1.0f, 2.0f;
  const cv::Mat1b bytes = UnitToByte(unit);
  EXPECT_EQ(bytes(0, 0), 0);
  EXPECT_EQ(bytes(0, 1), 128);
  EXPECT_EQ(bytes(0, 2), 255);
  EXPECT_EQ(bytes(0, 3), 255);
}

// Array tasks (Slurm): three tasks, run in any order into one folder, then merged, give the
// files and the index of one process byte for byte; a task beyond N is refused.
TEST(GenerateDataset, ArrayTasksMergeIntoTheBytesOfOneProcess) {
  DatasetParams params;
  params.scenes = 4;
  params.seed = 21;
  params.shard_size = 3;
  params.spec = SmallSpec();
  params.out_dir = FreshDir("whole");
  ASSERT_TRUE(GenerateDataset(params).ok());
  const fs::path split = FreshDir("split");
  params.out_dir = split;
  for (int k : {2, 0, 1}) {
    params.task = {k, 3};
    int done = 0;
    auto index = GenerateDataset(params, [&done](int d) { done = d; });
    ASSERT_TRUE(index.ok()) << index.error().message;
    EXPECT_EQ(index.value().filename(), "index.task-" + std::to_string(k) + "-of-3.json");
    EXPECT_EQ(done, k == 2 ? 2 : 1);  // 4 scenes: 1 + 1 + 2
  }
  ASSERT_TRUE(MergeTaskIndexes(split).ok());
  auto merged = Snapshot(split);
  for (int k = 0; k < 3; ++k) merged.erase("index.task-" + std::to_string(k) + "-of-3.json");
  EXPECT_EQ(merged, Snapshot(FreshDir("whole")));
  params.task = {3, 3};
  EXPECT_EQ(GenerateDataset(params).error().field, "task");
}

TEST(GenerateDataset, WritesShardsThatDecodeAndRepeatByteForByte) {
  DatasetParams params;
  params.scenes = 3;
  params.seed = 9;
  params.shard_size = 2;
  params.spec = SmallSpec();
  params.spec.render.noise.enabled = true;
  const fs::path dir_a = FreshDir("a");
  params.out_dir = dir_a;
  auto index = GenerateDataset(params);
  ASSERT_TRUE(index.ok()) << index.error().message;
  EXPECT_EQ(index.value(), dir_a / "index.json");
  params.out_dir = FreshDir("b");
  ASSERT_TRUE(GenerateDataset(params).ok());
  const auto a = Snapshot(dir_a);
  const auto b = Snapshot(params.out_dir);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.size(), 1u + 3u * 5u);
  ASSERT_TRUE(a.count("shard_0001/scene_000002_depth.png"));

  const nlohmann::json idx = nlohmann::json::parse(a.at("index.json"));
  ASSERT_EQ(idx["entries"].size(), 3u);
  EXPECT_EQ(idx["split"], "train");
  const nlohmann::json manifest = nlohmann::json::parse(a.at("shard_0000/scene_000001.json"));
  EXPECT_EQ(manifest["split"], "train");
  EXPECT_EQ(manifest["camera"]["width"], 640);
  EXPECT_TRUE(manifest["noise"]["enabled"].get<bool>());
  ASSERT_GE(manifest["objects"].size(), 1u);
  EXPECT_TRUE(manifest["objects"][0].contains("shape"));

  const fs::path dir = params.out_dir / "shard_0000";
  const cv::Mat depth = cv::imread((dir / "scene_000001_depth.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat stiffness =
      cv::imread((dir / "scene_000001_stiffness.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat deform =
      cv::imread((dir / "scene_000001_deformability.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat labels =
      cv::imread((dir / "scene_000001_labels.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(depth.type(), CV_16UC1);
  ASSERT_EQ(stiffness.type(), CV_8UC1);
  ASSERT_EQ(deform.type(), CV_8UC1);
  ASSERT_EQ(labels.type(), CV_16UC1);
  EXPECT_EQ(depth.cols, 640);
  EXPECT_EQ(depth.rows, 480);
  // Object pixels: stiffness + deformability = 255 (1 - s rounds complementarily); elsewhere 0.
  for (int v = 0; v < labels.rows; v += 3) {
    for (int u = 0; u < labels.cols; u += 3) {
      const int s = stiffness.at<std::uint8_t>(v, u);
      const int d = deform.at<std::uint8_t>(v, u);
      if (labels.at<std::uint16_t>(v, u) == 0) {
        EXPECT_EQ(s + d, 0);
      } else {
        EXPECT_NEAR(s + d, 255, 1);
      }
    }
  }
}

TEST(GenerateDataset, ValSplitUsesOtherScenesAndSaysSo) {
  DatasetParams params;
  params.scenes = 1;
  params.seed = 9;
  params.spec = SmallSpec();
  params.spec.split = ShapeSplit::kVal;
  params.out_dir = FreshDir("val");
  ASSERT_TRUE(GenerateDataset(params).ok());
  const nlohmann::json manifest =
      nlohmann::json::parse(ReadAll(params.out_dir / "shard_0000" / "scene_000000.json"));
  EXPECT_EQ(manifest["split"], "val");
  EXPECT_EQ(manifest["scene_seed"].get<std::uint64_t>(), SceneSeed(9, 0, ShapeSplit::kVal));
  for (const auto& object : manifest["objects"]) EXPECT_EQ(object["shape"]["split"], "val");
}

TEST(GenerateDataset, RejectsBadParams) {
  DatasetParams params;
  params.out_dir = FreshDir("bad");
  params.scenes = 0;
  EXPECT_EQ(GenerateDataset(params).error().field, "scenes");
  params.scenes = 1;
  params.shard_size = 0;
  EXPECT_EQ(GenerateDataset(params).error().field, "shard_size");
  params.shard_size = 10;
  params.out_dir = "/proc/softgrasp_cannot_write_here";
  EXPECT_EQ(GenerateDataset(params).error().field, "out");
}

// The command line: same arguments twice -> the same bytes; bad arguments -> exit code 2.
TEST(SimCli, GenerateIsDeterministicAndRejectsBadArguments) {
  const fs::path a = FreshDir("cli_a");
  const fs::path b = FreshDir("cli_b");
  const std::string exe = SOFTGRASP_SIM_EXE;
  const std::string args = " generate --scenes 2 --seed 4 --objects 1-2 --support table";
  ASSERT_EQ(std::system((exe + args + " --out " + a.string() + " > /dev/null").c_str()), 0);
  ASSERT_EQ(std::system((exe + args + " --out " + b.string() + " > /dev/null").c_str()), 0);
  EXPECT_EQ(Snapshot(a), Snapshot(b));
  const nlohmann::json manifest =
      nlohmann::json::parse(ReadAll(a / "shard_0000" / "scene_000000.json"));
  EXPECT_EQ(manifest["support"]["kind"], "table");
  for (const char* bad :
       {" generate --seed 1 --out /tmp/x", " generate --scenes 1 --objects 0-3 --out /tmp/x",
        " generate --scenes 1 --split test --out /tmp/x", " generate --scenes 1",
        " generate --scenes 1 --scenes 2 --out /tmp/x",
        " generate --scenes 1 --out /tmp/x --what 1", " generate --scenes 1 --out",
        " generate --scenes 1 --out /tmp/x --categories brush,mop",
        " generate --scenes 1 --out /tmp/x --categories brush,"}) {
    const int status = std::system((exe + bad + " > /dev/null 2>&1").c_str());
    EXPECT_EQ(WEXITSTATUS(status), 2) << bad;
  }
}

// --categories: only the named categories are drawn (brush piles, sponge-packed bins).
TEST(SimCli, GenerateDrawsOnlyTheListedCategories) {
  const fs::path dir = FreshDir("cli_categories");
  const std::string cmd = std::string(SOFTGRASP_SIM_EXE) +
                          " generate --scenes 3 --seed 9 --objects 3-4 --categories sponge,brush" +
                          " --out " + dir.string() + " > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const nlohmann::json index = nlohmann::json::parse(ReadAll(dir / "index.json"));
  EXPECT_EQ(index["spec"]["categories"], nlohmann::json::array({"sponge", "brush"}));
  int objects = 0;
  for (const auto& entry : index["entries"]) {
    for (const auto& c : entry["categories"]) {
      EXPECT_TRUE(c == "sponge" || c == "brush") << c;
      ++objects;
    }
  }
  EXPECT_GE(objects, 9);
}

}  // namespace
}  // namespace softgrasp::sim

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;

// A 4 cm cube, OBJ text, corners numbered x + 2y + 4z.
constexpr const char* kCubeObj =
    "v 0 0 0\nv 0.04 0 0\nv 0 0.04 0\nv 0.04 0.04 0\nv 0 0 0.04\nv 0.04 0 0.04\nv 0 0.04 0.04\n"
    "v 0.04 0.04 0.04\n"
    "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\n"
    "f 2 4 8\nf 2 8 6\n";

fs::path WriteText(const std::string& name, const std::string& text) {
  const fs::path path = Scratch() / name;
  std::ofstream(path) << text;
  return path;
}

TEST(UserObjects, ParseArgumentForms) {
  auto plain = ParseUserObjectArg("/a/b.obj");
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain.value().mesh_path, "/a/b.obj");
  EXPECT_FLOAT_EQ(plain.value().stiffness, 0.5f);
  auto constant = ParseUserObjectArg("/a/b.ply:0.8");
  ASSERT_TRUE(constant.ok());
  EXPECT_FLOAT_EQ(constant.value().stiffness, 0.8f);
  auto file = ParseUserObjectArg("/a/b.stl:/a/b.json");
  ASSERT_TRUE(file.ok());
  EXPECT_EQ(file.value().stiffness_path, "/a/b.json");
  EXPECT_EQ(ParseUserObjectArg("/a/b.obj:1.5").error().field, "stiffness");
  EXPECT_EQ(ParseUserObjectArg(":0.5").error().field, "mesh_path");
}

TEST(UserObjects, LoadsConstantAndPerVertexStiffness) {
  const fs::path cube = WriteText("user_cube.obj", kCubeObj);
  UserObjectSpec spec;
  spec.mesh_path = cube;
  spec.stiffness = 0.4f;
  spec.density_kg_m3 = 1000.0;
  auto object = LoadUserObject(spec);
  ASSERT_TRUE(object.ok()) << object.error().message;
  EXPECT_EQ(object.value().category, "user");
  EXPECT_NEAR(object.value().mass_kg, 0.064, 1e-9);  // (0.04 m)^3 * 1000 kg/m^3
  for (const float s : object.value().vertex_stiffness) EXPECT_FLOAT_EQ(s, 0.4f);

  spec.stiffness_path =
      WriteText("user_cube.json", R"({"vertex_stiffness": [1, 1, 1, 1, 0.2, 0.2, 0.2, 0.2]})");
  auto graded = LoadUserObject(spec);
  ASSERT_TRUE(graded.ok()) << graded.error().message;
  EXPECT_FLOAT_EQ(graded.value().vertex_stiffness[0], 1.0f);
  EXPECT_FLOAT_EQ(graded.value().vertex_stiffness[7], 0.2f);
}

TEST(UserObjects, BadFilesGiveClearErrors) {
  UserObjectSpec spec;
  spec.mesh_path = "/nonexistent/softgrasp.obj";
  EXPECT_EQ(LoadUserObject(spec).error().field, "mesh_path");
  spec.mesh_path = WriteText("user_broken.obj", "v 0 0 0\nf 1 2 3\n");
  EXPECT_EQ(LoadUserObject(spec).error().field, "mesh_path");
  spec.mesh_path = WriteText("user_cube2.obj", kCubeObj);
  spec.stiffness_path = WriteText("user_bad.json", R"({"vertex_stiffness": "hard"})");
  EXPECT_EQ(LoadUserObject(spec).error().field, "stiffness_path");
  spec.stiffness_path = WriteText("user_short.json", R"({"vertex_stiffness": [1, 1]})");
  EXPECT_EQ(LoadUserObject(spec).error().field, "vertex_stiffness");
  spec.stiffness_path = WriteText("user_notjson.json", "{{{");
  EXPECT_EQ(LoadUserObject(spec).error().field, "stiffness_path");
}

TEST(UserObjects, JoinTheSceneDraw) {
  UserObjectSpec user;
  user.mesh_path = WriteText("user_cube3.obj", kCubeObj);
  user.stiffness = 0.3f;
  auto object = LoadUserObject(user);
  ASSERT_TRUE(object.ok());
  SceneSpec spec;
  spec.min_objects = 6;
  spec.max_objects = 6;
  spec.categories = {"block"};
  spec.user_objects = {std::make_shared<const SimObject>(object.value())};
  auto generated = GenerateScene(spec, 2);
  ASSERT_TRUE(generated.ok()) << generated.error().message;
  int users = 0;
  for (const PlacedObject& p : generated.value().scene.objects) {
    EXPECT_TRUE(p.object->category == "user" || p.object->category == "block")
        << p.object->category;
    users += p.object->category == "user" ? 1 : 0;
  }
  EXPECT_GT(users, 0);  // 6 draws from {block, user}: seed 2 draws at least one user cube
}

}  // namespace
}  // namespace softgrasp::sim

namespace softgrasp::sim {
namespace {

// A real mesh exported as a triangle soup (Dex-Net bar clamp, tests/data): welded, it is a
// closed solid and joins the catalogue as a user object.
TEST(UserObjects, WeldsARealTriangleSoupIntoAClosedSolid) {
  UserObjectSpec spec;
  spec.mesh_path = testing::TestData("meshes/dexnet_bar_clamp.obj");
  spec.stiffness = 0.8f;
  auto object = LoadUserObject(spec);
  ASSERT_TRUE(object.ok()) << object.error().message;
  EXPECT_EQ(object.value().category, "user");
  EXPECT_LT(object.value().mesh_o.vertices.size(), 1428u);
  EXPECT_EQ(object.value().mesh_o.faces.size(), 476u);
  EXPECT_EQ(object.value().shape["welded_vertices"].get<std::size_t>(),
            1428u - object.value().mesh_o.vertices.size());
  EXPECT_GT(object.value().mass_kg, 0.0);
}

}  // namespace
}  // namespace softgrasp::sim

namespace softgrasp::sim {
namespace {

bool SameBytes(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

// A manifest holds the whole spec: the scene it describes can be rebuilt exactly.
TEST(SceneSpecJson, AManifestRebuildsItsSceneExactly) {
  SceneSpec spec;
  spec.min_objects = 2;
  spec.max_objects = 4;
  spec.split = ShapeSplit::kVal;
  spec.support.kind = Support::Kind::kTable;
  spec.render.noise.enabled = true;
  spec.render.world_from_camera = OverheadCameraPose(0.6);
  spec.fractal_probability = 0.3;
  spec.fractal_stiffness = 0.4f;
  spec.fractal.num_points = 3000;
  auto first = GenerateScene(spec, 77);
  ASSERT_TRUE(first.ok()) << first.error().message;
  const nlohmann::json manifest =
      nlohmann::json::parse(SceneManifest(spec, first.value()).dump());  // through text
  auto parsed = SceneSpecFromJson(manifest["spec"]);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  auto again = GenerateScene(parsed.value(), manifest["scene_seed"].get<std::uint64_t>());
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(SameBytes(first.value().views.depth.depth_m, again.value().views.depth.depth_m));
  EXPECT_TRUE(SameBytes(first.value().views.labels, again.value().views.labels));
  EXPECT_EQ(SceneSpecToJson(parsed.value()), manifest["spec"]);
}

TEST(SceneSpecJson, BrokenSpecsNameTheKey) {
  const nlohmann::json good = SceneSpecToJson(SceneSpec{});
  ASSERT_TRUE(SceneSpecFromJson(good).ok());
  nlohmann::json j = good;
  j.erase("noise");
  EXPECT_EQ(SceneSpecFromJson(j).error().code, core::ErrorCode::kInvalidArgument);
  j = good;
  j["objects"] = "three";
  EXPECT_EQ(SceneSpecFromJson(j).error().field, "objects");
  j = good;
  j["split"] = "test";
  EXPECT_EQ(SceneSpecFromJson(j).error().field, "split");
  j = good;
  j["camera"]["quaternion_xyzw"] = {0, 0, 0, 2};
  EXPECT_EQ(SceneSpecFromJson(j).error().code, core::ErrorCode::kInvalidArgument);
  j = good;
  j["camera"]["width"] = 0;
  EXPECT_EQ(SceneSpecFromJson(j).error().field, "camera.width");
  j = good;
  j["user_objects"] = 2;
  EXPECT_EQ(SceneSpecFromJson(j).error().code, core::ErrorCode::kUnprocessable);
  EXPECT_FALSE(SceneSpecFromJson(nlohmann::json::array()).ok());
}

}  // namespace
}  // namespace softgrasp::sim

namespace softgrasp::sim {
namespace {

TEST(SimCli, CameraHeightAndIntrinsicsAreConfigurable) {
  const softgrasp::testing::TempDir temp("cli-camera");
  const std::filesystem::path out = temp / "out";
  const std::string exe = SOFTGRASP_SIM_EXE;
  const std::string intr = testing::TestData("gqcnn/primesense/primesense.intr");
  const std::string args =
      " generate --scenes 1 --seed 3 --objects 1 --noise off --camera-height 0.7"
      " --intrinsics " +
      intr + " --out " + out.string();
  ASSERT_EQ(std::system((exe + args + " > /dev/null").c_str()), 0);
  std::ifstream in(out / "shard_0000" / "scene_000000.json");
  const nlohmann::json manifest = nlohmann::json::parse(in);
  EXPECT_DOUBLE_EQ(manifest["camera"]["fx"].get<double>(), 525.0);
  EXPECT_DOUBLE_EQ(manifest["camera"]["world_from_camera"]["position_m"][2].get<double>(), 0.7);
  // The image corner sees the table the bin stands on: 0.7 m down to the bin floor (z = 0) plus
  // the 20 mm floor thickness.
  const cv::Mat depth =
      cv::imread((out / "shard_0000" / "scene_000000_depth.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(depth.at<std::uint16_t>(0, 0), 720);
  for (const char* bad :
       {" --camera-height 0", " --intrinsics /nonexistent.intr", " --intrinsics /etc/hostname"}) {
    const int status = std::system(
        (exe + " generate --scenes 1 --out " + out.string() + bad + " > /dev/null 2>&1").c_str());
    EXPECT_EQ(WEXITSTATUS(status), 2) << bad;
  }
}

}  // namespace
}  // namespace softgrasp::sim
