#pragma once
/// Object instances for the REST layer (POST /v1/segmentation and the instance options of
/// POST /v1/grasps): which segmenter serves a request, running it on a preprocessed scene, and
/// describing the instances. No HTTP here; the handlers in api.cpp decode, call and encode.

#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "service/core/depth.h"
#include "service/core/preprocess.h"
#include "service/core/status.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/rest/depth_request.h"
#include "service/segmentation/instances.h"

namespace softgrasp::rest {

using SegmentationModelPtr = std::shared_ptr<const models::SegmentationModel>;

/// The segmenter for a request: `requested`, or the model when one is loaded, else pcl.
/// kUnavailable (503, field `field`) when the model is asked for and none is loaded.
core::Result<segmentation::Method> ResolveSegmentationMethod(
    std::optional<segmentation::Method> requested, bool model_loaded, const char* field);

/// A scene's instances and, from the model only, its deformability map.
struct SceneInstances {
  segmentation::Method method = segmentation::Method::kPcl;
  segmentation::InstanceMasks masks;
  /// [0, 1] (0 rigid ... 1 very soft), the scene's size; empty with pcl. Never a stiffness.
  cv::Mat1f deformability;
  /// Model foreground probability [0, 1]; empty with pcl.
  cv::Mat1f foreground;
  double milliseconds = 0;  ///< the segmenter's run time
};

/// Runs `method` on a preprocessed scene (core::Preprocess) seen by `camera`. `model` must be
/// non-null for Method::kModel. Errors: the PCL segmenter's (a scene and camera of different
/// sizes); a scene with no objects gives zero instances.
core::Result<SceneInstances> SegmentInstances(const core::Scene& scene,
                                              const core::Camera& camera,
                                              segmentation::Method method,
                                              const models::SegmentationModel* model);

/// The instances described as POST /v1/segmentation reports them: DescribeInstances with the
/// deformability map (model only) and, when `stiffness_model` is non-null, the mean of its
/// stiffness map over each instance. `stiffness_ms` (optional) receives the stiffness model's
/// run time (0 when it did not run).
std::vector<segmentation::InstanceInfo> DescribeSceneInstances(
    const SceneInstances& instances, const core::Scene& scene, const core::Camera& camera,
    const models::StiffnessModel* stiffness_model, double* stiffness_ms = nullptr);

/// The instances a POST /v1/grasps request works with: its labels part as given, or a fresh
/// segmentation of the scene (method: the request's "segmentation" field, else the model when
/// loaded, else pcl).
struct GraspInstances {
  cv::Mat1w labels;
  const char* source = "labels";  ///< "labels" (the client's), "model" or "pcl"
  int count = 0;                  ///< instances with at least one pixel
  /// scores[id - 1] for ids 1..max id: the segmenter's; 1 for labels given by the client.
  std::vector<float> scores;
  /// mean_deformability[id] for ids 1..max id (model only; empty otherwise).
  std::vector<std::optional<double>> mean_deformability;
  /// The segmentation model's deformability map (empty when it did not run) and foreground.
  cv::Mat1f deformability;
  cv::Mat1f foreground;
  double milliseconds = 0;  ///< segmenting and describing (0 for labels given)
};

/// The model's deformability map is also computed (for labels given, or a pcl segmentation) when
/// the request's strategy or overlay needs it. Errors: ResolveSegmentationMethod's (field
/// "segmentation"), SegmentInstances', and kUnprocessable (field "target") when the request's
/// target is not an id of the segmentation.
core::Result<GraspInstances> InstancesForGrasps(const GraspRequest& request,
                                                const core::Scene& scene,
                                                const core::Camera& camera,
                                                const models::SegmentationModel* model);

/// The instance id under pixel (u, v) (rounded, clamped into the image), 0 = none.
int InstanceAt(const cv::Mat1w& labels, double u_px, double v_px);

/// Whether `id` (> 0) labels at least one pixel.
bool HasInstance(const cv::Mat1w& labels, int id);

}  // namespace softgrasp::rest
