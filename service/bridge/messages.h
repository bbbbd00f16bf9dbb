#pragma once
/// C++ value types mirroring the DDS contracts in api/softgrasp.idl and their validation. Plain
/// C++: no Cyclone DDS or generated header is included, so configuration and REST code can use
/// these types without compiling the DDS API. The conversions to and from the idlc-generated C
/// structs are in messages_dds.h, private to the bridge. Nothing here talks to the network.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "service/core/status.h"

namespace softgrasp::bridge {

/// Value for "it worked" where there is nothing to return.
struct Ok {};

/// Axis-aligned box in a named frame (metres).
struct Workspace {
  std::string frame_id;
  std::array<double, 3> min_m{};
  std::array<double, 3> max_m{};

  /// True if `position_m` (given in `frame`) lies inside the box, faces included. A pose in
  /// another frame is never inside: the bridge does not transform between frames.
  bool Contains(const std::string& frame, const std::array<double, 3>& position_m) const;
};

/// A grasp for a robot to execute (topic softgrasp/grasp_command). See the IDL for field meaning.
struct GraspCommand {
  std::string command_id;
  std::string robot_id;  ///< "" = any robot
  std::string object_id;
  std::string frame_id;
  std::array<double, 3> position_m{};
  std::array<double, 4> orientation_xyzw{0.0, 0.0, 0.0, 1.0};
  double opening_width_m = 0.0;
  double closing_force_n = 0.0;
  double approach_m = 0.0;
  double retreat_m = 0.0;
  double score = 0.0;
  std::int64_t issued_unix_ns = 0;
};

enum class GraspOutcome { kSucceeded, kFailed, kRejected, kTimedOut };

/// A robot's answer to one command (topic softgrasp/grasp_result).
struct GraspResult {
  std::string command_id;
  std::string robot_id;
  std::string object_id;
  GraspOutcome outcome = GraspOutcome::kFailed;
  std::string reason;
  double contact_width_m = 0.0;  ///< l_c
  double grasped_width_m = 0.0;  ///< l_g
  double deformation_rate = 0.0;
  double execution_s = 0.0;
  std::int64_t finished_unix_ns = 0;
};

enum class RobotState { kIdle, kExecuting, kFault };

/// A robot's heartbeat (topic softgrasp/robot_status).
struct RobotStatus {
  std::string robot_id;
  RobotState state = RobotState::kIdle;
  bool simulated = false;
  Workspace workspace;
  std::string current_command_id;
  std::string detail;
  std::uint64_t heartbeat_seq = 0;
  std::int64_t stamp_unix_ns = 0;
};

/// What the service knows about one robot.
struct RobotInfo {
  RobotStatus status;  ///< the last heartbeat
  /// True while the robot's status instance is ALIVE: at least one live writer. False once its
  /// writer is gone or lost liveliness (NOT_ALIVE_NO_WRITERS) or disposed it.
  bool alive = false;
  double heartbeat_age_s = 0.0;  ///< local time since that heartbeat arrived
};

/// Stable lower-case names ("succeeded", "timed_out", "idle", ...), as REST shows them.
const char* OutcomeName(GraspOutcome outcome);
const char* RobotStateName(RobotState state);

/// Longest id (command, robot, object) and frame name the bridge accepts, in bytes.
inline constexpr std::size_t kMaxIdBytes = 256;
/// Longest free text (reason, detail) the bridge accepts, in bytes.
inline constexpr std::size_t kMaxTextBytes = 4096;

/// Checks what a message must satisfy before it goes on the bus (and after it comes off it):
/// every number finite, ids present and bounded, the quaternion of unit length (to 1e-3),
/// distances, widths and forces non-negative, the box ordered. Errors are kUnprocessable with
/// `field` naming the offending field.
core::Result<GraspCommand> Validate(GraspCommand command);
core::Result<GraspResult> Validate(GraspResult result);
core::Result<RobotStatus> Validate(RobotStatus status);
core::Result<Workspace> Validate(Workspace workspace);

/// Nanoseconds since the Unix epoch now (system clock).
std::int64_t UnixNowNs();

}  // namespace softgrasp::bridge
