#include "service/rest/api.h"

#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>

#include "service/codec/json_codec.h"
#include "service/codec/mesh_grasps_json.h"
#include "service/core/preprocess.h"
#include "service/engine/engine.h"
#include "service/engine/instances.h"
#include "service/http/static_files.h"
#include "service/io/depth_codec.h"
#include "service/io/overlay.h"
#include "service/rest/build_info.h"
#include "service/rest/depth_request.h"
#include "service/rest/fractal_request.h"
#include "service/rest/mesh_request.h"
#include "service/rest/robot_api.h"
#include "service/rest/strategy_fields.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;
using engine::Models;

// Optional numbers: null when absent.
json OrNull(const std::optional<double>& value) {
  return value && std::isfinite(*value) ? json(*value) : json();
}

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

json GraspToJson(const engine::PlannedGrasp& planned, int rank, const engine::Strategy& strategy) {
  const core::Grasp& g = planned.grasp;
  json out = {
      {"rank", rank},
      {"score", g.score},
      {"center_px", {{"u", g.center_u_px}, {"v", g.center_v_px}}},
      {"angle_rad", g.angle_rad},
      {"opening_px", g.opening_px},
      {"opening_m", g.opening_m},
      {"finger_width_px", g.finger_width_px},
      {"finger_thickness_px", g.finger_thickness_px},
      {"contact_height_m", g.contact_height_m},
      {"grasp_height_m", g.grasp_height_m},
      {"height_step", g.height_step},
      // Mean of the stiffness map over the contact surface in the closing region, in [0, 1];
      // null when the model did not run (none loaded, or strategy=fge without mean_stiffness).
      {"mean_stiffness", std::isfinite(g.mean_stiffness) ? json(g.mean_stiffness) : json()},
      // The instance it grasps (0 = none) when the request used a segmentation.
      {"instance_id", planned.instance_id ? json(*planned.instance_id) : json()},
      // That instance's mean deformability (0 rigid ... 1 very soft): the model's map only.
      {"instance_deformability", OrNull(planned.instance_deformability)},
      {"pose", codec::ToJson(codec::Pose{"camera", g.p_CG_m, g.q_CG_wxyz})},
  };
  // Every strategy that adds details to its grasps has its key in every grasp: its object for
  // its own grasps, null for the others'.
  for (const engine::Strategy* s : engine::Strategies()) {
    const std::string key = s->grasp_details_key();
    if (key.empty()) continue;
    out[key] = s == &strategy ? s->GraspDetailsJson(planned) : json();
  }
  return out;
}

http::Response Healthz() { return http::Response::Json(200, R"({"status":"ok"})"); }

json RobotInfoJson(const config::ServiceConfig& config, bool running) {
  std::string reason = config::RobotDisabledReason(config.robot);
  if (reason.empty() && !running) reason = "the robot endpoints are not running in this process";
  json robot = {{"enabled", reason.empty()}};
  if (!reason.empty()) robot["reason"] = reason;
  return robot;
}

json ModelsJson(const Models& models) {
  json list = json::array();
  if (const auto& model = models.stiffness) {
    list.push_back({{"name", "pix2stiffness"},
                    {"kind", "stiffness"},
                    {"input_size", model->input_size()},
                    {"parameters", model->parameter_count()},
                    {"description", model->description()}});
  }
  if (const auto& segmentation = models.segmentation) {
    list.push_back({{"name", "segmentation"},
                    {"kind", "segmentation"},
                    {"input_width", segmentation->input_width()},
                    {"input_height", segmentation->input_height()},
                    {"parameters", segmentation->parameter_count()},
                    {"description", segmentation->description()}});
  }
  if (const auto& gqcnn = models.gqcnn) {
    list.push_back({{"name", "gqcnn"},
                    {"kind", "grasp_quality"},
                    {"parameters", gqcnn->parameter_count()},
                    {"description", gqcnn->description()},
                    // Where its P(success) is cut into predicted_success, and what it was
                    // chosen on (null: the default 0.5, chosen on nothing).
                    {"decision_threshold", gqcnn->decision_threshold()},
                    {"decision_threshold_chosen_on", gqcnn->decision_threshold_card()}});
  }
  return list;
}

