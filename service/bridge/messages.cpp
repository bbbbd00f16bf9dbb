#include "service/bridge/messages.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>

namespace softgrasp::bridge {
namespace {

using core::ErrorCode;
using core::MakeError;

// ROS 2 stamps carry int32 seconds, so issued times must fit (until 2038-01-19).
constexpr std::int64_t kMaxUnixNs =
    static_cast<std::int64_t>(std::numeric_limits<std::int32_t>::max()) * 1'000'000'000LL;

core::Error Bad(std::string field, std::string what) {
  return MakeError(ErrorCode::kUnprocessable, field + " " + what, field);
}

// Each check returns the first problem found, or nothing.
using Problem = std::optional<core::Error>;

Problem CheckId(const std::string& value, const std::string& field, bool required) {
  if (required && value.empty()) return Bad(field, "must not be empty");
  if (value.size() > kMaxIdBytes) {
    return Bad(field, "is longer than " + std::to_string(kMaxIdBytes) + " bytes");
  }
  for (char c : value) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      return Bad(field, "must not contain control characters");
    }
  }
  return std::nullopt;
}

Problem CheckText(const std::string& value, const std::string& field) {
  if (value.size() > kMaxTextBytes) {
    return Bad(field, "is longer than " + std::to_string(kMaxTextBytes) + " bytes");
  }
  return std::nullopt;
}

Problem CheckFinite(double value, const std::string& field) {
  if (!std::isfinite(value)) return Bad(field, "must be a finite number");
  return std::nullopt;
}

Problem CheckNonNegative(double value, const std::string& field) {
  if (auto p = CheckFinite(value, field)) return p;
  if (value < 0.0) return Bad(field, "must be >= 0");
  return std::nullopt;
}

template <std::size_t N>
Problem CheckFiniteArray(const std::array<double, N>& values, const std::string& field) {
  for (double v : values) {
    if (auto p = CheckFinite(v, field)) return p;
  }
  return std::nullopt;
}

Problem CheckTime(std::int64_t unix_ns, const std::string& field) {
  if (unix_ns < 0 || unix_ns > kMaxUnixNs) {
    return Bad(field, "must be nanoseconds since 1970 within the int32-seconds range");
  }
  return std::nullopt;
}

Problem CheckWorkspace(const Workspace& w, const std::string& prefix) {
  if (auto p = CheckId(w.frame_id, prefix + "frame_id", true)) return p;
  if (auto p = CheckFiniteArray(w.min_m, prefix + "min_m")) return p;
  if (auto p = CheckFiniteArray(w.max_m, prefix + "max_m")) return p;
  for (std::size_t i = 0; i < 3; ++i) {
    if (w.max_m[i] < w.min_m[i]) return Bad(prefix + "max_m", "must be >= min_m on every axis");
  }
  return std::nullopt;
}

}  // namespace

bool Workspace::Contains(const std::string& frame, const std::array<double, 3>& position_m) const {
  if (frame != frame_id) return false;
  for (std::size_t i = 0; i < 3; ++i) {
    // Written so that NaN is outside.
    if (!(position_m[i] >= min_m[i] && position_m[i] <= max_m[i])) return false;
  }
  return true;
}

const char* OutcomeName(GraspOutcome outcome) {
  switch (outcome) {
    case GraspOutcome::kSucceeded:
      return "succeeded";
    case GraspOutcome::kFailed:
      return "failed";
    case GraspOutcome::kRejected:
      return "rejected";
    case GraspOutcome::kTimedOut:
      return "timed_out";
  }
  return "failed";
}

const char* RobotStateName(RobotState state) {
  switch (state) {
    case RobotState::kIdle:
      return "idle";
    case RobotState::kExecuting:
      return "executing";
    case RobotState::kFault:
      return "fault";
  }
  return "fault";
}

core::Result<Workspace> Validate(Workspace workspace) {
  if (auto p = CheckWorkspace(workspace, "workspace.")) return *p;
  return workspace;
}

core::Result<GraspCommand> Validate(GraspCommand c) {
  Problem p;
  if ((p = CheckId(c.command_id, "command_id", true)) ||
      (p = CheckId(c.robot_id, "robot_id", false)) ||
      (p = CheckId(c.object_id, "object_id", false)) ||
      (p = CheckId(c.frame_id, "frame_id", true)) ||
      (p = CheckFiniteArray(c.position_m, "position_m")) ||
      (p = CheckFiniteArray(c.orientation_xyzw, "orientation_xyzw")) ||
      (p = CheckNonNegative(c.opening_width_m, "opening_width_m")) ||
      (p = CheckNonNegative(c.closing_force_n, "closing_force_n")) ||
      (p = CheckNonNegative(c.approach_m, "approach_m")) ||
      (p = CheckNonNegative(c.retreat_m, "retreat_m")) || (p = CheckFinite(c.score, "score")) ||
      (p = CheckTime(c.issued_unix_ns, "issued_unix_ns"))) {
    return *p;
  }
  if (c.opening_width_m == 0.0) return Bad("opening_width_m", "must be > 0");
  double norm2 = 0.0;
  for (double q : c.orientation_xyzw) norm2 += q * q;
  if (std::abs(std::sqrt(norm2) - 1.0) > 1e-3) {
    return Bad("orientation_xyzw", "must be a unit quaternion (|q| = 1 to 1e-3)");
  }
  return c;
}

core::Result<GraspResult> Validate(GraspResult r) {
  Problem p;
  if ((p = CheckId(r.command_id, "command_id", true)) ||
      (p = CheckId(r.robot_id, "robot_id", true)) ||
      (p = CheckId(r.object_id, "object_id", false)) || (p = CheckText(r.reason, "reason")) ||
      (p = CheckNonNegative(r.contact_width_m, "contact_width_m")) ||
      (p = CheckNonNegative(r.grasped_width_m, "grasped_width_m")) ||
      (p = CheckFinite(r.deformation_rate, "deformation_rate")) ||
      (p = CheckNonNegative(r.execution_s, "execution_s")) ||
      (p = CheckTime(r.finished_unix_ns, "finished_unix_ns"))) {
    return *p;
  }
  switch (r.outcome) {
    case GraspOutcome::kSucceeded:
    case GraspOutcome::kFailed:
    case GraspOutcome::kRejected:
    case GraspOutcome::kTimedOut:
      return r;
  }
  return Bad("outcome", "is not a known GraspOutcome");
}

core::Result<RobotStatus> Validate(RobotStatus s) {
  Problem p;
  if ((p = CheckId(s.robot_id, "robot_id", true)) ||
      (p = CheckWorkspace(s.workspace, "workspace.")) ||
      (p = CheckId(s.current_command_id, "current_command_id", false)) ||
      (p = CheckText(s.detail, "detail")) || (p = CheckTime(s.stamp_unix_ns, "stamp_unix_ns"))) {
    return *p;
  }
  switch (s.state) {
    case RobotState::kIdle:
    case RobotState::kExecuting:
    case RobotState::kFault:
      return s;
  }
  return Bad("state", "is not a known RobotState");
}

std::int64_t UnixNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace softgrasp::bridge
