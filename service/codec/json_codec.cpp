#include "service/codec/json_codec.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>

namespace softgrasp::codec {
namespace {

using core::ErrorCode;
using core::MakeError;

// A missing key or a wrong type: the JSON has the wrong shape.
core::Error Invalid(const std::string& field, const std::string& problem) {
  return MakeError(ErrorCode::kInvalidArgument, field + " " + problem, field);
}
// The right shape, but a value nothing can use.
core::Error Unusable(const std::string& field, const std::string& problem) {
  return MakeError(ErrorCode::kUnprocessable, field + " " + problem, field);
}

// Reads the members of one JSON object into C++ values, remembering the first problem with the
// path of the field at fault. Each Read leaves its target alone once a problem is recorded.
class Fields {
 public:
  Fields(const json& j, std::string_view path) : j_(j), path_(path) {
    if (!j_.is_object()) error_ = Invalid(path_, "must be a JSON object");
  }

  std::string PathOf(const char* key) const { return path_ + "." + key; }

  // nullptr when absent (a problem when `required`) or when an earlier problem stopped reading.
  const json* Find(const char* key, bool required) {
    if (error_) return nullptr;
    const auto it = j_.find(key);
    if (it == j_.end()) {
      if (required) error_ = Invalid(PathOf(key), "is required");
      return nullptr;
    }
    return &*it;
  }

  void Number(const char* key, double* out, bool required = true) {
    const json* v = Find(key, required);
    if (!v) return;
    if (!v->is_number()) {
      error_ = Invalid(PathOf(key), "must be a number");
      return;
    }
    if (!std::isfinite(v->get<double>())) {
      error_ = Unusable(PathOf(key), "must be a finite number");
      return;
    }
    *out = v->get<double>();
  }

  template <class Int>
  void Integer(const char* key, Int* out) {
    const json* v = Find(key, true);
    if (!v) return;
    if (!v->is_number_integer()) {
      error_ = Invalid(PathOf(key), "must be an integer");
      return;
    }
    const bool fits =
        v->is_number_unsigned()
            ? v->get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<Int>::max())
            : v->get<std::int64_t>() >= std::numeric_limits<Int>::min() &&
                  v->get<std::int64_t>() <= std::numeric_limits<Int>::max();
    if (!fits) {
      error_ = Unusable(PathOf(key), "is out of range");
      return;
    }
    *out = v->get<Int>();
  }

  void Text(const char* key, std::string* out, bool required = true) {
    const json* v = Find(key, required);
    if (!v) return;
    if (!v->is_string()) {
      error_ = Invalid(PathOf(key), "must be a string");
      return;
    }
    *out = v->get<std::string>();
  }

  template <std::size_t N>
  void Numbers(const char* key, std::array<double, N>* out, bool required = true) {
    const json* v = Find(key, required);
    if (!v) return;
    if (!v->is_array() || v->size() != N) {
      error_ = Invalid(PathOf(key), "must be an array of " + std::to_string(N) + " numbers");
      return;
    }
    std::array<double, N> values{};
    for (std::size_t i = 0; i < N; ++i) {
      const std::string at = PathOf(key) + "[" + std::to_string(i) + "]";
      if (!(*v)[i].is_number()) {
        error_ = Invalid(at, "must be a number");
        return;
      }
      values[i] = (*v)[i].get<double>();
      if (!std::isfinite(values[i])) {
        error_ = Unusable(at, "must be a finite number");
        return;
      }
    }
    *out = values;
  }

  // A value of the right shape that cannot be used.
  void Refuse(const char* key, const std::string& problem) {
    if (!error_) error_ = Unusable(PathOf(key), problem);
  }
  void Fail(const char* key, const std::string& problem) {
    if (!error_) error_ = Invalid(PathOf(key), problem);
  }

  const std::optional<core::Error>& error() const { return error_; }

