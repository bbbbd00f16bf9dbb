#include "service/bridge/messages_dds.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>

namespace softgrasp::bridge {
namespace {

core::Error Bad(std::string field, std::string what) {
  return core::MakeError(core::ErrorCode::kUnprocessable, field + " " + what, field);
}

// The bytes of a C enum field as an integer. Loading an out-of-range value through the enum type
// is undefined in C++, and a foreign writer can put any 32-bit value there.
template <class CEnum>
std::int32_t RawEnum(const CEnum& field) {
  static_assert(sizeof(CEnum) == sizeof(std::int32_t));
  std::int32_t raw;
  std::memcpy(&raw, &field, sizeof raw);
  return raw;
}

std::string FromCString(const char* s) { return s == nullptr ? std::string() : std::string(s); }

template <class T, std::size_t N>
std::array<T, N> FromCArray(const T (&c)[N]) {
  std::array<T, N> out{};
  for (std::size_t i = 0; i < N; ++i) out[i] = c[i];
  return out;
}

template <class T, std::size_t N>
void ToCArray(const std::array<T, N>& in, T (&c)[N]) {
  for (std::size_t i = 0; i < N; ++i) c[i] = in[i];
}

Workspace WorkspaceFromC(const softgrasp_msg_Workspace& c) {
  return Workspace{FromCString(c.frame_id), FromCArray(c.min_m), FromCArray(c.max_m)};
}

}  // namespace

CSample<softgrasp_msg_GraspCommand> ToC(const GraspCommand& command) {
  CSample<softgrasp_msg_GraspCommand> out(&softgrasp_msg_GraspCommand_desc);
  softgrasp_msg_GraspCommand* c = out.get();
  c->command_id = dds_string_dup(command.command_id.c_str());
  c->robot_id = dds_string_dup(command.robot_id.c_str());
  c->object_id = dds_string_dup(command.object_id.c_str());
  c->frame_id = dds_string_dup(command.frame_id.c_str());
  ToCArray(command.position_m, c->position_m);
  ToCArray(command.orientation_xyzw, c->orientation_xyzw);
  c->opening_width_m = command.opening_width_m;
  c->closing_force_n = command.closing_force_n;
  c->approach_m = command.approach_m;
  c->retreat_m = command.retreat_m;
  c->score = command.score;
  c->issued_unix_ns = command.issued_unix_ns;
  return out;
}

CSample<softgrasp_msg_GraspResult> ToC(const GraspResult& result) {
  CSample<softgrasp_msg_GraspResult> out(&softgrasp_msg_GraspResult_desc);
  softgrasp_msg_GraspResult* c = out.get();
  c->command_id = dds_string_dup(result.command_id.c_str());
  c->robot_id = dds_string_dup(result.robot_id.c_str());
  c->object_id = dds_string_dup(result.object_id.c_str());
  switch (result.outcome) {
    case GraspOutcome::kSucceeded:
      c->outcome = softgrasp_msg_GRASP_OUTCOME_SUCCEEDED;
      break;
    case GraspOutcome::kFailed:
      c->outcome = softgrasp_msg_GRASP_OUTCOME_FAILED;
      break;
    case GraspOutcome::kRejected:
      c->outcome = softgrasp_msg_GRASP_OUTCOME_REJECTED;
      break;
    case GraspOutcome::kTimedOut:
      c->outcome = softgrasp_msg_GRASP_OUTCOME_TIMED_OUT;
      break;
  }
  c->reason = dds_string_dup(result.reason.c_str());
  c->contact_width_m = result.contact_width_m;
  c->grasped_width_m = result.grasped_width_m;
  c->deformation_rate = result.deformation_rate;
  c->execution_s = result.execution_s;
  c->finished_unix_ns = result.finished_unix_ns;
  return out;
}

CSample<softgrasp_msg_RobotStatus> ToC(const RobotStatus& status) {
  CSample<softgrasp_msg_RobotStatus> out(&softgrasp_msg_RobotStatus_desc);
  softgrasp_msg_RobotStatus* c = out.get();
  c->robot_id = dds_string_dup(status.robot_id.c_str());
  switch (status.state) {
    case RobotState::kIdle:
      c->state = softgrasp_msg_ROBOT_STATE_IDLE;
      break;
    case RobotState::kExecuting:
      c->state = softgrasp_msg_ROBOT_STATE_EXECUTING;
      break;
    case RobotState::kFault:
      c->state = softgrasp_msg_ROBOT_STATE_FAULT;
      break;
  }
  c->simulated = status.simulated;
  c->workspace.frame_id = dds_string_dup(status.workspace.frame_id.c_str());
  ToCArray(status.workspace.min_m, c->workspace.min_m);
  ToCArray(status.workspace.max_m, c->workspace.max_m);
  c->current_command_id = dds_string_dup(status.current_command_id.c_str());
  c->detail = dds_string_dup(status.detail.c_str());
  c->heartbeat_seq = status.heartbeat_seq;
  c->stamp_unix_ns = status.stamp_unix_ns;
  return out;
}

core::Result<GraspCommand> FromC(const softgrasp_msg_GraspCommand& c) {
  GraspCommand out;
  out.command_id = FromCString(c.command_id);
  out.robot_id = FromCString(c.robot_id);
  out.object_id = FromCString(c.object_id);
  out.frame_id = FromCString(c.frame_id);
  out.position_m = FromCArray(c.position_m);
  out.orientation_xyzw = FromCArray(c.orientation_xyzw);
  out.opening_width_m = c.opening_width_m;
  out.closing_force_n = c.closing_force_n;
  out.approach_m = c.approach_m;
  out.retreat_m = c.retreat_m;
  out.score = c.score;
  out.issued_unix_ns = c.issued_unix_ns;
  return Validate(std::move(out));
}

core::Result<GraspResult> FromC(const softgrasp_msg_GraspResult& c) {
  GraspResult out;
  out.command_id = FromCString(c.command_id);
  out.robot_id = FromCString(c.robot_id);
  out.object_id = FromCString(c.object_id);
  // The enum's underlying value may be anything a foreign writer put there: map it explicitly.
  switch (RawEnum(c.outcome)) {
    case softgrasp_msg_GRASP_OUTCOME_SUCCEEDED:
      out.outcome = GraspOutcome::kSucceeded;
      break;
    case softgrasp_msg_GRASP_OUTCOME_FAILED:
      out.outcome = GraspOutcome::kFailed;
      break;
    case softgrasp_msg_GRASP_OUTCOME_REJECTED:
      out.outcome = GraspOutcome::kRejected;
      break;
    case softgrasp_msg_GRASP_OUTCOME_TIMED_OUT:
      out.outcome = GraspOutcome::kTimedOut;
      break;
    default:
      return Bad("outcome", "has unknown value " + std::to_string(RawEnum(c.outcome)));
  }
  out.reason = FromCString(c.reason);
  out.contact_width_m = c.contact_width_m;
  out.grasped_width_m = c.grasped_width_m;
  out.deformation_rate = c.deformation_rate;
  out.execution_s = c.execution_s;
  out.finished_unix_ns = c.finished_unix_ns;
  return Validate(std::move(out));
}

core::Result<RobotStatus> FromC(const softgrasp_msg_RobotStatus& c) {
  RobotStatus out;
  out.robot_id = FromCString(c.robot_id);
  switch (RawEnum(c.state)) {
    case softgrasp_msg_ROBOT_STATE_IDLE:
      out.state = RobotState::kIdle;
      break;
    case softgrasp_msg_ROBOT_STATE_EXECUTING:
      out.state = RobotState::kExecuting;
      break;
    case softgrasp_msg_ROBOT_STATE_FAULT:
      out.state = RobotState::kFault;
      break;
    default:
      return Bad("state", "has unknown value " + std::to_string(RawEnum(c.state)));
  }
  out.simulated = c.simulated;
  out.workspace = WorkspaceFromC(c.workspace);
  out.current_command_id = FromCString(c.current_command_id);
  out.detail = FromCString(c.detail);
  out.heartbeat_seq = c.heartbeat_seq;
  out.stamp_unix_ns = c.stamp_unix_ns;
  return Validate(std::move(out));
}

CSample<geometry_msgs_msg_dds__PoseStamped_> ToPoseStamped(const GraspCommand& command) {
  CSample<geometry_msgs_msg_dds__PoseStamped_> out(&geometry_msgs_msg_dds__PoseStamped__desc);
  geometry_msgs_msg_dds__PoseStamped_* c = out.get();
  c->header.stamp.sec = static_cast<std::int32_t>(command.issued_unix_ns / 1'000'000'000LL);
  c->header.stamp.nanosec = static_cast<std::uint32_t>(command.issued_unix_ns % 1'000'000'000LL);
  c->header.frame_id = dds_string_dup(command.frame_id.c_str());
  c->pose.position.x = command.position_m[0];
  c->pose.position.y = command.position_m[1];
  c->pose.position.z = command.position_m[2];
  c->pose.orientation.x = command.orientation_xyzw[0];
  c->pose.orientation.y = command.orientation_xyzw[1];
  c->pose.orientation.z = command.orientation_xyzw[2];
  c->pose.orientation.w = command.orientation_xyzw[3];
  return out;
}

}  // namespace softgrasp::bridge