// The choices of the strategies' fields named `name` (e.g. "target_policy").
json ChoicesOfField(const std::string& name) {
  for (const engine::Strategy* s : engine::Strategies()) {
    for (const engine::StrategyField& f : s->fields()) {
      if (f.name == name) return f.choices;
    }
  }
  return json::array();
}

json Overlays(const Models& models) {
  json out = {"depth"};
  if (models.stiffness) out.push_back("stiffness");
  if (models.segmentation) out.push_back("deformability");
  return out;
}

json InfoJson(const config::ServiceConfig& config, bool robot_running, const Models& models) {
  const bool segmentation = models.segmentation != nullptr;
  const auto& limits = config.server.limits;
  json body = {
      {"name", "softgrasp"},
      {"version", build_info::kVersion},
      {"build",
       {{"type", build_info::kBuildType},
        {"compiler", build_info::kCompiler},
        {"sanitizer", build_info::kSanitizer}}},
      {"limits",
       {{"max_body_bytes", limits.max_body_bytes},
        {"max_header_bytes", limits.max_header_bytes},
        {"max_uri_bytes", limits.max_uri_bytes},
        {"max_image_pixels", config.max_image_pixels},
        {"max_connections", config.server.max_connections},
        {"queue_capacity", config.server.queue_capacity},
        {"workers", config.server.num_workers},
        {"max_connections_per_client", config.server.max_connections_per_client},
        {"header_timeout_ms", config.server.header_timeout_ms},
        {"body_timeout_ms", config.server.body_timeout_ms},
        {"max_fractal_points", config.max_fractal_points},
        {"max_fractal_attempts", config.max_fractal_attempts},
        {"max_mesh_triangles", config.max_mesh_triangles},
        {"max_mesh_quality_evaluations", config.max_mesh_quality_evaluations}}},
      {"models", ModelsJson(models)},
      {"strategies", engine::ServedStrategies(models)},
      {"default_strategy", engine::DefaultStrategy(models).info().name},
      {"strategy_fields", StrategyTablesJson()},
      {"target_policies", ChoicesOfField("target_policy")},
      {"overlays", Overlays(models)},
      {"depth_formats", {"npy", "png16", "tiff"}},
      {"stiffness_formats", {"png8", "png16", "npy", "color"}},
      {"segmentation_methods", segmentation ? json{"model", "pcl", "fused"} : json{"pcl"}},
      {"default_segmentation_method", segmentation ? "model" : "pcl"},
      {"segmentation_formats", {"json", "labels", "overlay", "deformability"}},
      {"mesh_formats", {"obj", "ply_ascii", "ply_binary", "stl_ascii", "stl_binary"}},
      {"defaults",
       {{"camera", codec::ToJson(config.default_camera)},
        {"gripper", codec::ToJson(config.default_gripper)},
        {"png_unit_m", config.png_unit_m}}},
      {"robot", RobotInfoJson(config, robot_running)},
  };
  body["defaults"].update(codec::ToJson(config.fge));
  body["defaults"].update(StrategyDefaultsJson());
  return body;
}

http::Response Info(const config::ServiceConfig& config, bool robot_running, const Models& models) {
  return http::Response::Json(200, InfoJson(config, robot_running, models).dump());
}

http::Response PngResponse(const cv::Mat& image, std::size_t grasp_count) {
  http::Response png = http::Response::Bytes(200, "image/png", io::EncodePng(image));
  png.set_header("X-Grasp-Count", std::to_string(grasp_count));
  return png;
}

// The picture under the grasps of a PNG answer: the depth, the stiffness model's map, or the
// segmentation model's deformability map with the target outlined.
cv::Mat3b OverlayPicture(const GraspRequest& in, const engine::Plan& plan) {
  switch (in.overlay) {
    case OverlayBackground::kStiffness:
      return io::ColorizeStiffness(plan.stiffness, models::kBackgroundThreshold);
    case OverlayBackground::kDeformability: {
      if (!plan.instances) break;  // not reached: the overlay asks for instances
      const engine::Instances& instances = *plan.instances;
      const cv::Mat3b map =
          io::ColorizeDeformability(instances.deformability, instances.foreground > 0.5f);
      const int chosen = plan.chosen_target_id > 0 ? plan.chosen_target_id : in.plan.target_id;
      return chosen > 0 ? io::DrawOutline(map, instances.labels == chosen) : map;
    }
    case OverlayBackground::kDepth:
      break;
  }
  return io::ColorizeDepth(in.upload.depth);
}

