#pragma once
/// Reads the requests that upload a depth image (POST /v1/grasps, POST /v1/stiffness,
/// POST /v1/segmentation; multipart form or raw body) into engine inputs. Errors name the field
/// at fault (depth, fx, top_k, ...).

#include <optional>
#include <string>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/fge_deformability.h"
#include "service/core/grasp.h"
#include "service/core/status.h"
#include "service/http/message.h"
#include "service/io/depth_codec.h"
#include "service/rest/config.h"
#include "service/segmentation/instances.h"

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
  /// Algorithm 1 on one target object with the segmentation model's deformability map
  /// (docs/deformability.md; needs a loaded segmentation model)
  kDeformability,
};
/// What the PNG answer of /v1/grasps shows under the grasps.
enum class OverlayBackground { kDepth, kStiffness, kDeformability };

const char* StrategyName(GraspStrategy strategy);

struct GraspRequest {
  DepthUpload upload;
  core::Gripper gripper;
  core::FgeParams fge;
  GraspStrategy strategy = GraspStrategy::kFge;
  /// strategy=deformability: fields target_policy, min_target_area_px (K), slice_step_mm (L),
  /// num_slices (M), min_score (R), opening_fractions, stiff_part_fraction,
  /// soft_obstacle_threshold, max_press_depth_mm; target_id is copied from "target".
  core::DeformabilityParams deformability;
  OutputFormat output = OutputFormat::kJson;
  /// PNG answers only: field "draw" = "grasps" (default) or "none" (the picture alone, e.g. as
  /// the background a client draws its own grasps on).
  bool draw_grasps = true;
  /// PNG answers only: field "overlay" = "depth" (default), "stiffness" (the stiffness model's
  /// map) or "deformability" (the segmentation model's map, the target outlined).
  OverlayBackground overlay = OverlayBackground::kDepth;
  /// File part "segmask" (GQ-CNN's convention: a PNG of the depth's size, non-zero = allowed):
  /// grasps only with contact on the mask. Empty = the whole image.
  cv::Mat1b region_of_interest;
  /// Field "min_depth_m" (default: the configuration's): nearer surfaces are obstacles only.
  double min_depth_m = 0.0;
  /// Field "mean_stiffness" = "true" | "false": whether strategy=fge grasps report the model's
  /// mean stiffness (it costs a model run). Default false; the stiffness strategy always does.
  bool report_mean_stiffness = false;
  /// File part "labels": an instance label image of the depth's size (the 16-bit PNG of
  /// POST /v1/segmentation?format=labels; 0 = no object), used instead of segmenting again.
  /// Empty = none given.
  cv::Mat1w instance_labels;
  /// Field "target" (> 0): only grasps with contacts on this instance; other objects stay
  /// obstacles. 0 = any object.
  int target_id = 0;
  /// Field "instances" = "true" | "false": report each grasp's instance (segments the scene
  /// unless labels are given). Default false; implied by "target" and by a "labels" part.
  bool report_instances = false;
  /// Field "segmentation" = "model" | "pcl": the segmenter when one has to run. Unset: the
  /// model when one is loaded, else pcl.
  std::optional<segmentation::Method> segmentation_method;
  /// Whether the answer needs an instance segmentation (given or computed).
  bool wants_instances() const {
    return report_instances || target_id > 0 || !instance_labels.empty() ||
           strategy == GraspStrategy::kDeformability ||
           overlay == OverlayBackground::kDeformability;
  }
};

/// Which models the service has loaded: they decide what can be served and the default
/// strategy (deformability with a segmentation model, else stiffness with a stiffness model,
/// else fge).
struct LoadedModels {
  bool stiffness = false;     ///< strategy=stiffness, overlay=stiffness, mean_stiffness
  bool segmentation = false;  ///< strategy=deformability, overlay=deformability
};

core::Result<GraspRequest> ParseGraspRequest(const http::Request& request,
                                             const ServiceConfig& config, LoadedModels models);

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

/// POST /v1/segmentation answers: the instances as JSON, the 16-bit label image, the coloured
/// overlay picture, or the model's deformability map (encoded as /v1/stiffness encodes its map).
enum class SegmentationFormat { kJson, kLabels, kOverlay, kDeformability };

struct SegmentationRequest {
  DepthUpload upload;
  /// Field "method" = "model" | "pcl". Unset: the model when one is loaded, else pcl.
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
                                                           const ServiceConfig& config);

}  // namespace softgrasp::rest
