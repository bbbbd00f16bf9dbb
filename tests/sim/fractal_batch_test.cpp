#include "sim/fractal_batch.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "service/mesh/mesh_check.h"
#include "service/mesh/mesh_io.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A folder that does not exist yet, under one scratch folder of this process removed at exit.
fs::path FreshDir(const std::string& name) {
  static const softgrasp::testing::TempDir scratch("fractal-batch-test");
  return scratch / name;
}

TEST(FractalBatchTest, WritesClosedMeshesAndAnIndex) {
  FractalBatchParams params;
  params.count = 4;
  params.seed = 100;
  params.model.num_points = 3000;
  params.format = mesh::MeshFormat::kPlyBinary;
  params.out_dir = FreshDir("batch");
  int last_progress = 0;
  auto index = GenerateFractalBatch(params, [&](int done) { last_progress = done; });
  ASSERT_TRUE(index.ok()) << index.error().message;
  EXPECT_EQ(last_progress, 4);
  const auto doc = nlohmann::json::parse(Slurp(index.value()));
  ASSERT_EQ(doc["models"].size(), 4u);
  for (int i = 0; i < 4; ++i) {
    const auto& entry = doc["models"][static_cast<std::size_t>(i)];
    EXPECT_EQ(entry["seed"], 100 + i);
    auto read = mesh::ReadMesh(Slurp(params.out_dir / entry["file"].get<std::string>()));
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read.value().faces.size(), entry["faces"].get<std::size_t>());
    EXPECT_TRUE(mesh::CheckMesh(read.value()).ok());
  }
}

// Array tasks (Slurm): two tasks then a merge give one process's files and index, byte for byte.
TEST(FractalBatchTest, ArrayTasksMergeIntoTheBytesOfOneProcess) {
  FractalBatchParams params;
  params.count = 5;
  params.seed = 40;
  params.model.num_points = 3000;
  params.out_dir = FreshDir("tasks_whole");
  ASSERT_TRUE(GenerateFractalBatch(params).ok());
  params.out_dir = FreshDir("tasks_split");
  for (int k : {1, 0}) {
    params.task = {k, 2};
    ASSERT_TRUE(GenerateFractalBatch(params).ok());
  }
  ASSERT_TRUE(MergeTaskIndexes(params.out_dir).ok());
  int files = 0;
  for (const auto& entry : fs::directory_iterator(FreshDir("tasks_whole"))) {
    const fs::path twin = params.out_dir / entry.path().filename();
    EXPECT_EQ(Slurp(entry.path()), Slurp(twin)) << entry.path().filename();
    ++files;
  }
  EXPECT_EQ(files, 6);  // 5 meshes and index.json
  params.task = {0, 6};
  EXPECT_EQ(GenerateFractalBatch(params).error().field, "task");
}

TEST(FractalBatchTest, BadParametersAreErrors) {
  FractalBatchParams params;
  params.out_dir = FreshDir("bad");
  params.model.sigma = 0.9;
  EXPECT_EQ(GenerateFractalBatch(params).error().field, "sigma");
  params.model.sigma = 0.05;
  params.count = 0;
  EXPECT_EQ(GenerateFractalBatch(params).error().field, "count");
}

// The command line, run as a process: same seed, same bytes; bad flags exit non-zero.
TEST(SimCliTest, FractalsCommandIsDeterministic) {
  const fs::path a = FreshDir("cli_a"), b = FreshDir("cli_b");
  const std::string sim = SOFTGRASP_SIM_EXE;
  for (const auto& dir : {a, b}) {
    const std::string cmd =
        sim + " fractals --count 3 --seed 5 --alpha 0.3 --points 3000 --format stl --out " +
        dir.string() + " > /dev/null";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  }
  for (const char* file : {"index.json", "fractal_5.stl", "fractal_6.stl", "fractal_7.stl"}) {
    ASSERT_TRUE(fs::exists(a / file)) << file;
    EXPECT_EQ(Slurp(a / file), Slurp(b / file)) << file;
  }
  EXPECT_NE(std::system((sim + " fractals --count 2 2> /dev/null").c_str()), 0);
  EXPECT_NE(std::system((sim + " fractals --count x --out /tmp/x 2> /dev/null").c_str()), 0);
  EXPECT_NE(std::system((sim + " nonsense 2> /dev/null").c_str()), 0);
}

}  // namespace
}  // namespace softgrasp::sim
