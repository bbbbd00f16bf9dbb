#pragma once
/// The REST API of openapi.yaml: HTTP <-> engine. Handlers stay short: decode, call, encode.

#include <memory>

#include "service/core/status.h"
#include "service/http/message.h"
#include "service/http/router.h"
#include "service/rest/config.h"
#include "service/robot/command_tracker.h"

namespace softgrasp::rest {

/// The one mapping from expected failures to HTTP: status and the JSON error body.
int HttpStatusFor(core::ErrorCode code);
http::Response ErrorToResponse(const core::Error& error);

/// A router serving every route documented in openapi.yaml. The robot routes answer 503 (no
/// robot bus in this process).
http::Router BuildRouter(const ServiceConfig& config);
/// The same, with the robot routes served by `robot` (null: 503, as above).
http::Router BuildRouter(const ServiceConfig& config, std::shared_ptr<robot::CommandTracker> robot);

}  // namespace softgrasp::rest
