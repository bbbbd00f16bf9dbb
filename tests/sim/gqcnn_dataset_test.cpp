// The GQ-CNN dataset generator (sim/gqcnn/gqcnn_dataset.h): on a 4 cm cube every datapoint carries
// the mesh analysis' values for its grasp and the label rule, face-centre grasps are collision-free
// with a nominal quality above the threshold, and the rendered crops show the cube's top at the
// centre and the table around; whole datasets: same seed same bytes, a damaged or deleted shard
// regenerated alone, another configuration refused, broken meshes skipped with their reason, bad
// parameters refused.
#include "sim/gqcnn/gqcnn_dataset.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <numbers>
#include <set>
#include <string>

#include "service/cli/files.h"
#include "service/gqcnn/clearance.h"
#include "service/mesh/mesh_check.h"
#include "service/mesh/mesh_io.h"
#include "sim/gqcnn/primitives.h"
#include "tests/support/box_mesh.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Small and fast: few grasps and robust samples, two images per pose.
GqcnnDatasetParams SmallParams(const fs::path& out) {
  GqcnnDatasetParams params = DefaultGqcnnDatasetParams();
  params.source = GqcnnMeshSource::kPrimitive;
  params.objects = 3;
  params.shard_objects = 2;
  params.seed = 11;
  params.images_per_pose = 2;
  params.analysis.num_grasps = 12;
  params.analysis.robust_samples = 2;
  params.out_dir = out;
  return params;
}

TEST(GqcnnPrimitivesTest, EveryKindIsAClosedOutwardSolid) {
  std::set<std::string> kinds;
  for (std::uint64_t seed = 0; seed < 60; ++seed) {
    const Primitive p = MakeRandomPrimitive(seed);
    kinds.insert(p.kind);
    const mesh::MeshReport report = mesh::CheckMesh(p.mesh);
    EXPECT_TRUE(report.ok()) << p.kind << " seed " << seed;
    EXPECT_EQ(MakeRandomPrimitive(seed).mesh, p.mesh);
  }
  EXPECT_EQ(kinds.size(), PrimitiveKinds().size());
}

