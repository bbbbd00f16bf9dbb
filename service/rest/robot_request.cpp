#include "service/rest/robot_request.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <vector>

#include "service/codec/json_codec.h"
#include "service/core/quaternion.h"

namespace softgrasp::rest {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

constexpr std::size_t kMaxClientIdBytes = 64;
constexpr double kDefaultApproachM = 0.10;
constexpr double kDefaultRetreatM = 0.10;

// Builds the document like nlohmann's own DOM parser, but knows the path of the value being
// read. JSON numbers too large for a double ("1e400") are a parse error in nlohmann; with the
// path we can say which field was not finite (422) instead of "malformed JSON" (400).
class PathTrackingSax {
 public:
  json root;
  std::string error_message;
  std::string error_field;
  bool not_finite = false;

  bool null() { return Put(nullptr) != nullptr; }
  bool boolean(bool v) { return Put(v) != nullptr; }
  bool number_integer(json::number_integer_t v) { return Put(v) != nullptr; }
  bool number_unsigned(json::number_unsigned_t v) { return Put(v) != nullptr; }
  bool number_float(json::number_float_t v, const std::string&) { return Put(v) != nullptr; }
  bool string(std::string& v) { return Put(v) != nullptr; }
  bool binary(json::binary_t& v) { return Put(json::binary(v)) != nullptr; }
  bool start_object(std::size_t) { return Open(json::object()); }
  bool start_array(std::size_t) { return Open(json::array()); }
  bool end_object() { return Close(); }
  bool end_array() { return Close(); }
  bool key(std::string& k) {
    stack_.back().key = k;
    return true;
  }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& e) {
    not_finite = e.id == 406;  // out_of_range: number overflow
    error_field = PathOfNext();
    std::ostringstream os;
    os << "the body is not valid JSON (at byte " << position << ")";
    error_message = os.str();
    return false;
  }

 private:
  struct Level {
    json* value;
    std::string path;
    std::string key;  // objects: the key of the value being read
  };

  std::string PathOfNext() const {
    if (stack_.empty()) return {};
    const Level& top = stack_.back();
    if (top.value->is_object()) return top.path.empty() ? top.key : top.path + "." + top.key;
    return top.path + "[" + std::to_string(top.value->size()) + "]";
  }

  json* Put(json v) {
    if (stack_.empty()) {
      root = std::move(v);
      return &root;
    }
    Level& top = stack_.back();
    if (top.value->is_object()) return &((*top.value)[top.key] = std::move(v));
    top.value->push_back(std::move(v));
    return &top.value->back();
  }
  bool Open(json container) {
    const std::string path = PathOfNext();
    json* slot = Put(std::move(container));
    stack_.push_back(Level{slot, path, {}});
    return true;
  }
  bool Close() {
    stack_.pop_back();
    return true;
  }

  std::vector<Level> stack_;
};

core::Error Bad(const std::string& field, const std::string& message) {
  return MakeError(ErrorCode::kInvalidArgument, field + " " + message, field);
}
core::Error Unusable(const std::string& field, const std::string& message) {
  return MakeError(ErrorCode::kUnprocessable, field + " " + message, field);
}

// A number field: wrong type is 400; the range check is the caller's (422).
core::Result<double> NumberAt(const json& parent, const std::string& key, const std::string& field,
                              std::optional<double> fallback) {
  if (!parent.contains(key) || parent[key].is_null()) {
    if (fallback) return *fallback;
    return Bad(field, "is required");
  }
  if (!parent[key].is_number()) return Bad(field, "must be a number");
  const double v = parent[key].get<double>();
  if (!std::isfinite(v)) return Unusable(field, "must be a finite number");
  return v;
}

core::Result<std::string> IdAt(const json& body, const std::string& key, bool required) {
  if (!body.contains(key) || body[key].is_null()) {
    if (required) {
      return Bad(key, "is required: a client-chosen id ([A-Za-z0-9._-], 1 to 64 characters)");
    }
    return std::string();
  }
  if (!body[key].is_string() || !IsValidClientId(body[key].get<std::string>())) {
    return Bad(key, "must be 1 to 64 characters from A-Z a-z 0-9 . _ -");
  }
  return body[key].get<std::string>();
}

core::Result<double> InRange(core::Result<double> v, const std::string& field, double min,
                             double max, bool min_exclusive) {
  if (!v) return v;
  const double x = v.value();
  if ((min_exclusive ? !(x > min) : !(x >= min)) || x > max) {
    std::ostringstream os;
    os << "must be in " << (min_exclusive ? "(" : "[") << min << ", " << max << "], got " << x;
    return Unusable(field, os.str());
  }
  return v;
}

