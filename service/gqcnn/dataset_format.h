#pragma once
/// The on-disk form of a GQ-CNN grasp dataset (docs/gqcnn-dataset.md): what `softgrasp-sim
/// gqcnn-dataset` writes and `softgrasp-train gqcnn` reads. A dataset is a directory with
/// `index.json` (what was generated from what, and one entry per finished shard) and shard files
/// `shards/shard_NNNNN.gqd` of fixed-size binary records, one per (rendered image, grasp) pair:
/// Dex-Net 2.0's `depth_ims_tf_table`, `hand_poses`, metrics and labels (REFERENCE §1.8), with
/// a CRC so that a shard cut short by a killed run is recognised and generated again.
///
/// Units: metres for depths, pixels for image coordinates, radians for angles.

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "service/core/status.h"

namespace softgrasp::gqcnn {

/// Side of the network's input crop, pixels (Dex-Net 2.0: 32, resized from a 96-pixel crop).
inline constexpr int kCropSizePx = 32;
inline constexpr int kCropPixels = kCropSizePx * kCropSizePx;
/// Dex-Net 2.0's label threshold on robust Ferrari-Canny (`metric_thresh`).
inline constexpr double kDexNetMetricThreshold = 0.002;

/// One (image, grasp) pair.
struct GraspDatapoint {
  /// Grasp-aligned crop, row-major: absolute depth (z in the camera frame, metres) with the
  /// grasp centre at the crop centre and the grasp axis along the crop's rows (+u); 0 = no
  /// reading. Dex-Net's depth_ims_tf_table.
  std::array<float, kCropPixels> crop_depth_m{};
  /// z of the grasp centre (midpoint of the jaws) in the camera frame: the pose input.
  float grasp_depth_m = 0.0F;
  /// Dex-Net's hand_poses: centre row, centre column, depth (m), angle (rad), row - cy,
  /// column - cx, width (px), all in the full rendered image.
  std::array<float, 7> hand_pose{};
  float robust_ferrari_canny = 0.0F;  ///< mean over the robust samples (0 when not computed)
  float ferrari_canny = 0.0F;         ///< nominal
  bool collision_free = false;        ///< the gripper reaches it in this pose (REFERENCE §1.6)
  bool label = false;                 ///< robust_ferrari_canny > threshold && collision_free
  std::uint32_t object_index = 0;     ///< into DatasetIndex::objects
  std::uint32_t pose_index = 0;       ///< the object's stable pose, most probable first
  std::uint32_t image_index = 0;      ///< dataset-wide rendered-image number
  std::uint32_t grasp_index = 0;      ///< the grasp's rank in the object's analysis
  /// gqcnn::MeasureClearance of the grasp in the rendered image (clearance.h), metres; NaN when
  /// not measured (every record of a version 1 shard).
  float jaw_clearance_m = std::numeric_limits<float>::quiet_NaN();
  float palm_clearance_m = std::numeric_limits<float>::quiet_NaN();
  float floor_clearance_m = std::numeric_limits<float>::quiet_NaN();
};

/// Bytes of one record in a shard file of the version this build writes.
std::size_t RecordBytes();

/// A shard as bytes: header, records, CRC-32.
std::string EncodeShard(const std::vector<GraspDatapoint>& datapoints);

/// Reads the current version and version 1 (no clearances: NaN). Errors (kInvalidArgument,
/// field "shard"): wrong magic or version, a crop size other than
/// kCropSizePx, a length that does not match the count, a CRC mismatch (a shard cut short),
/// non-finite or negative depths, flags other than 0/1. Never throws on any input.
core::Result<std::vector<GraspDatapoint>> DecodeShard(std::string_view bytes);

/// Writes atomically with cli::WriteFile (a reader sees the old file or the whole new one),
/// creating missing folders; its errors.
std::optional<core::Error> WriteShard(const std::filesystem::path& path,
                                      const std::vector<GraspDatapoint>& datapoints);
/// DecodeShard of the file; kNotFound when it does not exist.
core::Result<std::vector<GraspDatapoint>> ReadShard(const std::filesystem::path& path);

/// An object the dataset was generated from.
struct DatasetObject {
  std::string name;    ///< e.g. "fractal-a0.30-000017", "catalogue-sponge-000003", a file stem
  std::string source;  ///< "fractal", "primitive", "catalogue" or "mesh"
  std::uint32_t shard = 0;
  int stable_poses = 0;  ///< poses rendered
  int grasps = 0;        ///< grasps analysed
};

struct ShardEntry {
  std::string file;  ///< relative to the dataset directory, e.g. "shards/shard_00003.gqd"
  std::uint32_t index = 0;
  std::uint64_t images = 0;
  std::uint64_t datapoints = 0;
  std::uint64_t positives = 0;
};

struct DatasetIndex {
  /// What the generator was asked for (sources, seeds, cameras, gripper...), free-form; the
  /// generator compares it on resume so that shards of another configuration are never mixed in.
  nlohmann::json generator = nlohmann::json::object();
  double metric_threshold = kDexNetMetricThreshold;
  std::vector<DatasetObject> objects;
  std::vector<ShardEntry> shards;  ///< finished shards only, by index

  std::uint64_t Images() const;
  std::uint64_t Datapoints() const;
  std::uint64_t Positives() const;
};

inline constexpr std::string_view kIndexFileName = "index.json";

nlohmann::json IndexToJson(const DatasetIndex& index);
/// Errors (kInvalidArgument naming the field, e.g. "shards[2].file"): wrong format name or
/// version, missing or mistyped fields, a shard file outside the directory (absolute or with
/// ".."), an object pointing at a shard index that is not listed... Never throws.
core::Result<DatasetIndex> IndexFromJson(const nlohmann::json& json);

/// Atomic like WriteShard.
std::optional<core::Error> WriteIndex(const std::filesystem::path& dataset_dir,
                                      const DatasetIndex& index);
/// kNotFound when the directory has no index; IndexFromJson's errors (field prefixed with the
/// file) for a broken one.
core::Result<DatasetIndex> ReadIndex(const std::filesystem::path& dataset_dir);

}  // namespace softgrasp::gqcnn
