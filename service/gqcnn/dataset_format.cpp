#include "service/gqcnn/dataset_format.h"

#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "service/cli/files.h"

namespace softgrasp::gqcnn {
namespace {

static_assert(std::endian::native == std::endian::little,
              "shards are little-endian and written by memcpy of native values");

constexpr char kShardMagic[8] = {'S', 'G', 'G', 'Q', 'S', 'H', 'R', 'D'};
/// 2 adds the gripper clearances (clearance.h) at the end of each record; version 1 shards are
/// still read, with clearances NaN (not measured).
constexpr std::uint32_t kShardVersion = 2;
constexpr std::uint32_t kShardVersionWithoutClearance = 1;
constexpr std::size_t kHeaderBytes = sizeof(kShardMagic) + 4 * sizeof(std::uint32_t);
constexpr std::size_t kCrcBytes = sizeof(std::uint32_t);
constexpr const char* kIndexFormat = "softgrasp-gqcnn-dataset";
constexpr int kIndexVersion = 1;

template <class T>
void Put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

template <class T>
T Take(std::string_view bytes, std::size_t& offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  offset += sizeof(T);
  return value;
}

std::uint32_t Crc32(std::string_view bytes) {
  uLong crc = crc32(0L, Z_NULL, 0);
  // zlib takes uInt lengths; shards stay far below 4 GiB but feed in chunks anyway.
  std::size_t offset = 0;
  while (offset < bytes.size()) {
    const std::size_t chunk = std::min<std::size_t>(bytes.size() - offset, 1U << 30);
    crc =
        crc32(crc, reinterpret_cast<const Bytef*>(bytes.data() + offset), static_cast<uInt>(chunk));
    offset += chunk;
  }
  return static_cast<std::uint32_t>(crc);
}

core::Error ShardError(std::string message) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, std::move(message), "shard");
}

core::Error IndexError(std::string message, std::string field) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, std::move(message), std::move(field));
}

bool SafeRelativePath(const std::string& file) {
  if (file.empty()) return false;
  const std::filesystem::path path(file);
  if (path.is_absolute() || path.has_root_name() || path.has_root_directory()) return false;
  for (const auto& part : path) {
    if (part == "..") return false;
  }
  return true;
}

}  // namespace

std::size_t RecordBytes(std::uint32_t version) {
  const std::size_t clearances = version == kShardVersionWithoutClearance ? 0 : 3;
  return sizeof(float) * (kCropPixels + 1 + 7 + 2) + 4 /* flags, padding */ +
         4 * sizeof(std::uint32_t) + sizeof(float) * clearances;
}

std::size_t RecordBytes() { return RecordBytes(kShardVersion); }

std::string EncodeShard(const std::vector<GraspDatapoint>& datapoints) {
  std::string out;
  out.reserve(kHeaderBytes + datapoints.size() * RecordBytes() + kCrcBytes);
  out.append(kShardMagic, sizeof(kShardMagic));
  Put<std::uint32_t>(out, kShardVersion);
  Put<std::uint32_t>(out, kCropSizePx);
  Put<std::uint32_t>(out, static_cast<std::uint32_t>(datapoints.size()));
  Put<std::uint32_t>(out, 0);  // reserved
  for (const GraspDatapoint& d : datapoints) {
    for (float value : d.crop_depth_m) Put(out, value);
    Put(out, d.grasp_depth_m);
    for (float value : d.hand_pose) Put(out, value);
    Put(out, d.robust_ferrari_canny);
    Put(out, d.ferrari_canny);
    Put<std::uint8_t>(out, d.collision_free ? 1 : 0);
    Put<std::uint8_t>(out, d.label ? 1 : 0);
    Put<std::uint16_t>(out, 0);
    Put(out, d.object_index);
    Put(out, d.pose_index);
    Put(out, d.image_index);
    Put(out, d.grasp_index);
    Put(out, d.jaw_clearance_m);
    Put(out, d.palm_clearance_m);
    Put(out, d.floor_clearance_m);
  }
  Put<std::uint32_t>(out, Crc32(out));
  return out;
}