TEST(GqcnnDatasetTest, CubeDatapointsCarryTheAnalysisValuesAndFaceGraspsAreFree) {
  const mesh::TriangleMesh cube = testing::CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  GqcnnDatasetParams params = DefaultGqcnnDatasetParams();
  params.noise.enabled = false;
  mesh::MeshGraspOptions options = params.analysis;
  options.num_grasps = 60;
  options.robust_samples = 5;
  options.seed = 3;
  auto analysed = mesh::AnalyseMeshGrasps(cube, options);
  ASSERT_TRUE(analysed.ok()) << analysed.error().message;
  const mesh::MeshGraspAnalysis& analysis = analysed.value();
  ASSERT_EQ(analysis.poses.size(), 6u);
  auto scene = MakePoseScene(cube, analysis, 0);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const mesh::StablePose& pose = analysis.poses[0];

  std::set<std::uint32_t> aligned;
  for (std::size_t g = 0; g < analysis.grasps.size(); ++g) {
    if (analysis.grasps[g].poses[0].aligned) aligned.insert(static_cast<std::uint32_t>(g));
  }
  ASSERT_GE(aligned.size(), 5u);
  int face_grasps = 0;
  int centre_checks = 0;
  for (std::uint64_t image_seed = 1; image_seed <= 3; ++image_seed) {
    std::vector<gqcnn::GraspDatapoint> points;
    core::DepthImage depth;
    const std::int64_t pixels =
        scene.value().RenderImage(params, image_seed, false, &points, &depth);
    EXPECT_EQ(pixels, static_cast<std::int64_t>(depth.width()) * depth.height());
    EXPECT_LT(pixels, 600 * 600 / 2);  // a window, not the whole image
    std::set<std::uint32_t> seen;
    for (const gqcnn::GraspDatapoint& d : points) {
      seen.insert(d.grasp_index);
      ASSERT_LT(d.grasp_index, analysis.grasps.size());
      const mesh::AnalysedGrasp& g = analysis.grasps[d.grasp_index];
      EXPECT_EQ(d.robust_ferrari_canny, static_cast<float>(*g.robust_ferrari_canny));
      EXPECT_EQ(d.ferrari_canny, static_cast<float>(g.ferrari_canny));
      EXPECT_EQ(d.collision_free, g.poses[0].collision_free);
      EXPECT_EQ(d.label,
                g.poses[0].collision_free && *g.robust_ferrari_canny > params.metric_threshold);
      EXPECT_EQ(d.grasp_depth_m, d.hand_pose[2]);
      // The camera is 0.65-0.75 m from the table, within 5 degrees of vertical.
      EXPECT_GT(d.grasp_depth_m, 0.60F);
      EXPECT_LT(d.grasp_depth_m, 0.76F);
      const double height_m =
          (pose.table_from_object_rotation * g.grasp.center_m + pose.table_from_object_translation)
              .z();
      const Eigen::Vector3d center_t =
          pose.table_from_object_rotation * g.grasp.center_m + pose.table_from_object_translation;
      // Centres well inside the top face's footprint: the crop's centre is the top face,
      // (0.04 - height) nearer than the grasp centre; the crop's corners (68 px, ~9 cm away)
      // are the table, deeper than the centre.
      const Eigen::Vector3d com_t = pose.table_from_object_translation;
      if ((center_t - com_t).head<2>().cwiseAbs().maxCoeff() < 0.008) {
        const float centre = d.crop_depth_m[16 * gqcnn::kCropSizePx + 16];
        EXPECT_NEAR(centre, d.grasp_depth_m - (0.04 - height_m), 0.0015);
        EXPECT_GT(d.crop_depth_m[0], centre + 0.02F);
        EXPECT_GT(d.crop_depth_m[gqcnn::kCropPixels - 1], centre + 0.02F);
        ++centre_checks;
      }
      // A face-centre grasp: axis along a side normal, centre 10-30 mm above the table.
      const double off_normal = std::acos(std::min(1.0, g.grasp.axis.cwiseAbs().maxCoeff()));
      if (off_normal < 3.0 * std::numbers::pi / 180.0 && height_m > 0.010 && height_m < 0.030 &&
          (center_t - com_t).head<2>().norm() < 0.005) {
        EXPECT_TRUE(d.collision_free) << d.grasp_index;
        // Nominally well above Dex-Net's threshold (about 0.005); its robust mean under
        // Dex-Net's 1 cm object-pose noise is far lower on a 4 cm cube (about 0.0002, see
        // docs/gqcnn-dataset.md "Positive rates"), so the label follows the rule checked above.
        EXPECT_GT(d.ferrari_canny, gqcnn::kDexNetMetricThreshold) << d.grasp_index;
        EXPECT_GT(d.robust_ferrari_canny, 0.0F) << d.grasp_index;
        // Its fingers come down beside the cube onto the table, `height` below the grasp
        // centre (the camera's tilt of up to 5 degrees moves the nearest table pixel under a
        // finger up to 3 mm); the palm's footprint holds the top face, (0.04 - height) nearer
        // than the grasp centre.
        EXPECT_EQ(d.jaw_clearance_m, static_cast<float>(gqcnn::kNothingUnderGripperM));
        EXPECT_NEAR(d.floor_clearance_m, height_m, 0.004) << d.grasp_index;
        EXPECT_NEAR(d.palm_clearance_m, -(0.04 - height_m), 0.004) << d.grasp_index;
        EXPECT_TRUE(gqcnn::ClearanceRule{}.Admits(gqcnn::StoredClearance(d), core::Gripper{}));
        ++face_grasps;
      }
    }
    // Every aligned grasp is cropped once per image (a cube near the image centre).
    EXPECT_EQ(seen, aligned);
    EXPECT_EQ(points.size(), aligned.size());
  }
  EXPECT_GT(face_grasps, 0);
  EXPECT_GT(centre_checks, 0);
}