json GraspsToJson(const GraspRequest& in, const engine::Plan& plan, const Models& models,
                  double decode_ms, double total_ms) {
  const DepthUpload& up = in.upload;
  const engine::Strategy& strategy = *engine::FindStrategy(in.plan.strategy);
  json list = json::array();
  for (std::size_t i = 0; i < plan.grasps.size(); ++i) {
    list.push_back(GraspToJson(plan.grasps[i], static_cast<int>(i) + 1, strategy));
  }
  json camera = codec::ToJson(up.camera);
  camera["source"] = up.camera_source;
  json timing = {{"decode", decode_ms}, {"preprocess", plan.timing.preprocess_ms}};
  if (plan.timing.stiffness_ran) timing["stiffness"] = plan.timing.stiffness_ms;
  // The segmenter's time: it ran to segment, or (labels given) for the deformability map.
  if (plan.timing.segmentation_ms > 0) timing["segmentation"] = plan.timing.segmentation_ms;
  timing["detect"] = plan.timing.detect_ms;
  timing["total"] = total_ms;
  const core::Scene& scene = plan.scene;
  json body = {
      {"strategy", in.plan.strategy},
      {"stiffness_model", models.stiffness ? json("pix2stiffness") : json()},
      {"image",
       {{"width", up.depth.width()},
        {"height", up.depth.height()},
        {"format", io::DepthFormatName(up.depth_format)},
        {"missing_fraction", scene.missing_fraction}}},
      {"camera", camera},
      {"floor",
       {{"normal", {scene.floor.n[0], scene.floor.n[1], scene.floor.n[2]}},
        {"d_m", scene.floor.d}}},
      {"gripper", codec::ToJson(in.plan.gripper)},
      {"contact_region",
       {{"segmask", !in.plan.region_of_interest.empty()},
        {"min_depth_m", in.plan.min_depth_m},
        {"target", plan.target_id > 0 ? json(plan.target_id) : json()}}},
      {"segmentation", plan.instances ? json{{"source", plan.instances->source},
                                             {"instances", plan.instances->count}}
                                      : json()},
      {"grasps", list},
      {"timing_ms", timing},
  };
  strategy.WritePlanJson(plan, &body);
  return body;
}

// A picture shows no instance ids and no mean stiffness; it shows the overlay's map.
void AskForWhatTheAnswerShows(GraspRequest* in) {
  const bool png = in->output == OutputFormat::kPng;
  in->plan.report_instances = in->plan.report_instances && !png;
  in->plan.mean_stiffness = in->plan.mean_stiffness && !png;
  in->plan.want_stiffness_map = png && in->overlay == OverlayBackground::kStiffness;
  in->plan.want_deformability_map = in->overlay == OverlayBackground::kDeformability;
  in->plan.plan = !png || in->draw_grasps;
}

core::Error TargetPixelNotFound(const engine::PlanOptions& plan) {
  return core::MakeError(core::ErrorCode::kUnprocessable,
                         "target_px (" + std::to_string(plan.target_px->x) + ", " +
                             std::to_string(plan.target_px->y) +
                             ") is on no object of the segmentation",
                         "target_px");
}

// The PNG answer: the grasps drawn over the overlay's picture.
http::Response GraspsPicture(const GraspRequest& in, const engine::Plan& plan) {
  std::vector<core::Grasp> grasps;
  for (const auto& g : plan.grasps) grasps.push_back(g.grasp);
  return PngResponse(io::DrawGrasps(OverlayPicture(in, plan), grasps), grasps.size());
}