core::Result<std::vector<GraspDatapoint>> DecodeShard(std::string_view bytes) {
  if (bytes.size() < kHeaderBytes + kCrcBytes) {
    return ShardError("a shard is at least " + std::to_string(kHeaderBytes + kCrcBytes) +
                      " bytes; got " + std::to_string(bytes.size()));
  }
  if (std::memcmp(bytes.data(), kShardMagic, sizeof(kShardMagic)) != 0) {
    return ShardError("not a softgrasp GQ-CNN shard (bad magic)");
  }
  std::size_t offset = sizeof(kShardMagic);
  const auto version = Take<std::uint32_t>(bytes, offset);
  const auto crop_px = Take<std::uint32_t>(bytes, offset);
  const auto count = Take<std::uint32_t>(bytes, offset);
  offset += sizeof(std::uint32_t);  // reserved
  if (version != kShardVersion && version != kShardVersionWithoutClearance) {
    return ShardError("shard version " + std::to_string(version) + " is not supported (expected " +
                      std::to_string(kShardVersionWithoutClearance) + " or " +
                      std::to_string(kShardVersion) + ")");
  }
  const std::size_t record_bytes = RecordBytes(version);
  if (crop_px != static_cast<std::uint32_t>(kCropSizePx)) {
    return ShardError("shard crops are " + std::to_string(crop_px) + " px; this build reads " +
                      std::to_string(kCropSizePx) + " px");
  }
  const std::size_t records = bytes.size() - kHeaderBytes - kCrcBytes;
  if (records % record_bytes != 0 || records / record_bytes != count) {
    return ShardError("shard says " + std::to_string(count) + " records but holds " +
                      std::to_string(records) + " bytes of records (" +
                      std::to_string(record_bytes) + " each): cut short?");
  }
  std::size_t crc_offset = bytes.size() - kCrcBytes;
  const auto stored_crc = Take<std::uint32_t>(bytes, crc_offset);
  if (stored_crc != Crc32(bytes.substr(0, bytes.size() - kCrcBytes))) {
    return ShardError("shard CRC mismatch: the file is damaged");
  }
  std::vector<GraspDatapoint> out(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    GraspDatapoint& d = out[i];
    const std::string where = "record " + std::to_string(i) + ": ";
    for (float& value : d.crop_depth_m) {
      value = Take<float>(bytes, offset);
      if (!std::isfinite(value) || value < 0.0F) {
        return ShardError(where + "crop depths must be finite and >= 0 (0 = no reading)");
      }
    }
    d.grasp_depth_m = Take<float>(bytes, offset);
    if (!std::isfinite(d.grasp_depth_m) || d.grasp_depth_m <= 0.0F) {
      return ShardError(where + "grasp depth must be finite and > 0");
    }
    for (float& value : d.hand_pose) {
      value = Take<float>(bytes, offset);
      if (!std::isfinite(value)) return ShardError(where + "hand pose must be finite");
    }
    d.robust_ferrari_canny = Take<float>(bytes, offset);
    d.ferrari_canny = Take<float>(bytes, offset);
    if (!std::isfinite(d.robust_ferrari_canny) || !std::isfinite(d.ferrari_canny)) {
      return ShardError(where + "quality metrics must be finite");
    }
    const auto collision_free = Take<std::uint8_t>(bytes, offset);
    const auto label = Take<std::uint8_t>(bytes, offset);
    offset += sizeof(std::uint16_t);
    if (collision_free > 1 || label > 1) {
      return ShardError(where + "collision_free and label are 0 or 1");
    }
    d.collision_free = collision_free == 1;
    d.label = label == 1;
    d.object_index = Take<std::uint32_t>(bytes, offset);
    d.pose_index = Take<std::uint32_t>(bytes, offset);
    d.image_index = Take<std::uint32_t>(bytes, offset);
    d.grasp_index = Take<std::uint32_t>(bytes, offset);
    if (version == kShardVersionWithoutClearance) continue;
    d.jaw_clearance_m = Take<float>(bytes, offset);
    d.palm_clearance_m = Take<float>(bytes, offset);
    d.floor_clearance_m = Take<float>(bytes, offset);
    for (const float clearance : {d.jaw_clearance_m, d.palm_clearance_m, d.floor_clearance_m}) {
      if (std::isinf(clearance)) {
        return ShardError(where + "clearances must be finite (or NaN: not measured)");
      }
    }
  }
  return out;
}

std::optional<core::Error> WriteShard(const std::filesystem::path& path,
                                      const std::vector<GraspDatapoint>& datapoints) {
  return cli::WriteFile(path, EncodeShard(datapoints), cli::Parents::kCreate);
}