TEST(GqcnnDatasetTest, TheRenderedWindowHoldsEverythingTheCropsRead) {
  // Without noise, crops from the window equal crops from the full 600 x 600 render: the window
  // margin covers the crops' reach.
  const mesh::TriangleMesh box = testing::CentredBoxMesh(Eigen::Vector3d(0.02, 0.035, 0.025));
  GqcnnDatasetParams params = DefaultGqcnnDatasetParams();
  params.noise.enabled = false;
  mesh::MeshGraspOptions options = params.analysis;
  options.num_grasps = 30;
  options.robust_samples = 1;
  options.seed = 5;
  auto analysed = mesh::AnalyseMeshGrasps(box, options);
  ASSERT_TRUE(analysed.ok()) << analysed.error().message;
  int compared = 0;
  for (int pose = 0; pose < static_cast<int>(analysed.value().poses.size()); ++pose) {
    auto scene = MakePoseScene(box, analysed.value(), pose);
    ASSERT_TRUE(scene.ok());
    for (std::uint64_t image_seed = 10; image_seed < 12; ++image_seed) {
      std::vector<gqcnn::GraspDatapoint> window, full;
      const std::int64_t window_px = scene.value().RenderImage(params, image_seed, false, &window);
      const std::int64_t full_px = scene.value().RenderImage(params, image_seed, true, &full);
      ASSERT_EQ(window.size(), full.size());
      if (window.empty()) continue;
      EXPECT_EQ(full_px, 600 * 600);
      EXPECT_LT(window_px, full_px / 4);
      for (std::size_t i = 0; i < window.size(); ++i) {
        EXPECT_EQ(window[i].hand_pose, full[i].hand_pose);
        for (int p = 0; p < gqcnn::kCropPixels; ++p) {
          ASSERT_NEAR(window[i].crop_depth_m[p], full[i].crop_depth_m[p], 1e-6)
              << "pose " << pose << " grasp " << i << " pixel " << p;
        }
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 10);
}

TEST(GqcnnDatasetTest, SameSeedSameBytesAndADamagedOrDeletedShardIsRegeneratedAlone) {
  const testing::TempDir dir("gqcnn-dataset");
  auto first = GenerateGqcnnDataset(SmallParams(dir / "a"));
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_EQ(first.value().shards_generated, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_GT(first.value().index.Datapoints(), 0u);
  EXPECT_GT(first.value().index.Images(), 0u);
  auto second = GenerateGqcnnDataset(SmallParams(dir / "b"));
  ASSERT_TRUE(second.ok()) << second.error().message;
  const std::vector<std::string> files = {"index.json", "skipped.json", "shards/shard_00000.gqd",
                                          "shards/shard_00001.gqd"};
  for (const std::string& f : files) {
    EXPECT_EQ(Slurp(dir / "a" / f), Slurp(dir / "b" / f)) << f;
  }
  // Another seed: other bytes.
  GqcnnDatasetParams other = SmallParams(dir / "c");
  other.seed = 12;
  ASSERT_TRUE(GenerateGqcnnDataset(other).ok());
  EXPECT_NE(Slurp(dir / "a" / files[2]), Slurp(dir / "c" / files[2]));

  // Convex primitives: the ray through a grasp centre meets the object at or before the centre,
  // so the crop's centre pixel reads at most the grasp depth (noise: +1 mm; dropout: 0).
  {
    auto shard0 = gqcnn::ReadShard(dir / "a" / files[2]);
    ASSERT_TRUE(shard0.ok());
    std::size_t in_front = 0;
    for (const auto& d : shard0.value()) {
      const float centre = d.crop_depth_m[16 * gqcnn::kCropSizePx + 16];
      if (centre > 0.0F && centre < d.grasp_depth_m + 0.001F) ++in_front;
    }
    EXPECT_GE(static_cast<double>(in_front), 0.95 * static_cast<double>(shard0.value().size()));
    // The clearance check read from the image mostly agrees with the mesh's collision label.
    std::size_t agree = 0;
    for (const auto& d : shard0.value()) {
      const bool admitted =
          gqcnn::ClearanceRule{}.Admits(gqcnn::StoredClearance(d), core::Gripper{});
      if (admitted == d.collision_free) ++agree;
    }
    std::printf("clearance check agrees with %zu of %zu collision labels\n", agree,
                shard0.value().size());
    EXPECT_GE(static_cast<double>(agree), 0.85 * static_cast<double>(shard0.value().size()));
  }
  // Records are numbered dataset-wide and point into the index.
  auto shard1 = gqcnn::ReadShard(dir / "a" / files[3]);
  ASSERT_TRUE(shard1.ok());
  ASSERT_FALSE(shard1.value().empty());
  EXPECT_EQ(shard1.value().front().object_index, 2u);
  EXPECT_EQ(shard1.value().front().image_index, first.value().index.shards[0].images);

  // Damage shard 0 (one byte): only it is regenerated, to the same bytes.
  {
    std::string bytes = Slurp(dir / "a" / files[2]);
    bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5A);
    std::ofstream(dir / "a" / files[2], std::ios::binary) << bytes;
  }
  auto resumed = GenerateGqcnnDataset(SmallParams(dir / "a"));
  ASSERT_TRUE(resumed.ok()) << resumed.error().message;
  EXPECT_EQ(resumed.value().shards_generated, (std::vector<std::uint32_t>{0}));
  EXPECT_EQ(resumed.value().shards_kept, (std::vector<std::uint32_t>{1}));
  for (const std::string& f : files) EXPECT_EQ(Slurp(dir / "a" / f), Slurp(dir / "b" / f)) << f;

  // Delete shard 1: only it is regenerated.
  fs::remove(dir / "a" / files[3]);
  resumed = GenerateGqcnnDataset(SmallParams(dir / "a"));
  ASSERT_TRUE(resumed.ok()) << resumed.error().message;
  EXPECT_EQ(resumed.value().shards_generated, (std::vector<std::uint32_t>{1}));
  EXPECT_EQ(resumed.value().shards_kept, (std::vector<std::uint32_t>{0}));
  for (const std::string& f : files) EXPECT_EQ(Slurp(dir / "a" / f), Slurp(dir / "b" / f)) << f;

  // Nothing missing: everything kept, nothing rendered.
  resumed = GenerateGqcnnDataset(SmallParams(dir / "a"));
  ASSERT_TRUE(resumed.ok());
  EXPECT_TRUE(resumed.value().shards_generated.empty());
  EXPECT_EQ(resumed.value().images_generated, 0u);

  // Another configuration in the same folder: refused, nothing touched.
  GqcnnDatasetParams changed = SmallParams(dir / "a");
  changed.images_per_pose = 3;
  auto refused = GenerateGqcnnDataset(changed);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, core::ErrorCode::kConflict);
  EXPECT_NE(refused.error().message.find("another configuration"), std::string::npos);
  for (const std::string& f : files) EXPECT_EQ(Slurp(dir / "a" / f), Slurp(dir / "b" / f)) << f;
}

// Equal-sized datasets: exactly K images per object whatever its number of stable poses, spread
// over the poses in turn; labels follow the chosen threshold, which the index records.
// Array tasks (Slurm): each task numbers its images from 0; the merge shifts them by the images
// of the tasks before, so the folder is one process's, byte for byte, and merging again (as after
// an interrupted merge) changes nothing. A missing task is named; a task beyond the shards is
// refused.
TEST(GqcnnDatasetTest, ArrayTasksMergeIntoTheBytesOfOneProcess) {
  const testing::TempDir dir("gqcnn-dataset-tasks");
  GqcnnDatasetParams whole = SmallParams(dir / "whole");
  whole.objects = 4;
  whole.shard_objects = 1;
  auto one = GenerateGqcnnDataset(whole);
  ASSERT_TRUE(one.ok()) << one.error().message;
  ASSERT_GT(one.value().index.shards[2].datapoints, 0u);  // a shifted shard is checked below
  GqcnnDatasetParams split = whole;
  split.out_dir = dir / "split";
  for (int k : {2, 0}) {
    split.task = {k, 3};
    auto part = GenerateGqcnnDataset(split);
    ASSERT_TRUE(part.ok()) << part.error().message;
  }
  auto missing = MergeGqcnnDatasetTasks(split.out_dir);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("have not written their index: 1"), std::string::npos)
      << missing.error().message;
  split.task = {1, 3};
  ASSERT_TRUE(GenerateGqcnnDataset(split).ok());
  const std::vector<std::string> files = {"index.json",
                                          "skipped.json",
                                          "shards/shard_00000.gqd",
                                          "shards/shard_00001.gqd",
                                          "shards/shard_00002.gqd",
                                          "shards/shard_00003.gqd"};
  for (int round = 0; round < 2; ++round) {
    auto merged = MergeGqcnnDatasetTasks(split.out_dir);
    ASSERT_TRUE(merged.ok()) << merged.error().message;
    for (const std::string& f : files) {
      EXPECT_EQ(Slurp(whole.out_dir / f), Slurp(split.out_dir / f)) << f << ", round " << round;
    }
  }
  // The merged folder resumes as one process: every shard is kept.
  GqcnnDatasetParams again = whole;
  again.out_dir = split.out_dir;
  auto resumed = GenerateGqcnnDataset(again);
  ASSERT_TRUE(resumed.ok()) << resumed.error().message;
  EXPECT_EQ(resumed.value().shards_kept, (std::vector<std::uint32_t>{0, 1, 2, 3}));
  split.task = {4, 5};
  auto beyond = GenerateGqcnnDataset(split);
  ASSERT_FALSE(beyond.ok());
  EXPECT_EQ(beyond.error().field, "task");
}

