#pragma once
/// POST /v1/robot/grasps: the JSON body (a grasp as /v1/grasps returns it, plus the command's
/// id, force, frame and robot) checked and turned into a bridge::GraspCommand. Field names in
/// errors are the request's, e.g. "pose.position_m[2]".

#include <string>
#include <string_view>

#include "service/bridge/messages.h"
#include "service/config/config.h"
#include "service/core/status.h"

namespace softgrasp::rest {

struct RobotGraspRequest {
  bridge::GraspCommand command;  ///< robot_id as requested ("" = the only robot alive)
  /// The request after defaults, as canonical JSON: the same id with another fingerprint is a
  /// conflict. Fields the command does not use (rank, center_px, ...) are not part of it.
  std::string fingerprint;
};

/// True for [A-Za-z0-9._-]{1,64}: command ids and robot ids in requests and paths.
bool IsValidClientId(std::string_view id);

/// Errors: kInvalidArgument (not JSON, wrong type or shape, bad id; 400), kUnprocessable (a
/// number that is not finite or out of range, a quaternion that is not unit length, a pose
/// outside robot.workspace or in another frame; 422). `field` names the offending field.
core::Result<RobotGraspRequest> ParseRobotGraspRequest(std::string_view body,
                                                       const config::RobotConfig& config);

}  // namespace softgrasp::rest