core::Result<std::vector<GraspDatapoint>> ReadShard(const std::filesystem::path& path) {
  auto bytes = cli::ReadFile(path);
  if (!bytes.ok()) return bytes.error();
  auto decoded = DecodeShard(bytes.value());
  if (!decoded.ok()) {
    core::Error error = decoded.error();
    error.message = path.string() + ": " + error.message;
    return error;
  }
  return decoded;
}

std::uint64_t DatasetIndex::Images() const {
  std::uint64_t total = 0;
  for (const ShardEntry& shard : shards) total += shard.images;
  return total;
}

std::uint64_t DatasetIndex::Datapoints() const {
  std::uint64_t total = 0;
  for (const ShardEntry& shard : shards) total += shard.datapoints;
  return total;
}

std::uint64_t DatasetIndex::Positives() const {
  std::uint64_t total = 0;
  for (const ShardEntry& shard : shards) total += shard.positives;
  return total;
}

nlohmann::json IndexToJson(const DatasetIndex& index) {
  nlohmann::json objects = nlohmann::json::array();
  for (const DatasetObject& object : index.objects) {
    objects.push_back({{"name", object.name},
                       {"source", object.source},
                       {"shard", object.shard},
                       {"stable_poses", object.stable_poses},
                       {"grasps", object.grasps}});
  }
  nlohmann::json shards = nlohmann::json::array();
  for (const ShardEntry& shard : index.shards) {
    shards.push_back({{"file", shard.file},
                      {"index", shard.index},
                      {"images", shard.images},
                      {"datapoints", shard.datapoints},
                      {"positives", shard.positives}});
  }
  const std::uint64_t datapoints = index.Datapoints();
  return {{"format", kIndexFormat},
          {"version", kIndexVersion},
          {"crop_size_px", kCropSizePx},
          {"metric_threshold", index.metric_threshold},
          {"generator", index.generator},
          {"objects", objects},
          {"shards", shards},
          {"totals",
           {{"objects", index.objects.size()},
            {"images", index.Images()},
            {"datapoints", datapoints},
            {"positives", index.Positives()},
            {"positive_rate", datapoints == 0 ? 0.0
                                              : static_cast<double>(index.Positives()) /
                                                    static_cast<double>(datapoints)}}}};
}

namespace {

// Typed field access for IndexFromJson: every failure names the field.
struct Fields {
  const nlohmann::json& json;
  std::string prefix;

  const nlohmann::json* Get(const char* name, std::optional<core::Error>& error) const {
    if (error) return nullptr;
    if (!json.is_object() || !json.contains(name)) {
      error = IndexError("missing field", prefix + name);
      return nullptr;
    }
    return &json.at(name);
  }
  std::string String(const char* name, std::optional<core::Error>& error) const {
    const nlohmann::json* value = Get(name, error);
    if (value == nullptr) return {};
    if (!value->is_string()) {
      error = IndexError("must be a string", prefix + name);
      return {};
    }
    return value->get<std::string>();
  }
  std::uint64_t Count(const char* name, std::optional<core::Error>& error) const {
    const nlohmann::json* value = Get(name, error);
    if (value == nullptr) return 0;
    if (!value->is_number_unsigned() &&
        !(value->is_number_integer() && value->get<long long>() >= 0)) {
      error = IndexError("must be a non-negative integer", prefix + name);
      return 0;
    }
    return value->get<std::uint64_t>();
  }
};

}  // namespace