TEST(GqcnnDatasetTest, ImagesPerObjectAndTheLabelThreshold) {
  const fs::path dir = fs::temp_directory_path() / "gqcnn_dataset_images_per_object";
  fs::remove_all(dir);
  GqcnnDatasetParams params = SmallParams(dir / "out");
  params.images_per_object = 5;
  params.metric_threshold = 0.0;  // every collision-free grasp with any robust quality
  auto result = GenerateGqcnnDataset(params);
  ASSERT_TRUE(result.ok()) << result.error().message;
  const gqcnn::DatasetIndex& index = result.value().index;
  EXPECT_EQ(index.metric_threshold, 0.0);
  auto reread = gqcnn::ReadIndex(dir / "out");
  ASSERT_TRUE(reread.ok());
  EXPECT_EQ(reread.value().metric_threshold, 0.0);
  ASSERT_EQ(index.objects.size(), 3u);
  EXPECT_EQ(index.Images(), 3u * 5u);
  std::map<std::uint32_t, std::set<std::uint32_t>> poses_of_object;
  for (const gqcnn::ShardEntry& shard : index.shards) {
    auto records = gqcnn::ReadShard(dir / "out" / shard.file);
    ASSERT_TRUE(records.ok());
    for (const gqcnn::GraspDatapoint& d : records.value()) {
      EXPECT_EQ(d.label, d.collision_free && d.robust_ferrari_canny > 0.0F);
      poses_of_object[d.object_index].insert(d.pose_index);
    }
  }
  for (const auto& [object, poses] : poses_of_object) {
    const int stable = index.objects[object].stable_poses;
    EXPECT_LE(static_cast<int>(poses.size()), std::min(stable, 5)) << object;
  }
  fs::remove_all(dir);
}

