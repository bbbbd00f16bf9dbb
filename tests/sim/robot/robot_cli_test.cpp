#include "sim/robot/robot_cli.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sim/dataset/dataset.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;

TEST(RobotCli, SceneFlagRebuildsTheSpecAndSeedOfAManifest) {
  DatasetParams params;
  params.scenes = 1;
  params.seed = 5;
  params.spec.min_objects = 2;
  params.spec.max_objects = 3;
  params.spec.support.kind = Support::Kind::kTable;
  const softgrasp::testing::TempDir temp("robot-cli");
  params.out_dir = temp / "data";
  ASSERT_TRUE(GenerateDataset(params).ok());
  const fs::path manifest = params.out_dir / "shard_0000" / "scene_000000.json";

  RobotCommandLine cli;
  ASSERT_EQ(ParseRobotArgs({"--scene", manifest.string(), "--robot-id", "r2"}, &cli), "");
  EXPECT_EQ(cli.scene_seed, SceneSeed(5, 0, ShapeSplit::kTrain));
  EXPECT_EQ(cli.spec.support.kind, Support::Kind::kTable);
  EXPECT_EQ(cli.spec.max_objects, 3);
  EXPECT_EQ(SceneSpecToJson(cli.spec), SceneSpecToJson(params.spec));
  EXPECT_EQ(cli.robot_id, "r2");

  // The other options change the manifest's scene wherever they stand.
  RobotCommandLine changed;
  ASSERT_EQ(ParseRobotArgs({"--support", "bin", "--scene", manifest.string(), "--objects", "4"},
                           &changed),
            "");
  EXPECT_EQ(changed.scene_seed, cli.scene_seed);
  EXPECT_EQ(changed.spec.support.kind, Support::Kind::kBin);
  EXPECT_EQ(changed.spec.min_objects, 4);
  EXPECT_EQ(changed.spec.max_objects, 4);
}

TEST(RobotCli, BadOptionsSayWhatTheyTake) {
  RobotCommandLine cli;
  EXPECT_EQ(ParseRobotArgs({"--domain", "300"}, &cli), "--domain must be an integer in 0..232");
  EXPECT_EQ(ParseRobotArgs({"--support", "floor"}, &cli), "--support must be one of bin, table");
  EXPECT_EQ(ParseRobotArgs({"--robot-id", ""}, &cli), "--robot-id must be 1-256 bytes");
  EXPECT_EQ(ParseRobotArgs({"--objects", "0-3"}, &cli),
            "--objects must be N or MIN-MAX within 1-40");
  EXPECT_EQ(ParseRobotArgs({"--http-port", "8081", "extra"}, &cli), "unknown argument extra");
  EXPECT_EQ(ParseRobotArgs({"--http-port", "1", "--http-port", "2"}, &cli),
            "--http-port given twice");
}

TEST(RobotCli, BadSceneFilesAreClearErrors) {
  RobotCommandLine cli;
  EXPECT_NE(ParseRobotArgs({"--scene", "/nonexistent/scene.json"}, &cli).find("cannot read"),
            std::string::npos);
  const softgrasp::testing::TempDir temp("robot-cli-junk");
  const fs::path junk = temp / "not_a_manifest.json";
  std::ofstream(junk) << R"({"objects": []})";
  EXPECT_NE(ParseRobotArgs({"--scene", junk.string()}, &cli).find("not a scene manifest"),
            std::string::npos);
  std::ofstream(junk) << R"({"scene_seed": 3, "spec": {"objects": [1, 2]}})";
  EXPECT_NE(ParseRobotArgs({"--scene", junk.string()}, &cli).find("scene spec"), std::string::npos);
  EXPECT_NE(ParseRobotArgs({"--scene"}, &cli), "");
}

}  // namespace
}  // namespace softgrasp::sim
