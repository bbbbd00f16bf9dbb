#pragma once
/// Reads the requests that upload a depth image (POST /v1/grasps, POST /v1/stiffness,
/// POST /v1/segmentation; multipart form or raw body) into engine inputs. Errors name the field
/// at fault (depth, fx, top_k, ...).

#include <optional>
#include <string>

#include "service/config/config.h"
#include "service/core/depth.h"
#include "service/core/status.h"
#include "service/engine/engine.h"
#include "service/http/message.h"
#include "service/io/depth_codec.h"
#include "service/rest/form_fields.h"
#include "service/segmentation/instances.h"

namespace softgrasp::rest {

/// The decoded depth image and the camera it was taken with.
struct DepthUpload {
  core::DepthImage depth;
  io::DepthFormat depth_format = io::DepthFormat::kNpy;
  core::Camera camera;
  std::string camera_source;  ///< "request" or "default"
};

/// What the PNG answer of /v1/grasps shows under the grasps.
enum class OverlayBackground { kDepth, kStiffness, kDeformability };

/// POST /v1/grasps: the upload, what to plan (engine::PlanOptions, filled from the fields below)
/// and how to answer.
///
/// Planning fields: the gripper (`*_mm`), FGE's (top_k, num_angles, num_height_steps,
/// height_step_mm, grip_depth_mm), "strategy" (engine::Strategies() names; default: the last
/// one the loaded models serve), every strategy's own fields (its room's table,
/// engine::Strategy::fields(): parsed into the chosen strategy's options, checked and unused for
/// the others), the file part "segmask" (GQ-CNN's convention: a PNG of the depth's size, non-zero
/// = contacts allowed), "min_depth_m" (default: the configuration's), "mean_stiffness" = true |
/// false (fge grasps report the stiffness model's mean), the file part "labels" (a 16-bit PNG label
/// image as POST /v1/segmentation?format=labels gives it, used instead of segmenting again),
/// "target" (an instance id), "instances" = true | false (report each grasp's instance; implied by
/// "target" and "labels"), "segmentation" = model | pcl (the segmenter when one runs).
struct GraspRequest {
  DepthUpload upload;
  engine::PlanOptions plan;
  OutputFormat output = OutputFormat::kJson;
  /// PNG answers only: field "draw" = "grasps" (default) or "none" (the picture alone, e.g. as
  /// the background a client draws its own grasps on).
  bool draw_grasps = true;
  /// PNG answers only: field "overlay" = "depth" (default), "stiffness" (the stiffness model's
  /// map) or "deformability" (the segmentation model's map, the target outlined).
  OverlayBackground overlay = OverlayBackground::kDepth;
};

/// The default strategy and the overlays that can be served follow from `models`; whether they
/// serve the strategy is the engine's to check.
core::Result<GraspRequest> ParseGraspRequest(const http::Request& request,
                                             const config::ServiceConfig& config,
                                             const engine::Models& models);

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
                                                     const config::ServiceConfig& config);

/// POST /v1/segmentation answers: the instances as JSON, the 16-bit label image, the coloured
/// overlay picture, or the model's deformability map (encoded as /v1/stiffness encodes its map).
enum class SegmentationFormat { kJson, kLabels, kOverlay, kDeformability };

struct SegmentationRequest {
  DepthUpload upload;
  /// Field "method" = "model" | "pcl" | "fused". Unset: the model when one is loaded, else pcl.
  std::optional<segmentation::Method> method;
  SegmentationFormat format = SegmentationFormat::kJson;
  /// format=deformability only: field "encoding" = png8 (default), png16, npy or color.
  StiffnessFormat encoding = StiffnessFormat::kPng8;
};

/// Fields: the depth (and intrinsics) as for /v1/grasps, png_unit_m, "method", "format" = json
/// (default), labels, overlay or deformability, and "encoding" (format=deformability only);
/// anything else is a 400 naming the field. Whether the method can serve is checked later
/// (ResolveSegmentationMethod).
core::Result<SegmentationRequest> ParseSegmentationRequest(const http::Request& request,
                                                           const config::ServiceConfig& config);

}  // namespace softgrasp::rest