TEST(GqcnnDatasetTest, BrokenMeshesAreSkippedWithTheirReason) {
  const testing::TempDir dir("gqcnn-dataset-meshes");
  fs::create_directories(dir / "in");
  std::ofstream(dir / "in" / "a_cube.obj")
      << mesh::WriteObj(testing::CentredBoxMesh(Eigen::Vector3d(0.02, 0.025, 0.03)));
  std::ofstream(dir / "in" / "b_broken.obj") << "v 0 0 0\nf 1 2 3\n";
  std::ofstream(dir / "in" / "notes.txt") << "not a mesh\n";
  GqcnnDatasetParams params = SmallParams(dir / "out");
  params.source = GqcnnMeshSource::kMeshes;
  params.meshes_dir = dir / "in";
  params.objects = 2;
  params.shard_objects = 5;
  auto result = GenerateGqcnnDataset(params);
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_EQ(result.value().index.objects.size(), 2u);
  EXPECT_EQ(result.value().index.objects[0].name, "a_cube");
  EXPECT_EQ(result.value().index.objects[0].source, "mesh");
  EXPECT_GE(result.value().index.objects[0].stable_poses, 3);
  EXPECT_EQ(result.value().index.objects[1].name, "b_broken");
  EXPECT_EQ(result.value().index.objects[1].stable_poses, 0);
  ASSERT_EQ(result.value().skipped.size(), 1u);
  EXPECT_NE(result.value().skipped[0].find("b_broken"), std::string::npos);
  const nlohmann::json skipped = nlohmann::json::parse(Slurp(dir / "out" / "skipped.json"));
  ASSERT_EQ(skipped.size(), 1u);
  EXPECT_EQ(skipped[0]["object"], 1);
  EXPECT_FALSE(skipped[0]["reason"].get<std::string>().empty());
  EXPECT_GT(result.value().index.Datapoints(), 0u);
  // Resumed: the skipped object's reason survives with its kept shard.
  auto again = GenerateGqcnnDataset(params);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.value().skipped, result.value().skipped);
}

