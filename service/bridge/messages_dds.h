#pragma once
/// Private to softgrasp::bridge: the conversions between the C++ value types of messages.h and
/// the idlc-generated C structs of api/generated, and an owner for one generated sample. Only the
/// bridge's own sources (and its tests) include this header: it pulls in Cyclone DDS, which the
/// users of messages.h (configuration, REST, the robot record) do not compile.

#include "api/generated/pose_stamped.h"
#include "api/generated/softgrasp.h"
#include "service/bridge/messages.h"
#include "service/core/status.h"

namespace softgrasp::bridge {

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

}  // namespace softgrasp::bridge
