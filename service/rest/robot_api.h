#pragma once
/// The robot routes of openapi.yaml (docs/robot-api.md): POST /v1/robot/grasps,
/// GET /v1/robot/grasps/{id}, GET /v1/robot. Handlers stay thin: authorise, parse, call the
/// CommandTracker, encode.

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "service/config/config.h"
#include "service/core/status.h"
#include "service/http/message.h"
#include "service/http/router.h"
#include "service/robot/command_tracker.h"

namespace softgrasp::rest {

/// True if `presented` equals one of `tokens`. Time depends only on the configured tokens'
/// lengths, not on where `presented` differs from them (no early exit).
bool TokenMatches(std::string_view presented, const std::vector<std::string>& tokens);

/// Checks `Authorization: Bearer <token>`: kUnauthenticated when missing or not a Bearer
/// credential, kPermissionDenied when the token is not one of `tokens`.
core::Result<bridge::Ok> Authorize(const http::Request& request,
                                   const std::vector<std::string>& tokens);

/// Registers the three robot routes. With a null `tracker`, or when
/// config::RobotDisabledReason(config) says so, every one answers 503 with that reason (the routes
/// stay, so clients and the contract see them).
void AddRobotRoutes(http::Router& router, const config::ServiceConfig& config,
                    std::shared_ptr<robot::CommandTracker> tracker);

}  // namespace softgrasp::rest
