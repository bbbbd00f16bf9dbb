// softgrasp-sim mesh-grasps, as a process: one JSON per mesh equal to the library's answer
// (timings aside), a preview PNG, repeated file names kept apart, a broken file reported in
// index.json and by the exit code while the others are still written; bad flags exit 2.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "service/mesh/mesh_io.h"
#include "tests/support/box_mesh.h"
#include "tests/support/temp_dir.h"
#include "tests/support/test_data.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

int RunMeshGrasps(const std::string& args) {
  const std::string cmd = std::string(SOFTGRASP_SIM_EXE) + " mesh-grasps " + args;
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(MeshGraspsCliTest, WritesOneAnswerPerMeshAndReportsTheBrokenOne) {
  const testing::TempDir dir("mesh-grasps-cli");
  fs::create_directories(dir / "in" / "other");
  const std::string cube =
      mesh::WriteObj(testing::CentredBoxMesh(Eigen::Vector3d(0.02, 0.015, 0.01)));
  std::ofstream(dir / "in" / "box.obj") << cube;
  std::ofstream(dir / "in" / "other" / "box.obj") << cube;
  std::ofstream(dir / "in" / "broken.obj") << "v 0 0 0\nf 1 2 3\n";
  const std::string out = (dir / "out").string();
  const std::string inputs = testing::TestData("meshes/dexnet_bar_clamp.obj") + " " +
                             (dir / "in" / "box.obj").string() + " " +
                             (dir / "in" / "other" / "box.obj").string() + " " +
                             (dir / "in" / "broken.obj").string();
  EXPECT_EQ(RunMeshGrasps(inputs + " --out " + out +
                          " --grasps 20 --robust-samples 3 --seed 4 --png"
                          " > /dev/null 2>&1"),
            1);
  const json index = json::parse(Slurp(dir / "out" / "index.json"));
  ASSERT_EQ(index["meshes"].size(), 4u);
  EXPECT_EQ(index["meshes"][0]["output"], "dexnet_bar_clamp.json");
  EXPECT_EQ(index["meshes"][1]["output"], "box.json");
  EXPECT_EQ(index["meshes"][2]["output"], "box-2.json");
  EXPECT_TRUE(index["meshes"][3].contains("error"));
  EXPECT_FALSE(index["meshes"][3].contains("output"));
  const json clamp = json::parse(Slurp(dir / "out" / "dexnet_bar_clamp.json"));
  EXPECT_GE(clamp["stable_poses"].size(), 2u);
  EXPECT_EQ(clamp["grasps"].size(), 20u);
  EXPECT_GT(fs::file_size(dir / "out" / "dexnet_bar_clamp.png"), 1000u);
  // Same seed, same answer (timings aside).
  const std::string again = (dir / "again").string();
  EXPECT_EQ(RunMeshGrasps(testing::TestData("meshes/dexnet_bar_clamp.obj") + " --out " + again +
                          " --grasps 20 --robust-samples 3 --seed 4 > /dev/null 2>&1"),
            0);
  json a = clamp, b = json::parse(Slurp(dir / "again" / "dexnet_bar_clamp.json"));
  a.erase("timing_ms");
  b.erase("timing_ms");
  EXPECT_EQ(a, b);
}

TEST(MeshGraspsCliTest, BadArgumentsExitTwo) {
  const std::string clamp = testing::TestData("meshes/dexnet_bar_clamp.obj");
  EXPECT_EQ(RunMeshGrasps("--out /tmp/x 2> /dev/null"), 2);                        // no mesh
  EXPECT_EQ(RunMeshGrasps(clamp + " 2> /dev/null"), 2);                            // no --out
  EXPECT_EQ(RunMeshGrasps(clamp + " --out /tmp/x --unit cm 2> /dev/null"), 2);     // bad unit
  EXPECT_EQ(RunMeshGrasps(clamp + " --out /tmp/x --grasps 0 2> /dev/null"), 2);    // out of range
  EXPECT_EQ(RunMeshGrasps(clamp + " --out /tmp/x --frobnicate 2> /dev/null"), 2);  // unknown
}

}  // namespace
}  // namespace softgrasp::sim