http::Response Grasps(const http::Request& request, const config::ServiceConfig& config,
                      const Models& models) {
  const auto start = Clock::now();
  auto parsed = ParseGraspRequest(request, config, models);
  if (!parsed.ok()) return ErrorToResponse(parsed.error());
  GraspRequest& in = parsed.value();
  const double decode_ms = MillisecondsSince(start);
  const bool png = in.output == OutputFormat::kPng;
  if (png && !in.draw_grasps && in.overlay == OverlayBackground::kDepth) {
    // The picture alone needs no planning; the client asks for the grasps separately.
    return PngResponse(io::ColorizeDepth(in.upload.depth), 0);
  }
  AskForWhatTheAnswerShows(&in);
  auto planned = engine::PlanGrasps(in.upload.depth, in.upload.camera, in.plan, models);
  if (!planned.ok()) return ErrorToResponse(planned.error());
  const engine::Plan& plan = planned.value();
  if (plan.target_not_found) return ErrorToResponse(TargetPixelNotFound(in.plan));
  if (png) return GraspsPicture(in, plan);
  return http::Response::Json(
      200, GraspsToJson(in, plan, models, decode_ms, MillisecondsSince(start)).dump());
}

// A map in [0, 1] as /v1/stiffness sends it: png8 round(255 x), png16 round(65535 x), npy x
// itself, or `colorize`'s picture.
template <class Colorize>
http::Response EncodeMap(const cv::Mat1f& map, StiffnessFormat format, Colorize&& colorize) {
  switch (format) {
    case StiffnessFormat::kPng8:
    case StiffnessFormat::kPng16: {
      const bool wide = format == StiffnessFormat::kPng16;
      cv::Mat levels;
      map.convertTo(levels, wide ? CV_16U : CV_8U, wide ? 65535.0 : 255.0);  // rounds, saturates
      return http::Response::Bytes(200, "image/png", io::EncodePng(levels));
    }
    case StiffnessFormat::kNpy:
      return http::Response::Bytes(200, "application/x-npy", io::EncodeNpy(map));
    case StiffnessFormat::kColor:
      break;
  }
  return http::Response::Bytes(200, "image/png", io::EncodePng(colorize(map)));
}

// POST /v1/stiffness: the model's map of the uploaded depth, same size as the input.
http::Response Stiffness(const http::Request& request, const config::ServiceConfig& config,
                         const models::StiffnessModel* model) {
  if (!model) {
    return ErrorToResponse(core::MakeError(
        core::ErrorCode::kUnavailable,
        "no stiffness model is loaded: start the server with --stiffness-model FILE (the shipped "
        "model is models/pix2stiffness.pt)",
        "model"));
  }
  auto parsed = ParseStiffnessRequest(request, config);
  if (!parsed.ok()) return ErrorToResponse(parsed.error());
  const StiffnessRequest& in = parsed.value();
  const auto start = Clock::now();
  auto map = model->Predict(in.upload.depth, in.upload.camera);
  if (!map.ok()) return ErrorToResponse(map.error());
  const double model_ms = MillisecondsSince(start);
  const cv::Mat1f& s = map.value();

  http::Response out = EncodeMap(s, in.format, [](const cv::Mat1f& values) {
    return io::ColorizeStiffness(values, models::kBackgroundThreshold);
  });
  out.set_header("Server-Timing", "model;dur=" + std::to_string(model_ms));
  return out;
}

json InstanceToJson(const segmentation::InstanceInfo& i) {
  return {
      {"id", i.id},
      {"score", i.score},
      {"area_px", i.area_px},
      {"bbox_px", {i.bbox_px.x, i.bbox_px.y, i.bbox_px.width, i.bbox_px.height}},
      {"centroid_px", i.centroid_px},
      {"centroid_m", i.centroid_m},
      {"top_height_m", i.top_height_m},
      {"mean_deformability", OrNull(i.mean_deformability)},
      {"mean_stiffness", OrNull(i.mean_stiffness)},
  };
}

