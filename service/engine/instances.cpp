#include "service/engine/instances.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "service/segmentation/fuse.h"
#include "service/segmentation/pcl_segmenter.h"

namespace softgrasp::engine {
namespace {

using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

core::Result<segmentation::Method> ResolveSegmentationMethod(
    std::optional<segmentation::Method> requested, bool model_loaded, const char* field) {
  if (!requested) return model_loaded ? segmentation::Method::kModel : segmentation::Method::kPcl;
  if (*requested != segmentation::Method::kPcl && !model_loaded) {
    return core::MakeError(core::ErrorCode::kUnavailable,
                           "no segmentation model is loaded: start the server with "
                           "--segmentation-model FILE (the shipped model is "
                           "models/segmentation.pt), or ask for the PCL baseline with " +
                               std::string(field) + "=pcl",
                           field);
  }
  return *requested;
}

core::Result<SceneInstances> SegmentInstances(const core::Scene& scene, const core::Camera& camera,
                                              segmentation::Method method,
                                              const models::SegmentationModel* model) {
  const auto start = Clock::now();
  SceneInstances out;
  out.method = method;
  if (method != segmentation::Method::kPcl) {
    if (model == nullptr) {
      return core::MakeError(core::ErrorCode::kUnavailable, "no segmentation model is loaded",
                             "method");
    }
    models::SegmentationOutput result = model->SegmentScene(scene);
    out.masks = std::move(result.instances);
    out.deformability = std::move(result.deformability);
    out.foreground = std::move(result.foreground);
  }
  if (method != segmentation::Method::kModel) {
    auto masks = segmentation::SegmentPcl(scene, camera);
    if (!masks.ok()) return masks.error();
    out.masks = method == segmentation::Method::kPcl
                    ? std::move(masks).value()
                    : segmentation::FuseInstances(out.masks, masks.value());
  }
  out.milliseconds = MillisecondsSince(start);
  return out;
}

std::vector<segmentation::InstanceInfo> DescribeSceneInstances(
    const SceneInstances& instances, const core::Scene& scene, const core::Camera& camera,
    const models::StiffnessModel* stiffness_model, double* stiffness_ms) {
  const auto start = Clock::now();
  cv::Mat1f stiffness;
  // The stiffness map only matters where there are instances to average it over.
  if (stiffness_model != nullptr && instances.masks.count() > 0) {
    stiffness = stiffness_model->PredictScene(scene);
  }
  if (stiffness_ms != nullptr) *stiffness_ms = stiffness.empty() ? 0.0 : MillisecondsSince(start);
  return segmentation::DescribeInstances(instances.masks, scene, camera, instances.deformability,
                                         stiffness);
}

int InstanceAt(const cv::Mat1w& labels, double u_px, double v_px) {
  if (labels.empty() || !std::isfinite(u_px) || !std::isfinite(v_px)) return 0;
  const int u = static_cast<int>(std::lround(std::clamp(u_px, 0.0, labels.cols - 1.0)));
  const int v = static_cast<int>(std::lround(std::clamp(v_px, 0.0, labels.rows - 1.0)));
  return labels(v, u);
}
core::Result<Instances> InstancesForPlan(const InstanceRequest& request, const core::Scene& scene,
                                         const core::Camera& camera,
                                         const models::SegmentationModel* model) {
  Instances out;
  const bool need_deformability = request.need_deformability;
  const auto start = Clock::now();
  if (!request.labels.empty()) {
    out.labels = request.labels;
  } else {
    auto method = ResolveSegmentationMethod(request.method, model != nullptr, "segmentation");
    if (!method.ok()) return method.error();
    auto segmented = SegmentInstances(scene, camera, method.value(), model);
    if (!segmented.ok()) return segmented.error();
    const SceneInstances& found = segmented.value();
    out.labels = found.masks.labels;
    out.scores = found.masks.scores;
    out.source = segmentation::MethodName(found.method);
    out.deformability = found.deformability;
    out.foreground = found.foreground;
  }
  if (need_deformability && out.deformability.empty()) {
    if (model == nullptr) {
      return core::MakeError(core::ErrorCode::kUnavailable,
                             "the deformability map needs a segmentation model and none is loaded",
                             "strategy");
    }
    const models::SegmentationOutput maps = model->SegmentScene(scene);
    out.deformability = maps.deformability;
    out.foreground = maps.foreground;
  }
  if (!out.deformability.empty()) {
    SceneInstances described;
    described.masks.labels = out.labels;
    double ids = 0;
    cv::minMaxLoc(out.labels, nullptr, &ids);
    described.masks.scores.assign(static_cast<std::size_t>(ids), 1.0f);
    described.deformability = out.deformability;
    out.mean_deformability.resize(static_cast<std::size_t>(ids) + 1);
    for (const auto& info : DescribeSceneInstances(described, scene, camera, nullptr)) {
      out.mean_deformability[static_cast<std::size_t>(info.id)] = info.mean_deformability;
    }
  }
  if (std::string(out.source) != "labels" || need_deformability) {
    out.milliseconds = MillisecondsSince(start);
  }
  double max_id = 0;
  cv::minMaxLoc(out.labels, nullptr, &max_id);
  std::vector<bool> present(static_cast<std::size_t>(max_id) + 1, false);
  for (int v = 0; v < out.labels.rows; ++v) {
    const std::uint16_t* row = out.labels[v];
    for (int u = 0; u < out.labels.cols; ++u) present[row[u]] = true;
  }
  out.count = static_cast<int>(std::count(present.begin() + 1, present.end(), true));
  // Labels given by the client carry no scores: every instance counts as confident.
  out.scores.resize(static_cast<std::size_t>(max_id), 1.0f);
  const int target = request.target_id;
  if (target > 0 && (target > static_cast<int>(max_id) || !present[target])) {
    return core::MakeError(
        core::ErrorCode::kUnprocessable,
        "target " + std::to_string(target) + " is not an instance of the segmentation (" +
            std::to_string(out.count) + " instances, ids up to " +
            std::to_string(static_cast<int>(max_id)) + "; see POST /v1/segmentation)",
        "target");
  }
  return out;
}

}  // namespace softgrasp::engine
