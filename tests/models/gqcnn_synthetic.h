#pragma once
/// A learnable synthetic GQ-CNN dataset for tests, written with the real shard and index writers:
/// each crop shows a bar across the grasp axis (rows are the grasp axis, so the bar spans every
/// row over a band of columns) standing on a table. The grasp succeeds when the bar fits between
/// the jaws: its width in columns is below kJawOpeningPx. Each object has its own typical width,
/// each image jitters it, so labels vary within an object and a held-out object is new. The
/// grasp also fails when the jaws close above the bar's top (grasp depth less than 3 mm below
/// it): the label needs the pose input read against the image, as in Dex-Net. The two causes are
/// the label's two factors: a bar wider than the jaws is a collision (collision_free false), jaws
/// closing above its top a poor quality (robust Ferrari-Canny 0, else 0.004, against the index's
/// default threshold 0.002). The gripper clearances are the bar's: its top is under the palm,
/// and under the jaws too when it is wider than they open; else the jaws are over the table.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "service/gqcnn/dataset_format.h"

namespace softgrasp::testing {

inline constexpr int kJawOpeningPx = 12;

struct SyntheticGqcnnParams {
  int objects = 30;
  int images_per_object = 10;
  int grasps_per_image = 4;
  std::uint64_t seed = 3;
  int first_object_width_seed = 0;  ///< shifts the objects' widths (other objects, same law)
};

/// One crop: table at `table_m`, a bar of `width_px` columns centred at column `centre_col`,
/// `height_m` above the table; `missing` pixels set to 0.
inline gqcnn::GraspDatapoint SyntheticDatapoint(double table_m, double height_m, int width_px,
                                                int centre_col, double grasp_below_top_m,
                                                std::mt19937_64& rng) {
  gqcnn::GraspDatapoint d;
  const int side = gqcnn::kCropSizePx;
  const int left = centre_col - width_px / 2;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.001);
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const bool on_bar = c >= left && c < left + width_px;
      float depth = static_cast<float>((on_bar ? table_m - height_m : table_m) + noise(rng));
      if (unit(rng) < 0.02) depth = 0.0F;  // sensor dropouts
      d.crop_depth_m[static_cast<std::size_t>(r * side + c)] = depth;
    }
  }
  d.grasp_depth_m = static_cast<float>(table_m - height_m + grasp_below_top_m);
  d.hand_pose = {320, 240, d.grasp_depth_m, 0, 0, 0, 3.0F * kJawOpeningPx};
  d.collision_free = width_px < kJawOpeningPx;
  d.robust_ferrari_canny = grasp_below_top_m > 0.003 ? 0.004F : 0.0F;
  d.label = d.collision_free && d.robust_ferrari_canny > gqcnn::kDexNetMetricThreshold;
  d.palm_clearance_m = static_cast<float>(-grasp_below_top_m);
  d.jaw_clearance_m = d.collision_free ? 1.0F : d.palm_clearance_m;
  d.floor_clearance_m = d.collision_free ? static_cast<float>(table_m) - d.grasp_depth_m : 1.0F;
  return d;
}

/// Writes index.json and two shards under `dir`; returns the number of records.
inline std::size_t WriteSyntheticGqcnnDataset(const std::filesystem::path& dir,
                                              const SyntheticGqcnnParams& p) {
  std::mt19937_64 rng(p.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  gqcnn::DatasetIndex index;
  index.generator = {{"test", "synthetic bars"}, {"seed", p.seed}};
  std::vector<std::vector<gqcnn::GraspDatapoint>> shards(2);
  std::uint32_t image = 0;
  for (int o = 0; o < p.objects; ++o) {
    const std::uint32_t shard = o < p.objects / 2 ? 0 : 1;
    gqcnn::DatasetObject object;
    object.name = "bar-" + std::to_string(o);
    object.source = "primitive";
    object.shard = shard;
    object.stable_poses = 1;
    object.grasps = p.images_per_object * p.grasps_per_image;
    index.objects.push_back(object);
    // Typical widths 4..22 px: about a third of the objects below the opening; with the depth
    // condition about a fifth of the grasps succeed (Dex-Net 2.0: about 20 %).
    const int base = 4 + static_cast<int>(((o + p.first_object_width_seed) * 7) % 19);
    for (int i = 0; i < p.images_per_object; ++i, ++image) {
      const double table = 0.6 + 0.1 * unit(rng);
      const double height = 0.02 + 0.05 * unit(rng);
      for (int g = 0; g < p.grasps_per_image; ++g) {
        const int width = std::max(2, base + static_cast<int>(std::lround(8 * unit(rng))) - 4);
        const int centre = 16 + static_cast<int>(std::lround(2 * unit(rng))) - 1;
        const double below_top = -0.01 + 0.03 * unit(rng);
        gqcnn::GraspDatapoint d = SyntheticDatapoint(table, height, width, centre, below_top, rng);
        d.object_index = static_cast<std::uint32_t>(o);
        d.image_index = image;
        d.grasp_index = static_cast<std::uint32_t>(g);
        shards[shard].push_back(d);
      }
    }
  }
  std::size_t total = 0;
  for (std::uint32_t s = 0; s < shards.size(); ++s) {
    gqcnn::ShardEntry entry;
    entry.index = s;
    entry.file = "shards/shard_0000" + std::to_string(s) + ".gqd";
    entry.datapoints = shards[s].size();
    entry.images = shards[s].size() / static_cast<std::size_t>(p.grasps_per_image);
    for (const auto& d : shards[s]) entry.positives += d.label ? 1 : 0;
    EXPECT_FALSE(gqcnn::WriteShard(dir / entry.file, shards[s]).has_value());
    index.shards.push_back(entry);
    total += shards[s].size();
  }
  EXPECT_FALSE(gqcnn::WriteIndex(dir, index).has_value());
  return total;
}

}  // namespace softgrasp::testing
