#include "service/gqcnn/dataset_format.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

namespace softgrasp::gqcnn {
namespace {

GraspDatapoint Sample(std::uint32_t i) {
  GraspDatapoint d;
  for (int p = 0; p < kCropPixels; ++p)
    d.crop_depth_m[p] = 0.6F + 0.001F * static_cast<float>(p % 17);
  d.crop_depth_m[5] = 0.0F;  // a missing reading
  d.grasp_depth_m = 0.62F + 0.01F * static_cast<float>(i);
  d.hand_pose = {300.0F, 301.5F, d.grasp_depth_m, 1.25F, 0.5F, 2.0F, 40.0F};
  d.robust_ferrari_canny = 0.003F;
  d.ferrari_canny = 0.0041F;
  d.collision_free = true;
  d.label = (i % 2) == 0;
  d.object_index = 7 + i;
  d.pose_index = 2;
  d.image_index = 100 + i;
  d.grasp_index = 3 * i;
  d.jaw_clearance_m = 0.002F * static_cast<float>(i) - 0.001F;
  d.palm_clearance_m = -0.03F;
  d.floor_clearance_m = 0.015F;
  return d;
}

// `bytes` (a shard of this build) as a version 1 shard: no clearances, CRC recomputed.
std::string AsVersion1(const std::string& bytes) {
  const std::size_t header = 8 + 16, record = RecordBytes(), old_record = record - 12;
  std::string out = bytes.substr(0, header);
  out[8] = 1;
  for (std::size_t at = header; at + record <= bytes.size() - 4; at += record) {
    out += bytes.substr(at, old_record);
  }
  const auto crc = static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(out.data()), static_cast<uInt>(out.size())));
  out.append(reinterpret_cast<const char*>(&crc), 4);
  return out;
}

void ExpectSame(const GraspDatapoint& a, const GraspDatapoint& b) {
  EXPECT_EQ(a.crop_depth_m, b.crop_depth_m);
  EXPECT_EQ(a.grasp_depth_m, b.grasp_depth_m);
  EXPECT_EQ(a.hand_pose, b.hand_pose);
  EXPECT_EQ(a.robust_ferrari_canny, b.robust_ferrari_canny);
  EXPECT_EQ(a.ferrari_canny, b.ferrari_canny);
  EXPECT_EQ(a.collision_free, b.collision_free);
  EXPECT_EQ(a.label, b.label);
  EXPECT_EQ(a.object_index, b.object_index);
  EXPECT_EQ(a.pose_index, b.pose_index);
  EXPECT_EQ(a.image_index, b.image_index);
  EXPECT_EQ(a.grasp_index, b.grasp_index);
  EXPECT_EQ(a.jaw_clearance_m, b.jaw_clearance_m);
  EXPECT_EQ(a.palm_clearance_m, b.palm_clearance_m);
  EXPECT_EQ(a.floor_clearance_m, b.floor_clearance_m);
}

TEST(GqcnnDatasetFormatTest, ShardRoundTripsBitForBit) {
  const std::vector<GraspDatapoint> in = {Sample(0), Sample(1), Sample(2)};
  const std::string bytes = EncodeShard(in);
  EXPECT_EQ(bytes.size(), 8 + 16 + 3 * RecordBytes() + 4);
  const auto out = DecodeShard(bytes);
  ASSERT_TRUE(out.ok()) << out.error().message;
  ASSERT_EQ(out.value().size(), 3U);
  for (int i = 0; i < 3; ++i) ExpectSame(in[i], out.value()[i]);
  EXPECT_EQ(EncodeShard(out.value()), bytes);
  const auto empty = DecodeShard(EncodeShard({}));
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty.value().empty());
}

TEST(GqcnnDatasetFormatTest, DamagedShardsAreRefusedWithTheReason) {
  const std::string bytes = EncodeShard({Sample(0), Sample(1)});
  auto refused = [](std::string_view b, const std::string& words) {
    const auto result = DecodeShard(b);
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.error().code, core::ErrorCode::kInvalidArgument);
    EXPECT_EQ(result.error().field, "shard");
    EXPECT_NE(result.error().message.find(words), std::string::npos) << result.error().message;
  };
  refused("", "at least");
  refused(std::string(bytes.size(), 'x'), "magic");
  refused(std::string_view(bytes).substr(0, bytes.size() - 100), "cut short");
  std::string flipped = bytes;
  flipped[100] ^= 0x40;
  refused(flipped, "CRC");
  std::string version = bytes;
  version[8] = 9;
  refused(version, "version");
  // A record that passes the CRC but holds a NaN depth (a writer bug) is refused too.
  GraspDatapoint nan = Sample(0);
  nan.crop_depth_m[3] = std::numeric_limits<float>::quiet_NaN();
  refused(EncodeShard({nan}), "finite");
  GraspDatapoint negative_depth = Sample(0);
  negative_depth.grasp_depth_m = -1.0F;
  refused(EncodeShard({negative_depth}), "grasp depth");
  GraspDatapoint infinite = Sample(0);
  infinite.palm_clearance_m = std::numeric_limits<float>::infinity();
  refused(EncodeShard({infinite}), "clearances");
}

