// softgrasp-sim gqcnn-dataset, as a process: three small catalogue objects give an index whose
// counts add up and shards that read back; a rerun keeps them; a different configuration in the
// same folder exits 1 naming the problem; bad arguments exit 2 with a message naming the option.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "service/gqcnn/dataset_format.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Runs the command with `args`; stdout and stderr go to files in `dir`.
int RunCommand(const fs::path& dir, const std::string& args) {
  const std::string cmd = std::string(SOFTGRASP_SIM_EXE) + " gqcnn-dataset " + args + " > " +
                          (dir / "stdout.txt").string() + " 2> " + (dir / "stderr.txt").string();
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(GqcnnDatasetCliTest, WritesAResumableDatasetOfThreeObjects) {
  const testing::TempDir dir("gqcnn-dataset-cli");
  const std::string out = (dir / "data").string();
  const std::string args = "--out " + out +
                           " --source catalogue --objects 3 --shard-objects 2 --seed 5"
                           " --images-per-pose 2 --grasps 10 --robust-samples 2 --preview 16";
  ASSERT_EQ(RunCommand(dir.path(), args), 0) << Slurp(dir / "stderr.txt");
  EXPECT_NE(Slurp(dir / "stdout.txt").find("positives"), std::string::npos);
  auto index = gqcnn::ReadIndex(dir / "data");
  ASSERT_TRUE(index.ok()) << index.error().message;
  ASSERT_EQ(index.value().objects.size(), 3u);
  ASSERT_EQ(index.value().shards.size(), 2u);
  EXPECT_EQ(index.value().generator["source"], "catalogue");
  EXPECT_EQ(index.value().objects[0].source, "catalogue");
  std::uint64_t datapoints = 0;
  std::uint64_t positives = 0;
  for (const auto& shard : index.value().shards) {
    auto records = gqcnn::ReadShard(dir / "data" / shard.file);
    ASSERT_TRUE(records.ok()) << records.error().message;
    EXPECT_EQ(records.value().size(), shard.datapoints);
    datapoints += records.value().size();
    for (const auto& d : records.value()) positives += d.label ? 1 : 0;
  }
  EXPECT_GT(datapoints, 0u);
  EXPECT_EQ(datapoints, index.value().Datapoints());
  EXPECT_EQ(positives, index.value().Positives());
  EXPECT_GT(fs::file_size(dir / "data" / "previews" / "crops.png"), 1000u);
  // Rerun: everything kept.
  ASSERT_EQ(RunCommand(dir.path(), args), 0) << Slurp(dir / "stderr.txt");
  EXPECT_NE(Slurp(dir / "stdout.txt").find("shards generated 0, kept 2"), std::string::npos)
      << Slurp(dir / "stdout.txt");
  // Another seed into the same folder: refused.
  EXPECT_EQ(RunCommand(dir.path(), "--out " + out + " --source catalogue --objects 3 --seed 6"), 1);
  EXPECT_NE(Slurp(dir / "stderr.txt").find("another configuration"), std::string::npos);
}

TEST(GqcnnDatasetCliTest, BadArgumentsExitTwoNamingTheOption) {
  const testing::TempDir dir("gqcnn-dataset-cli-bad");
  const std::string out = " --out " + (dir / "x").string();
  const std::pair<std::string, std::string> cases[] = {
      {"--objects 2", "--out"},                              // no --out
      {out + " --source sponges", "--source"},               // unknown source
      {out + " --source primitive --alpha 0.3", "--alpha"},  // alpha without fractals
      {out + " --alpha 0", "--alpha"},                       // out of range
      {out + " --source meshes", "--meshes"},                // no folder
      {out + " --meshes /tmp", "--meshes"},                  // folder without the source
      {out + " --objects 0", "--objects"},
      {out + " --images-per-pose x", "--images-per-pose"},
      {out + " --robust-samples 0", "--robust-samples"},
      {out + " --split test --source catalogue", "--split"},
      {out + " --frobnicate", "--frobnicate"},
      {out + " --source meshes --meshes " + (dir / "none").string(), "is not a folder"},
  };
  for (const auto& [args, expected] : cases) {
    EXPECT_EQ(RunCommand(dir.path(), args), 2) << args;
    EXPECT_NE(Slurp(dir / "stderr.txt").find(expected), std::string::npos)
        << args << ": " << Slurp(dir / "stderr.txt");
  }
  EXPECT_FALSE(fs::exists(dir / "x" / "index.json"));
}

}  // namespace
}  // namespace softgrasp::sim