json SegmentationToJson(const SegmentationRequest& in, const engine::Segmentation& found,
                        const Models& models, double decode_ms, double total_ms) {
  const DepthUpload& up = in.upload;
  const engine::SegmentTimings& t = found.timing;
  json list = json::array();
  for (const auto& info : found.described) list.push_back(InstanceToJson(info));
  json camera = codec::ToJson(up.camera);
  camera["source"] = up.camera_source;
  json timing = {{"decode", decode_ms}, {"preprocess", t.preprocess_ms}, {"segment", t.segment_ms}};
  if (t.stiffness_ms > 0) timing["stiffness"] = t.stiffness_ms;
  timing["describe"] = t.describe_ms;
  timing["total"] = total_ms;
  const segmentation::Method method = found.instances.method;
  return {
      {"method", segmentation::MethodName(method)},
      {"segmentation_model", method != segmentation::Method::kPcl ? json("segmentation") : json()},
      {"stiffness_model", models.stiffness ? json("pix2stiffness") : json()},
      {"image",
       {{"width", up.depth.width()},
        {"height", up.depth.height()},
        {"format", io::DepthFormatName(up.depth_format)},
        {"missing_fraction", found.scene.missing_fraction}}},
      {"camera", camera},
      {"instances", list},
      {"timing_ms", timing},
  };
}

// The segmentation's answer in the requested format (the headers come after).
http::Response SegmentationAnswer(const SegmentationRequest& in, const engine::Segmentation& found,
                                  const Models& models, double decode_ms, double total_ms) {
  const segmentation::InstanceMasks& masks = found.instances.masks;
  switch (in.format) {
    case SegmentationFormat::kLabels:
      return http::Response::Bytes(200, "image/png", io::EncodePng(masks.labels));
    case SegmentationFormat::kOverlay:
      return http::Response::Bytes(
          200, "image/png",
          io::EncodePng(io::DrawInstances(io::ColorizeDepth(in.upload.depth), masks.labels)));
    case SegmentationFormat::kDeformability: {
      const cv::Mat1b objects = masks.labels > 0;
      return EncodeMap(found.instances.deformability, in.encoding,
                       [&objects](const cv::Mat1f& values) {
                         return io::ColorizeDeformability(values, objects);
                       });
    }
    case SegmentationFormat::kJson:
      return http::Response::Json(
          200, SegmentationToJson(in, found, models, decode_ms, total_ms).dump());
  }
  return http::Response::Json(500, "{}");  // not reached: every format is handled
}

// POST /v1/segmentation: object instances of the uploaded depth (docs/segmentation.md).
http::Response Segmentation(const http::Request& request, const config::ServiceConfig& config,
                            const Models& models) {
  const auto start = Clock::now();
  auto parsed = ParseSegmentationRequest(request, config);
  if (!parsed.ok()) return ErrorToResponse(parsed.error());
  const SegmentationRequest& in = parsed.value();
  if (in.format == SegmentationFormat::kDeformability && !models.segmentation) {
    // method=pcl with this format is refused while parsing; here no model is loaded.
    return ErrorToResponse(core::MakeError(
        core::ErrorCode::kUnavailable,
        "format 'deformability' needs the segmentation model and none is loaded (start the "
        "server with --segmentation-model FILE)",
        "format"));
  }
  const double decode_ms = MillisecondsSince(start);
  engine::SegmentOptions options{in.method, in.format == SegmentationFormat::kJson};
  auto segmented = engine::Segment(in.upload.depth, in.upload.camera, options, models);
  if (!segmented.ok()) return ErrorToResponse(segmented.error());
  const engine::Segmentation& found = segmented.value();
  const segmentation::InstanceMasks& masks = found.instances.masks;

  http::Response out = SegmentationAnswer(in, found, models, decode_ms, MillisecondsSince(start));
  out.set_header("X-Instance-Count", std::to_string(masks.count()));
  out.set_header("X-Segmentation-Method", segmentation::MethodName(found.instances.method));
  out.set_header("Server-Timing", "preprocess;dur=" + std::to_string(found.timing.preprocess_ms) +
                                      ", segment;dur=" + std::to_string(found.timing.segment_ms));
  return out;
}

const char* MeshContentType(mesh::MeshFormat format) {
  switch (format) {
    case mesh::MeshFormat::kObj:
      return "model/obj";
    case mesh::MeshFormat::kPlyAscii:
    case mesh::MeshFormat::kPlyBinary:
      return "application/x-ply";
    case mesh::MeshFormat::kStlAscii:
    case mesh::MeshFormat::kStlBinary:
      return "model/stl";
  }
  return "application/octet-stream";
}