// Datasets written before the clearances were stored still load, with clearances NaN.
TEST(GqcnnDatasetFormatTest, Version1ShardsAreReadWithoutClearances) {
  const std::vector<GraspDatapoint> in = {Sample(0), Sample(1)};
  const std::string v1 = AsVersion1(EncodeShard(in));
  ASSERT_EQ(v1.size(), 8 + 16 + 2 * (RecordBytes() - 12) + 4);
  const auto out = DecodeShard(v1);
  ASSERT_TRUE(out.ok()) << out.error().message;
  ASSERT_EQ(out.value().size(), 2U);
  for (std::size_t i = 0; i < 2; ++i) {
    GraspDatapoint read = out.value()[i];
    EXPECT_TRUE(std::isnan(read.jaw_clearance_m));
    EXPECT_TRUE(std::isnan(read.palm_clearance_m));
    EXPECT_TRUE(std::isnan(read.floor_clearance_m));
    read.jaw_clearance_m = in[i].jaw_clearance_m;
    read.palm_clearance_m = in[i].palm_clearance_m;
    read.floor_clearance_m = in[i].floor_clearance_m;
    ExpectSame(in[i], read);  // every other field as written
  }
  // Re-encoded, they are a current shard whose clearances stay NaN (not measured).
  const auto again = DecodeShard(EncodeShard(out.value()));
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_TRUE(std::isnan(again.value()[1].floor_clearance_m));
  EXPECT_EQ(EncodeShard(again.value()), EncodeShard(out.value()));
}

TEST(GqcnnDatasetFormatTest, IndexRoundTripsAndCountsTotals) {
  DatasetIndex index;
  index.generator = {{"source", "fractal"}, {"alpha", 0.3}};
  index.objects = {{"fractal-0", "fractal", 0, 3, 100}, {"fractal-1", "fractal", 1, 2, 80}};
  index.shards = {{"shards/shard_00000.gqd", 0, 10, 400, 90},
                  {"shards/shard_00001.gqd", 1, 5, 200, 10}};
  const nlohmann::json json = IndexToJson(index);
  EXPECT_EQ(json["totals"]["datapoints"], 600);
  EXPECT_EQ(json["totals"]["positives"], 100);
  EXPECT_NEAR(json["totals"]["positive_rate"].get<double>(), 100.0 / 600.0, 1e-12);
  const auto back = IndexFromJson(json);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(IndexToJson(back.value()), json);
}

TEST(GqcnnDatasetFormatTest, BrokenIndexesNameTheField) {
  DatasetIndex index;
  index.shards = {{"shards/shard_00000.gqd", 0, 1, 4, 1}};
  const nlohmann::json good = IndexToJson(index);
  auto field_of = [](const nlohmann::json& json) {
    const auto result = IndexFromJson(json);
    return result.ok() ? std::string("<accepted>") : result.error().field;
  };
  nlohmann::json j = good;
  j["format"] = "something-else";
  EXPECT_EQ(field_of(j), "format");
  j = good;
  j["shards"][0]["file"] = "../../etc/passwd";
  EXPECT_EQ(field_of(j), "shards[0].file");
  j = good;
  j["shards"][0]["file"] = "/tmp/x.gqd";
  EXPECT_EQ(field_of(j), "shards[0].file");
  j = good;
  j["shards"][0]["positives"] = 9;
  EXPECT_EQ(field_of(j), "shards[0].positives");
  j = good;
  j["shards"][0].erase("images");
  EXPECT_EQ(field_of(j), "shards[0].images");
  j = good;
  j["shards"].push_back(j["shards"][0]);
  EXPECT_EQ(field_of(j), "shards[1].index");
  j = good;
  j["crop_size_px"] = 64;
  EXPECT_EQ(field_of(j), "crop_size_px");
  EXPECT_EQ(field_of(nlohmann::json::array()), "index");
}

TEST(GqcnnDatasetFormatTest, FilesOnDisk) {
  const auto dir = std::filesystem::temp_directory_path() / "gqcnn_dataset_format_test";
  std::filesystem::remove_all(dir);
  ASSERT_FALSE(WriteShard(dir / "shards" / "shard_00000.gqd", {Sample(4)}).has_value());
  const auto shard = ReadShard(dir / "shards" / "shard_00000.gqd");
  ASSERT_TRUE(shard.ok()) << shard.error().message;
  ExpectSame(shard.value().at(0), Sample(4));
  EXPECT_EQ(ReadShard(dir / "nope.gqd").error().code, core::ErrorCode::kNotFound);
  EXPECT_EQ(ReadIndex(dir).error().code, core::ErrorCode::kNotFound);
  DatasetIndex index;
  index.shards = {{"shards/shard_00000.gqd", 0, 1, 1, 1}};
  ASSERT_FALSE(WriteIndex(dir, index).has_value());
  const auto read = ReadIndex(dir);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read.value().Datapoints(), 1U);
  std::ofstream(dir / "index.json") << "{not json";
  EXPECT_EQ(ReadIndex(dir).error().code, core::ErrorCode::kInvalidArgument);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace softgrasp::gqcnn