 private:
  const json& j_;
  std::string path_;
  std::optional<core::Error> error_;
};

std::optional<bridge::GraspOutcome> OutcomeByName(std::string_view name) {
  for (const bridge::GraspOutcome o :
       {bridge::GraspOutcome::kSucceeded, bridge::GraspOutcome::kFailed,
        bridge::GraspOutcome::kRejected, bridge::GraspOutcome::kTimedOut}) {
    if (name == bridge::OutcomeName(o)) return o;
  }
  return std::nullopt;
}

}  // namespace

json ToJson(const core::Camera& c) {
  return {{"fx", c.fx}, {"fy", c.fy},       {"cx", c.cx},
          {"cy", c.cy}, {"width", c.width}, {"height", c.height}};
}

core::Result<core::Camera> CameraFromJson(const json& j, std::string_view path) {
  core::Camera c;
  Fields f(j, path);
  f.Number("fx", &c.fx);
  f.Number("fy", &c.fy);
  f.Number("cx", &c.cx);
  f.Number("cy", &c.cy);
  f.Integer("width", &c.width);
  f.Integer("height", &c.height);
  if (!f.error()) {
    if (!(c.fx > 0)) f.Refuse("fx", "must be > 0");
    if (!(c.fy > 0)) f.Refuse("fy", "must be > 0");
    if (c.width < 1) f.Refuse("width", "must be >= 1");
    if (c.height < 1) f.Refuse("height", "must be >= 1");
  }
  if (f.error()) return *f.error();
  return c;
}

json ToJson(const core::Gripper& g) {
  return {{"opening_stroke_mm", core::MmFromMetres(g.opening_stroke_m)},
          {"finger_width_mm", core::MmFromMetres(g.finger_width_m)},
          {"finger_thickness_mm", core::MmFromMetres(g.finger_thickness_m)},
          {"finger_length_mm", core::MmFromMetres(g.finger_length_m)},
          {"closing_force_n", g.closing_force_n},
          {"friction_coefficient", g.friction_coefficient},
          {"max_press_force_n", g.max_press_force_n}};
}

json ToJson(const core::FgeParams& p) {
  return {{"top_k", p.top_k},
          {"num_angles", p.num_angles},
          {"num_height_steps", p.num_height_steps},
          {"height_step_m", p.height_step_m}};
}

json ToJson(const Pose& p) {
  json j = {{"position_m", p.position_m}, {"orientation_wxyz", p.orientation_wxyz}};
  if (!p.frame.empty()) j["frame"] = p.frame;
  return j;
}

core::Result<Pose> PoseFromJson(const json& j, std::string_view path) {
  Pose p;
  Fields f(j, path);
  f.Numbers("position_m", &p.position_m);
  f.Numbers("orientation_wxyz", &p.orientation_wxyz);
  f.Text("frame", &p.frame, /*required=*/false);
  if (f.error()) return *f.error();
  const double norm = core::QuaternionNorm(p.orientation_wxyz);
  if (std::abs(norm - 1.0) > 1e-3) {
    std::ostringstream os;
    os << "must be a unit quaternion (its norm is " << norm << ")";
    f.Refuse("orientation_wxyz", os.str());
    return *f.error();
  }
  return p;
}

json ToJson(const bridge::Workspace& w) {
  return {{"frame_id", w.frame_id}, {"min_m", w.min_m}, {"max_m", w.max_m}};
}

core::Result<bridge::Workspace> WorkspaceFromJson(const json& j, std::string_view path,
                                                  const bridge::Workspace& base) {
  bridge::Workspace w = base;
  Fields f(j, path);
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      if (key != "frame_id" && key != "min_m" && key != "max_m") {
        f.Fail(key.c_str(), "is not a workspace key (frame_id, min_m, max_m)");
      }
    }
  }
  f.Text("frame_id", &w.frame_id, /*required=*/false);
  f.Numbers("min_m", &w.min_m, /*required=*/false);
  f.Numbers("max_m", &w.max_m, /*required=*/false);
  if (!f.error() && w.frame_id.empty()) f.Fail("frame_id", "must be a non-empty string");
  for (std::size_t i = 0; i < 3 && !f.error(); ++i) {
    if (!(w.min_m[i] < w.max_m[i])) f.Refuse("min_m", "must be below max_m on every axis");
  }
  if (f.error()) return *f.error();
  return w;
}