json FractalStats(const mesh::FractalModel& m, const FractalRequest& in, double milliseconds) {
  const std::array<double, 3> size{m.bbox_max_m[0] - m.bbox_min_m[0],
                                   m.bbox_max_m[1] - m.bbox_min_m[1],
                                   m.bbox_max_m[2] - m.bbox_min_m[2]};
  return {
      {"seed", in.params.seed},
      {"vertices", m.mesh.vertices.size()},
      {"faces", m.mesh.faces.size()},
      {"volume_m3", m.volume_m3},
      {"bbox", {{"min_m", m.bbox_min_m}, {"max_m", m.bbox_max_m}, {"size_m", size}}},
      {"maps", m.ifs.maps.size()},
      {"points", m.num_points},
      {"points_triangulated", m.points_triangulated},
      {"merge_cell", m.merge_cell},
      {"sigma", in.params.sigma},
      {"variances", m.variances},
      {"alpha_requested", m.alpha_requested},
      {"alpha_used", m.alpha_used},
      {"alpha_raised", m.alpha_raised},
      {"pieces_dropped", m.pieces_dropped},
      {"attempts", m.attempts},
      {"rejections",
       {{"expanding", m.rejections.expanding},
        {"diverged", m.rejections.diverged},
        {"low_variance", m.rejections.low_variance},
        {"no_solid", m.rejections.no_solid},
        {"float_collision", m.rejections.float_collision},
        {"self_intersecting", m.rejections.self_intersecting}}},
      {"milliseconds", milliseconds},
  };
}

http::Response Fractals(const http::Request& request, const config::ServiceConfig& config) {
  const auto start = Clock::now();
  const std::string content_type(request.header("Content-Type").value_or(""));
  if (!request.body.empty() && content_type.rfind("application/json", 0) != 0) {
    return ErrorToResponse(core::MakeError(core::ErrorCode::kUnsupportedFormat,
                                           "send the parameters as application/json",
                                           "Content-Type"));
  }
  auto parsed = ParseFractalRequest(request.body, config);
  if (!parsed.ok()) return ErrorToResponse(parsed.error());
  const FractalRequest& in = parsed.value();
  auto model = mesh::GenerateFractal(in.params);
  if (!model.ok()) return ErrorToResponse(model.error());
  const mesh::FractalModel& m = model.value();
  if (in.stats_only) {
    return http::Response::Json(200, FractalStats(m, in, MillisecondsSince(start)).dump());
  }
  http::Response file =
      http::Response::Bytes(200, MeshContentType(in.format), mesh::WriteMesh(m.mesh, in.format));
  file.set_header("Content-Disposition", "attachment; filename=\"" + FractalFileName(in) + "\"");
  file.set_header("X-Fractal-Alpha-Used", json(m.alpha_used).dump());
  file.set_header("X-Fractal-Attempts", std::to_string(m.attempts));
  return file;
}

http::Response MeshGrasps(const http::Request& request, const config::ServiceConfig& config) {
  auto parsed = ParseMeshGraspRequest(request, config);
  if (!parsed.ok()) return ErrorToResponse(parsed.error());
  const MeshGraspRequest& in = parsed.value();
  mesh::MeshFileJob job;
  job.prepare.unit_scale_m = in.unit_scale_m;
  job.prepare.rescale_min_extent_m = in.rescale_min_extent_m;
  job.prepare.max_triangles = config.max_mesh_triangles;
  job.analysis = in.analysis;
  auto analysed = mesh::AnalyseMeshFile(in.mesh_bytes, job);
  if (!analysed.ok()) return ErrorToResponse(analysed.error());
  if (in.output == OutputFormat::kJson) {
    return http::Response::Json(200, codec::ToJson(analysed.value()).dump());
  }
  auto view = mesh::RenderPoseView(analysed.value().prepared.mesh, analysed.value().analysis,
                                   in.preview_pose, in.analysis.gripper, in.preview_size_px,
                                   in.preview_grasps);
  if (!view.ok()) return ErrorToResponse(view.error());
  return PngResponse(io::RenderGraspOverlay(view.value().depth, view.value().grasps),
                     view.value().grasps.size());
}

// The page loads only its own bundled files and talks only to this service.
constexpr const char* kPageSecurityPolicy =
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; "
    "connect-src 'self' blob:; object-src 'none'; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'none'";

