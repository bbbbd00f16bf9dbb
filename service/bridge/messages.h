#pragma once
/// C++ value types mirroring the DDS contracts in api/softgrasp.idl, their validation, and the
/// conversions to and from the idlc-generated C structs. Nothing here talks to the network.

#include <array>
#include <cstdint>
#include <string>

#include "api/generated/pose_stamped.h"
#include "api/generated/softgrasp.h"
#include "service/core/status.h"

namespace softgrasp::bridge {

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

/// Owns one generated C sample and frees the strings inside it (dds_sample_free with
/// DDS_FREE_CONTENTS) when it goes. Move-only.
template <class CType>
class CSample {
 public:
  explicit CSample(const dds_topic_descriptor_t* descriptor) : descriptor_(descriptor) {}
  ~CSample() { dds_sample_free(&sample_, descriptor_, DDS_FREE_CONTENTS); }
  CSample(const CSample&) = delete;
  CSample& operator=(const CSample&) = delete;
  CSample(CSample&& other) noexcept : descriptor_(other.descriptor_), sample_(other.sample_) {
    other.sample_ = CType{};
  }
  CSample& operator=(CSample&&) = delete;

  CType* get() { return &sample_; }
  const CType& operator*() const { return sample_; }
  const CType* operator->() const { return &sample_; }

 private:
  const dds_topic_descriptor_t* descriptor_;
  CType sample_{};
};

/// C++ -> C. The strings in the returned sample are copies made with dds_string_dup.
/// Precondition: the message passed Validate (conversions do not check again).
CSample<softgrasp_msg_GraspCommand> ToC(const GraspCommand& command);
CSample<softgrasp_msg_GraspResult> ToC(const GraspResult& result);
CSample<softgrasp_msg_RobotStatus> ToC(const RobotStatus& status);

/// C -> C++, validated: a sample from another implementation with a NaN, an unknown enum value
/// or a missing id is an Error, never a crash. Null strings read as "".
core::Result<GraspCommand> FromC(const softgrasp_msg_GraspCommand& c);
core::Result<GraspResult> FromC(const softgrasp_msg_GraspResult& c);
core::Result<RobotStatus> FromC(const softgrasp_msg_RobotStatus& c);

/// The ROS 2 geometry_msgs/PoseStamped of a command: header.stamp = issued time (sec, nanosec),
/// header.frame_id = frame_id, pose = position and orientation. Precondition: validated command.
CSample<geometry_msgs_msg_dds__PoseStamped_> ToPoseStamped(const GraspCommand& command);

/// Nanoseconds since the Unix epoch now (system clock).
std::int64_t UnixNowNs();

}  // namespace softgrasp::bridge
