#pragma once
/// Reads the requests that upload a depth image (POST /v1/grasps, POST /v1/stiffness; multipart
/// form or raw body) into engine inputs. Errors name the field at fault (depth, fx, top_k, ...).

#include <string>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/grasp.h"
#include "service/core/status.h"
#include "service/http/message.h"
#include "service/io/depth_codec.h"
#include "service/rest/config.h"

namespace softgrasp::rest {

/// The decoded depth image and the camera it was taken with.
struct DepthUpload {
  core::DepthImage depth;
  io::DepthFormat depth_format = io::DepthFormat::kNpy;
  core::Camera camera;
  std::string camera_source;  ///< "request" or "default"
};

enum class OutputFormat { kJson, kPng };
enum class GraspStrategy {
  kFge,        ///< classic FGE: graspability (centre of the contact surface)
  kStiffness,  ///< stiffness-aware FGE on the model's map (needs a loaded model)
};
/// What the PNG answer of /v1/grasps shows under the grasps.
enum class OverlayBackground { kDepth, kStiffness };

const char* StrategyName(GraspStrategy strategy);

struct GraspRequest {
  DepthUpload upload;
  core::Gripper gripper;
  core::FgeParams fge;
  GraspStrategy strategy = GraspStrategy::kFge;
  OutputFormat output = OutputFormat::kJson;
  /// PNG answers only: field "draw" = "grasps" (default) or "none" (the picture alone, e.g. as
  /// the background a client draws its own grasps on).
  bool draw_grasps = true;
  /// PNG answers only: field "overlay" = "depth" (default) or "stiffness" (the model's map).
  OverlayBackground overlay = OverlayBackground::kDepth;
  /// File part "segmask" (GQ-CNN's convention: a PNG of the depth's size, non-zero = allowed):
  /// grasps only with contact on the mask. Empty = the whole image.
  cv::Mat1b region_of_interest;
  /// Field "min_depth_m" (default: the configuration's): nearer surfaces are obstacles only.
  double min_depth_m = 0.0;
  /// Field "mean_stiffness" = "true" | "false": whether strategy=fge grasps report the model's
  /// mean stiffness (it costs a model run). Default false; the stiffness strategy always does.
  bool report_mean_stiffness = false;
};

/// `stiffness_model_loaded`: whether strategy=stiffness and overlay=stiffness can be served;
/// it also makes "stiffness" the default strategy.
core::Result<GraspRequest> ParseGraspRequest(const http::Request& request,
                                             const ServiceConfig& config,
                                             bool stiffness_model_loaded);

/// POST /v1/stiffness answer formats: 8-bit PNG (round(255 s)), 16-bit PNG (round(65535 s)),
/// NPY float32 (s itself), or the colour-mapped picture (PNG).
enum class StiffnessFormat { kPng8, kPng16, kNpy, kColor };

struct StiffnessRequest {
  DepthUpload upload;
  StiffnessFormat format = StiffnessFormat::kPng8;
};

/// Fields: the depth (and intrinsics) as for /v1/grasps, png_unit_m, and "format" = png8
/// (default), png16, npy or color; anything else is a 400 naming the field.
core::Result<StiffnessRequest> ParseStiffnessRequest(const http::Request& request,
                                                     const ServiceConfig& config);

}  // namespace softgrasp::rest
