#pragma once
/// The one JSON form of each value type the service writes or reads: REST answers, the robot
/// journal, configuration files and dataset manifests all go through these functions, so a field
/// is named, ordered and converted (units, quaternion order) in one place.
///
/// Readers take the JSON value and the path it was found at ("camera", "pose", ...) and name the
/// offending field in their error ("camera.fx", "pose.position_m[1]"): kInvalidArgument when a
/// key is missing or has the wrong type, kUnprocessable when a value has the right type but
/// nothing can use it (not finite, a non-unit quaternion, a focal length <= 0). They do not
/// check ranges a caller's context decides (image limits, the robot's workspace).
///
///   nlohmann::json j = codec::ToJson(camera);
///   auto back = codec::CameraFromJson(j, "camera");

#include <array>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "service/bridge/messages.h"
#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/grasp.h"
#include "service/core/quaternion.h"
#include "service/core/status.h"

namespace softgrasp::codec {

using nlohmann::json;

/// A rigid pose as the API states it: a position in metres and a unit quaternion (w, x, y, z),
/// both in `frame` ("" = unstated).
struct Pose {
  std::string frame;
  std::array<double, 3> position_m{};
  core::QuaternionWxyz orientation_wxyz{1.0, 0.0, 0.0, 0.0};
};

/// {"fx", "fy", "cx", "cy", "width", "height"}: pixels.
json ToJson(const core::Camera& camera);
/// Every key required; focal lengths > 0, sizes >= 1.
core::Result<core::Camera> CameraFromJson(const json& j, std::string_view path);

/// {"opening_stroke_mm", "finger_width_mm", "finger_thickness_mm", "finger_length_mm",
/// "closing_force_n", "friction_coefficient", "max_press_force_n"}: sizes in millimetres as data
/// sheets give them (the REST fields' unit), rounded to a nanometre so they read back as given.
json ToJson(const core::Gripper& gripper);

/// {"top_k", "num_angles", "num_height_steps", "height_step_m"}: the FGE search a request can set.
json ToJson(const core::FgeParams& fge);

/// {"frame", "position_m", "orientation_wxyz"}; "frame" is left out when empty.
json ToJson(const Pose& pose);
/// "position_m" (3 finite numbers) and "orientation_wxyz" (4, norm within 1e-3 of 1) required,
/// "frame" optional (a string).
core::Result<Pose> PoseFromJson(const json& j, std::string_view path);

/// {"frame_id", "min_m", "max_m"}.
json ToJson(const bridge::Workspace& workspace);
/// The keys present replace `base`'s (a configuration file may set one corner); an unknown key,
/// an empty frame or min_m not below max_m on every axis is refused.
core::Result<bridge::Workspace> WorkspaceFromJson(const json& j, std::string_view path,
                                                  const bridge::Workspace& base);

/// A command as the bus carries it (the robot journal's record): the message's own field names,
/// orientation (x, y, z, w) as on DDS / ROS 2. Every key required.
json ToJson(const bridge::GraspCommand& command);
core::Result<bridge::GraspCommand> CommandFromJson(const json& j, std::string_view path);

/// A command as the REST API states it (POST /v1/robot/grasps' fields; the command of a record):
/// {"id", "robot_id", "object_id", "frame_id", "position_m", "orientation_wxyz", "opening_m",
/// "force_n", "approach_m", "retreat_m", "score"}. Its dump is the idempotency fingerprint.
json ApiCommandJson(const bridge::GraspCommand& command);

/// A robot's result as the bus carries it (the robot journal's record). Every key required.
json ToJson(const bridge::GraspResult& result);
core::Result<bridge::GraspResult> ResultFromJson(const json& j, std::string_view path);

}  // namespace softgrasp::codec
