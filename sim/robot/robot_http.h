#pragma once
/// What the simulated robot's camera sees, over HTTP (docs/sim-robot.md), so a client can run
/// "detect -> forward -> execute -> detect again" without a sensor:
///   GET  /depth.npy      float32 (H, W) metres, NaN = missing          (application/x-npy)
///   GET  /depth.png      16-bit millimetres, 0 = missing               (image/png)
///   GET  /camera.intr    GQ-CNN .intr JSON intrinsics (io::ParseIntrinsicsJson reads it)
///   GET  /scene.json     the scene manifest: objects left and their poses, camera, picked ids
///   GET  /stiffness.png  8-bit round(255 * stiffness), 0 = background
///   GET  /labels.png     16-bit instance ids, 0 = support or nothing
///   POST /reset          a new scene; body {} or {"seed": N}; answers like GET /scene.json
///   GET  /               the list above as JSON
/// Every image answer carries X-Scene-Generation (bumps on each pick or reset), so a client can
/// tell that the view changed.

#include <string>

#include "service/http/router.h"
#include "sim/robot/sim_robot.h"

namespace softgrasp::sim {

/// The intrinsics of `camera` as GQ-CNN .intr JSON, frame name "camera".
std::string IntrinsicsJson(const core::Camera& camera);

/// Registers the routes above. `robot` must outlive the router.
void AddSimRobotRoutes(http::Router& router, SimRobot& robot);

}  // namespace softgrasp::sim