core::Result<DatasetIndex> IndexFromJson(const nlohmann::json& json) {
  std::optional<core::Error> error;
  const Fields top{json, ""};
  if (!json.is_object()) return IndexError("a dataset index is a JSON object", "index");
  if (top.String("format", error) != kIndexFormat && !error) {
    return IndexError(std::string("expected \"") + kIndexFormat + "\"", "format");
  }
  const std::uint64_t version = top.Count("version", error);
  if (!error && version != kIndexVersion) {
    return IndexError("index version " + std::to_string(version) + " is not supported (expected " +
                          std::to_string(kIndexVersion) + ")",
                      "version");
  }
  if (!error && top.Count("crop_size_px", error) != static_cast<std::uint64_t>(kCropSizePx) &&
      !error) {
    return IndexError("this build reads " + std::to_string(kCropSizePx) + " px crops",
                      "crop_size_px");
  }
  DatasetIndex index;
  if (const nlohmann::json* threshold = top.Get("metric_threshold", error)) {
    if (!threshold->is_number() || !std::isfinite(threshold->get<double>()) ||
        threshold->get<double>() < 0.0) {
      return IndexError("must be a finite number >= 0", "metric_threshold");
    }
    index.metric_threshold = threshold->get<double>();
  }
  if (const nlohmann::json* generator = top.Get("generator", error)) {
    if (!generator->is_object()) return IndexError("must be an object", "generator");
    index.generator = *generator;
  }
  const nlohmann::json* shards = top.Get("shards", error);
  const nlohmann::json* objects = top.Get("objects", error);
  if (error) return *error;
  if (!shards->is_array()) return IndexError("must be an array", "shards");
  if (!objects->is_array()) return IndexError("must be an array", "objects");
  for (std::size_t i = 0; i < shards->size(); ++i) {
    const Fields fields{shards->at(i), "shards[" + std::to_string(i) + "]."};
    if (!shards->at(i).is_object()) {
      return IndexError("must be an object", "shards[" + std::to_string(i) + "]");
    }
    ShardEntry shard;
    shard.file = fields.String("file", error);
    const std::uint64_t shard_index = fields.Count("index", error);
    shard.images = fields.Count("images", error);
    shard.datapoints = fields.Count("datapoints", error);
    shard.positives = fields.Count("positives", error);
    if (error) return *error;
    if (!SafeRelativePath(shard.file)) {
      return IndexError("must be a relative path inside the dataset (no \"..\")",
                        fields.prefix + "file");
    }
    if (shard_index > std::numeric_limits<std::uint32_t>::max()) {
      return IndexError("out of range", fields.prefix + "index");
    }
    if (shard.positives > shard.datapoints) {
      return IndexError("more positives than datapoints", fields.prefix + "positives");
    }
    shard.index = static_cast<std::uint32_t>(shard_index);
    for (const ShardEntry& earlier : index.shards) {
      if (earlier.index == shard.index) {
        return IndexError("shard " + std::to_string(shard.index) + " is listed twice",
                          fields.prefix + "index");
      }
    }
    index.shards.push_back(std::move(shard));
  }
  for (std::size_t i = 0; i < objects->size(); ++i) {
    const Fields fields{objects->at(i), "objects[" + std::to_string(i) + "]."};
    if (!objects->at(i).is_object()) {
      return IndexError("must be an object", "objects[" + std::to_string(i) + "]");
    }
    DatasetObject object;
    object.name = fields.String("name", error);
    object.source = fields.String("source", error);
    const std::uint64_t shard = fields.Count("shard", error);
    const std::uint64_t poses = fields.Count("stable_poses", error);
    const std::uint64_t grasps = fields.Count("grasps", error);
    if (error) return *error;
    if (shard > std::numeric_limits<std::uint32_t>::max() ||
        poses > static_cast<std::uint64_t>(std::numeric_limits<int>::max()) ||
        grasps > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) {
      return IndexError("out of range", fields.prefix + "shard");
    }
    object.shard = static_cast<std::uint32_t>(shard);
    object.stable_poses = static_cast<int>(poses);
    object.grasps = static_cast<int>(grasps);
    index.objects.push_back(std::move(object));
  }
  return index;
}

std::optional<core::Error> WriteIndex(const std::filesystem::path& dataset_dir,
                                      const DatasetIndex& index) {
  return cli::WriteFile(dataset_dir / kIndexFileName, IndexToJson(index).dump(1) + "\n",
                        cli::Parents::kCreate);
}

core::Result<DatasetIndex> ReadIndex(const std::filesystem::path& dataset_dir) {
  const std::filesystem::path path = dataset_dir / kIndexFileName;
  auto text = cli::ReadFile(path);
  if (!text.ok()) return text.error();
  const nlohmann::json json = nlohmann::json::parse(text.value(), nullptr, false);
  if (json.is_discarded()) {
    return IndexError(path.string() + " is not valid JSON", std::string(kIndexFileName));
  }
  auto index = IndexFromJson(json);
  if (!index.ok()) {
    core::Error error = index.error();
    error.message = path.string() + ": " + error.field + ": " + error.message;
    return error;
  }
  return index;
}

}  // namespace softgrasp::gqcnn