json ToJson(const bridge::GraspCommand& c) {
  return {{"command_id", c.command_id},
          {"robot_id", c.robot_id},
          {"object_id", c.object_id},
          {"frame_id", c.frame_id},
          {"position_m", c.position_m},
          {"orientation_xyzw", c.orientation_xyzw},
          {"opening_width_m", c.opening_width_m},
          {"closing_force_n", c.closing_force_n},
          {"approach_m", c.approach_m},
          {"retreat_m", c.retreat_m},
          {"score", c.score},
          {"issued_unix_ns", c.issued_unix_ns}};
}

core::Result<bridge::GraspCommand> CommandFromJson(const json& j, std::string_view path) {
  bridge::GraspCommand c;
  Fields f(j, path);
  f.Text("command_id", &c.command_id);
  f.Text("robot_id", &c.robot_id);
  f.Text("object_id", &c.object_id);
  f.Text("frame_id", &c.frame_id);
  f.Numbers("position_m", &c.position_m);
  f.Numbers("orientation_xyzw", &c.orientation_xyzw);
  f.Number("opening_width_m", &c.opening_width_m);
  f.Number("closing_force_n", &c.closing_force_n);
  f.Number("approach_m", &c.approach_m);
  f.Number("retreat_m", &c.retreat_m);
  f.Number("score", &c.score);
  f.Integer("issued_unix_ns", &c.issued_unix_ns);
  if (f.error()) return *f.error();
  return c;
}

json ApiCommandJson(const bridge::GraspCommand& c) {
  return {{"id", c.command_id},
          {"robot_id", c.robot_id},
          {"object_id", c.object_id},
          {"frame_id", c.frame_id},
          {"position_m", c.position_m},
          {"orientation_wxyz", core::WxyzFromXyzw(c.orientation_xyzw)},
          {"opening_m", c.opening_width_m},
          {"force_n", c.closing_force_n},
          {"approach_m", c.approach_m},
          {"retreat_m", c.retreat_m},
          {"score", c.score}};
}

json ToJson(const bridge::GraspResult& r) {
  return {{"command_id", r.command_id},
          {"robot_id", r.robot_id},
          {"object_id", r.object_id},
          {"outcome", bridge::OutcomeName(r.outcome)},
          {"reason", r.reason},
          {"contact_width_m", r.contact_width_m},
          {"grasped_width_m", r.grasped_width_m},
          {"deformation_rate", r.deformation_rate},
          {"execution_s", r.execution_s},
          {"finished_unix_ns", r.finished_unix_ns}};
}

core::Result<bridge::GraspResult> ResultFromJson(const json& j, std::string_view path) {
  bridge::GraspResult r;
  Fields f(j, path);
  f.Text("command_id", &r.command_id);
  f.Text("robot_id", &r.robot_id);
  f.Text("object_id", &r.object_id);
  std::string outcome;
  f.Text("outcome", &outcome);
  if (!f.error()) {
    if (const auto known = OutcomeByName(outcome)) {
      r.outcome = *known;
    } else {
      f.Fail("outcome",
             "'" + outcome + "' is not an outcome (succeeded, failed, rejected, " + "timed_out)");
    }
  }
  f.Text("reason", &r.reason);
  f.Number("contact_width_m", &r.contact_width_m);
  f.Number("grasped_width_m", &r.grasped_width_m);
  f.Number("deformation_rate", &r.deformation_rate);
  f.Number("execution_s", &r.execution_s);
  f.Integer("finished_unix_ns", &r.finished_unix_ns);
  if (f.error()) return *f.error();
  return r;
}

}  // namespace softgrasp::codec
