#pragma once
/// The REST API of openapi.yaml: HTTP <-> engine. Handlers stay short: decode, call, encode.

#include "service/core/status.h"
#include "service/http/message.h"
#include "service/http/router.h"
#include "service/rest/config.h"

namespace softgrasp::rest {

/// The one mapping from expected failures to HTTP: status and the JSON error body.
int HttpStatusFor(core::ErrorCode code);
http::Response ErrorToResponse(const core::Error& error);

/// A router serving every route documented in openapi.yaml.
http::Router BuildRouter(const ServiceConfig& config);

}  // namespace softgrasp::rest
