#pragma once
/// Object instances for the engine (segmentation answers and the instance options of grasp
/// planning): which segmenter serves a request, running it on a preprocessed scene, and
/// describing the instances.

#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "service/core/depth.h"
#include "service/core/preprocess.h"
#include "service/core/status.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/segmentation/instances.h"

namespace softgrasp::engine {

using SegmentationModelPtr = std::shared_ptr<const models::SegmentationModel>;

/// The segmenter for a request: `requested`, or the model when one is loaded, else pcl.
/// kUnavailable (503, field `field`) when the model or fused is asked for and no model is loaded.
core::Result<segmentation::Method> ResolveSegmentationMethod(
    std::optional<segmentation::Method> requested, bool model_loaded, const char* field);

/// A scene's instances and, from the model only, its deformability map.
struct SceneInstances {
  segmentation::Method method = segmentation::Method::kPcl;
  segmentation::InstanceMasks masks;
  /// [0, 1] (0 rigid ... 1 very soft), the scene's size (model and fused); empty with pcl.
  /// Never a stiffness.
  cv::Mat1f deformability;
  /// Model foreground probability [0, 1]; empty with pcl.
  cv::Mat1f foreground;
  double milliseconds = 0;  ///< the segmenter's run time
};

/// Runs `method` on a preprocessed scene (core::Preprocess) seen by `camera`. `model` must be
/// non-null for Method::kModel and kFused. Errors: the PCL segmenter's (a scene and camera of
/// different sizes); a scene with no objects gives zero instances.
core::Result<SceneInstances> SegmentInstances(const core::Scene& scene, const core::Camera& camera,
                                              segmentation::Method method,
                                              const models::SegmentationModel* model);

/// The instances described as POST /v1/segmentation reports them: DescribeInstances with the
/// deformability map (model only) and, when `stiffness_model` is non-null, the mean of its
/// stiffness map over each instance. `stiffness_ms` (optional) receives the stiffness model's
/// run time (0 when it did not run).
std::vector<segmentation::InstanceInfo> DescribeSceneInstances(
    const SceneInstances& instances, const core::Scene& scene, const core::Camera& camera,
    const models::StiffnessModel* stiffness_model, double* stiffness_ms = nullptr);

/// The instances a grasp plan works with: labels as the caller gave them, or a fresh
/// segmentation of the scene.
struct Instances {
  cv::Mat1w labels;
  const char* source = "labels";  ///< "labels" (the client's), "model", "pcl" or "fused"
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

/// What a plan asks of its instances.
struct InstanceRequest {
  cv::Mat1w labels;  ///< given by the caller (0 = no object); empty = segment the scene
  /// The segmenter when one has to run; unset: the model when loaded, else pcl.
  std::optional<segmentation::Method> method;
  /// Compute the model's deformability map also for labels given or a pcl segmentation.
  bool need_deformability = false;
  int target_id = 0;  ///< > 0: must be an id of the segmentation
};

/// Labels given, or `request.method` run on the scene. Errors: ResolveSegmentationMethod's
/// (field "segmentation"), SegmentInstances', kUnavailable (field "strategy") when the
/// deformability map is needed and no model is loaded, and kUnprocessable (field "target") when
/// the target is not an id of the segmentation.
core::Result<Instances> InstancesForPlan(const InstanceRequest& request, const core::Scene& scene,
                                         const core::Camera& camera,
                                         const models::SegmentationModel* model);

/// The instance id under pixel (u, v) (rounded, clamped into the image), 0 = none.
int InstanceAt(const cv::Mat1w& labels, double u_px, double v_px);
}  // namespace softgrasp::engine