http::Response WebPage(const http::StaticFiles& files, const http::Request& request) {
  http::Response page = files.Serve(request, {"index.html"});
  if (page.status == 404) {
    return http::ErrorResponse(404, "not_found",
                               "the web page is not built: run scripts/build.sh, or point "
                               "--web-root (web.root, SOFTGRASP_WEB_ROOT) at a built page");
  }
  page.set_header("Content-Security-Policy", kPageSecurityPolicy);
  page.set_header("Referrer-Policy", "no-referrer");
  return page;
}

}  // namespace

namespace {

// Each kind of failure as an HTTP status and the stable name error bodies carry.
struct HttpError {
  int status;
  const char* name;
};

HttpError HttpErrorFor(core::ErrorCode code) {
  switch (code) {
    case core::ErrorCode::kInvalidArgument:
      return {400, "invalid_argument"};
    case core::ErrorCode::kUnsupportedFormat:
      return {415, "unsupported_media_type"};
    case core::ErrorCode::kTooLarge:
      return {413, "payload_too_large"};
    case core::ErrorCode::kUnprocessable:
      return {422, "unprocessable"};
    case core::ErrorCode::kNotFound:
      return {404, "not_found"};
    case core::ErrorCode::kInternal:
      return {500, "internal"};
    case core::ErrorCode::kUnauthenticated:
      return {401, "unauthorized"};
    case core::ErrorCode::kPermissionDenied:
      return {403, "forbidden"};
    case core::ErrorCode::kConflict:
      return {409, "conflict"};
    case core::ErrorCode::kUnavailable:
      return {503, "service_unavailable"};
  }
  return {500, "internal"};
}

}  // namespace

int HttpStatusFor(core::ErrorCode code) { return HttpErrorFor(code).status; }

http::Response ErrorToResponse(const core::Error& error) {
  const HttpError http = HttpErrorFor(error.code);
  return http::ErrorResponse(http.status, http.name, error.message, error.field);
}

http::Router BuildRouter(const config::ServiceConfig& config) {
  return BuildRouter(config, nullptr);
}

http::Router BuildRouter(const config::ServiceConfig& config,
                         std::shared_ptr<robot::CommandTracker> robot,
                         std::shared_ptr<const models::StiffnessModel> stiffness_model,
                         std::shared_ptr<const models::SegmentationModel> segmentation_model,
                         std::shared_ptr<const models::GqcnnModel> gqcnn_model) {
  const Models models{std::move(stiffness_model), std::move(segmentation_model),
                      std::move(gqcnn_model)};
  http::Router router;
  const bool robot_running = robot != nullptr;
  // Constant-time answers: served on the I/O thread, so they answer while every worker plans.
  router.Add(
      "GET", "/healthz", [](const http::Request&) { return Healthz(); },
      http::Router::Execution::kInline);
  router.Add(
      "GET", "/v1/info",
      [config, robot_running, models](const http::Request&) {
        return Info(config, robot_running, models);
      },
      http::Router::Execution::kInline);
  router.Add("POST", "/v1/grasps",
             [config, models](const http::Request& r) { return Grasps(r, config, models); });
  router.Add("POST", "/v1/stiffness", [config, models](const http::Request& r) {
    return Stiffness(r, config, models.stiffness.get());
  });
  router.Add("POST", "/v1/segmentation",
             [config, models](const http::Request& r) { return Segmentation(r, config, models); });
  router.Add("POST", "/v1/fractals",
             [config](const http::Request& r) { return Fractals(r, config); });
  router.Add("POST", "/v1/meshes/grasps",
             [config](const http::Request& r) { return MeshGrasps(r, config); });

  // The browser page (docs/web.md): index.html at "/", content-hashed bundles under /assets/.
  auto files = std::make_shared<const http::StaticFiles>(http::StaticFilesOptions{config.web_root});
  router.Add("GET", "/", [files](const http::Request& r) { return WebPage(*files, r); });
  router.Add("GET", "/assets/{file}", [files](const http::Request& r) {
    return files->Serve(r, {"assets", r.path_params.at("file")});
  });
  AddRobotRoutes(router, config, std::move(robot));
  return router;
}

}  // namespace softgrasp::rest
