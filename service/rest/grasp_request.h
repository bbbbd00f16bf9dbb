#pragma once
/// Reads a POST /v1/grasps request (multipart form or raw body) into engine inputs.

#include <string>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/grasp.h"
#include "service/core/status.h"
#include "service/http/message.h"
#include "service/io/depth_codec.h"
#include "service/rest/config.h"

namespace softgrasp::rest {

enum class OutputFormat { kJson, kPng };

struct GraspRequest {
  core::DepthImage depth;
  io::DepthFormat depth_format = io::DepthFormat::kNpy;
  core::Camera camera;
  std::string camera_source;  ///< "request" or "default"
  core::Gripper gripper;
  core::FgeParams fge;
  OutputFormat output = OutputFormat::kJson;
  /// PNG answers only: field "draw" = "grasps" (default) or "none" (the colour-mapped depth
  /// alone, e.g. as the background a client draws its own grasps on).
  bool draw_grasps = true;
};

/// Validates and decodes. Errors name the field at fault (depth, fx, top_k, ...).
core::Result<GraspRequest> ParseGraspRequest(const http::Request& request,
                                             const ServiceConfig& config);

}  // namespace softgrasp::rest