std::string Box(const bridge::Workspace& w) {
  std::ostringstream os;
  os << "[" << w.min_m[0] << ", " << w.max_m[0] << "] x [" << w.min_m[1] << ", " << w.max_m[1]
     << "] x [" << w.min_m[2] << ", " << w.max_m[2] << "] m in frame " << w.frame_id;
  return os.str();
}

}  // namespace

bool IsValidClientId(std::string_view id) {
  if (id.empty() || id.size() > kMaxClientIdBytes) return false;
  for (const char c : id) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

core::Result<RobotGraspRequest> ParseRobotGraspRequest(std::string_view body_text,
                                                       const config::RobotConfig& config) {
  PathTrackingSax sax;
  if (!json::sax_parse(body_text, &sax)) {
    if (sax.not_finite) return Unusable(sax.error_field, "must be a finite number");
    return MakeError(ErrorCode::kInvalidArgument, sax.error_message, sax.error_field);
  }
  const json& body = sax.root;
  if (!body.is_object()) {
    return MakeError(ErrorCode::kInvalidArgument, "the body must be a JSON object (a grasp)");
  }

  RobotGraspRequest out;
  bridge::GraspCommand& c = out.command;
  auto id = IdAt(body, "id", /*required=*/true);
  if (!id) return id.error();
  c.command_id = id.value();
  auto robot_id = IdAt(body, "robot_id", /*required=*/false);
  if (!robot_id) return robot_id.error();
  c.robot_id = robot_id.value();
  if (body.contains("object_id") && !body["object_id"].is_null()) {
    if (!body["object_id"].is_string() || body["object_id"].get<std::string>().size() > 256) {
      return Bad("object_id", "must be a string of at most 256 bytes");
    }
    c.object_id = body["object_id"].get<std::string>();
  }

  if (!body.contains("pose") || !body["pose"].is_object()) {
    return Bad("pose", "is required: {frame, position_m [x, y, z], orientation_wxyz [w, x, y, z]}");
  }
  auto pose = codec::PoseFromJson(body["pose"], "pose");
  if (!pose) return pose.error();
  c.position_m = pose.value().position_m;
  c.orientation_xyzw = core::XyzwFromWxyz(pose.value().orientation_wxyz);

  // The frame: frame_id, else the pose's own frame, else the camera's.
  const std::string& pose_frame = pose.value().frame;
  if (body.contains("frame_id") && !body["frame_id"].is_null()) {
    if (!body["frame_id"].is_string() || body["frame_id"].get<std::string>().empty()) {
      return Bad("frame_id", "must be a non-empty string");
    }
    c.frame_id = body["frame_id"].get<std::string>();
    if (!pose_frame.empty() && pose_frame != c.frame_id) {
      return Unusable("frame_id",
                      "'" + c.frame_id + "' contradicts pose.frame '" + pose_frame + "'");
    }
  } else {
    c.frame_id = pose_frame.empty() ? "camera" : pose_frame;
  }
  if (c.frame_id != config.workspace.frame_id) {
    return Unusable("frame_id", "'" + c.frame_id + "' is not the workspace's frame '" +
                                    config.workspace.frame_id +
                                    "' (the service does not transform between frames)");
  }
  if (!config.workspace.Contains(c.frame_id, c.position_m)) {
    std::ostringstream os;
    os << "(" << c.position_m[0] << ", " << c.position_m[1] << ", " << c.position_m[2]
       << ") is outside the robot workspace " << Box(config.workspace);
    return Unusable("pose.position_m", os.str());
  }

  auto opening = InRange(NumberAt(body, "opening_m", "opening_m", std::nullopt), "opening_m", 0.0,
                         1.0, /*min_exclusive=*/true);
  auto force = InRange(NumberAt(body, "force_n", "force_n", config.default_force_n), "force_n", 0.0,
                       1000.0, true);
  auto approach = InRange(NumberAt(body, "approach_m", "approach_m", kDefaultApproachM),
                          "approach_m", 0.0, 1.0, false);
  auto retreat = InRange(NumberAt(body, "retreat_m", "retreat_m", kDefaultRetreatM), "retreat_m",
                         0.0, 1.0, false);
  auto score = NumberAt(body, "score", "score", 0.0);
  for (const auto* r : {&opening, &force, &approach, &retreat, &score}) {
    if (!*r) return r->error();
  }
  c.opening_width_m = opening.value();
  c.closing_force_n = force.value();
  c.approach_m = approach.value();
  c.retreat_m = retreat.value();
  c.score = score.value();

  out.fingerprint = codec::ApiCommandJson(c).dump();
  return out;
}

}  // namespace softgrasp::rest