TEST(GqcnnDatasetTest, BadParametersAreRefusedWithTheirName) {
  const testing::TempDir dir("gqcnn-dataset-bad");
  const auto field_of = [](const GqcnnDatasetParams& p) {
    auto r = GenerateGqcnnDataset(p);
    EXPECT_FALSE(r.ok());
    if (r.ok()) return std::string();
    EXPECT_EQ(r.error().code, core::ErrorCode::kInvalidArgument) << r.error().message;
    return r.error().field;
  };
  GqcnnDatasetParams p = SmallParams(dir / "out");
  p.objects = 0;
  EXPECT_EQ(field_of(p), "objects");
  p = SmallParams(dir / "out");
  p.images_per_pose = 0;
  EXPECT_EQ(field_of(p), "images_per_pose");
  p = SmallParams(dir / "out");
  p.images_per_object = -1;
  EXPECT_EQ(field_of(p), "images_per_object");
  p = SmallParams(dir / "out");
  p.metric_threshold = -0.1;
  EXPECT_EQ(field_of(p), "metric_threshold");
  p = SmallParams(dir / "out");
  p.analysis.robust_samples = 0;
  EXPECT_EQ(field_of(p), "robust_samples");
  p = SmallParams("");
  EXPECT_EQ(field_of(p), "out");
  p = SmallParams(dir / "out");
  p.source = GqcnnMeshSource::kMeshes;
  p.meshes_dir = dir / "missing";
  EXPECT_EQ(field_of(p), "meshes");
  fs::create_directories(dir / "one");
  std::ofstream(dir / "one" / "cube.obj")
      << mesh::WriteObj(testing::CentredBoxMesh(Eigen::Vector3d::Constant(0.02)));
  p.meshes_dir = dir / "one";
  p.objects = 2;
  EXPECT_EQ(field_of(p), "objects");
  EXPECT_FALSE(fs::exists(dir / "out" / "index.json"));
}

}  // namespace
}  // namespace softgrasp::sim
