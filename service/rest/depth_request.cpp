#include "service/rest/depth_request.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <optional>

#include "service/rest/strategy_fields.h"

namespace softgrasp::rest {
namespace {

using core::ErrorCode;
using core::MakeError;

// Form fields and query parameters, merged (form fields win), plus the file parts.
struct RequestFields {
  std::map<std::string, std::string> values;
  std::optional<std::string> depth_bytes;
  std::optional<std::string> intrinsics_json;
  std::optional<std::string> segmask_bytes;
  std::optional<std::string> labels_bytes;
};

bool IsRawDepthContentType(std::string_view type) {
  for (std::string_view t :
       {"application/octet-stream", "application/x-npy", "image/png", "image/tiff"}) {
    if (type.substr(0, t.size()) == t) return true;
  }
  return false;
}

// A body sent without a Content-Type (Python's requests.post(url, data=file)) or with curl's
// default form type (curl --data-binary @d.npy) that starts like a depth file is the raw depth:
// neither type could mean anything else for these bytes.
bool LooksLikeUntypedDepth(std::string_view type, std::string_view body) {
  constexpr std::string_view kFormType = "application/x-www-form-urlencoded";
  const bool untyped = type.empty() || type.substr(0, kFormType.size()) == kFormType;
  return untyped && !body.empty() && io::SniffDepthFormat(body).ok();
}

core::Result<RequestFields> CollectFields(const http::Request& request) {
  RequestFields fields;
  for (const auto& [key, value] : request.query) fields.values[key] = value;

  const std::string content_type(request.header("Content-Type").value_or(""));
  if (content_type.rfind("multipart/form-data", 0) == 0) {
    http::MultipartResult form = http::ParseMultipart(content_type, request.body);
    if (!form.ok()) return MakeError(ErrorCode::kInvalidArgument, form.error, "body");
    for (auto& part : form.parts) {
      if (part.name == "depth") {
        fields.depth_bytes = std::move(part.data);
      } else if (part.name == "intrinsics") {
        fields.intrinsics_json = std::move(part.data);
      } else if (part.name == "segmask") {
        fields.segmask_bytes = std::move(part.data);
      } else if (part.name == "labels") {
        fields.labels_bytes = std::move(part.data);
      } else {
        fields.values[part.name] = std::move(part.data);
      }
    }
  } else if (IsRawDepthContentType(content_type) ||
             LooksLikeUntypedDepth(content_type, request.body)) {
    fields.depth_bytes = request.body;
  } else if (!request.body.empty() || !content_type.empty()) {
    return MakeError(ErrorCode::kUnsupportedFormat,
                     "send the depth image as multipart/form-data (part 'depth') or as a raw body "
                     "with Content-Type application/octet-stream, application/x-npy, image/png "
                     "or image/tiff; got '" +
                         content_type + "'",
                     "Content-Type");
  }
  if (!fields.depth_bytes || fields.depth_bytes->empty()) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "a depth image is required: multipart part 'depth' or a raw body", "depth");
  }
  return fields;
}

// Numeric options: name -> range and where the value goes.
struct NumericOption {
  double min, max;
  bool integer;
  std::function<void(GraspRequest&, double)> apply;
};

// A field that overrides a configuration setting: the setting's limits, in the field's units
// (`scale` per unit of the setting).
NumericOption Overrides(const char* section, const char* key, double scale, bool integer,
                        std::function<void(GraspRequest&, double)> apply) {
  const config::Setting s = config::SettingOf(section, key);
  return {s.min * scale, s.max * scale, integer, std::move(apply)};
}

const std::map<std::string, NumericOption>& NumericOptions() {
  static const std::map<std::string, NumericOption> options = {
      {"opening_stroke_mm", Overrides("gripper", "opening_stroke_mm", 1, false,
                                      [](GraspRequest& r, double v) {
                                        r.plan.gripper.opening_stroke_m = core::MetresFromMm(v);
                                      })},
      {"finger_width_mm", Overrides("gripper", "finger_width_mm", 1, false,
                                    [](GraspRequest& r, double v) {
                                      r.plan.gripper.finger_width_m = core::MetresFromMm(v);
                                    })},
      {"finger_thickness_mm", Overrides("gripper", "finger_thickness_mm", 1, false,
                                        [](GraspRequest& r, double v) {
                                          r.plan.gripper.finger_thickness_m = core::MetresFromMm(v);
                                        })},
      {"finger_length_mm", Overrides("gripper", "finger_length_mm", 1, false,
                                     [](GraspRequest& r, double v) {
                                       r.plan.gripper.finger_length_m = core::MetresFromMm(v);
                                     })},
      {"top_k",
       Overrides("fge", "top_k", 1, true,
                 [](GraspRequest& r, double v) { r.plan.fge.top_k = static_cast<int>(v); })},
      {"num_angles",
       Overrides("fge", "num_angles", 1, true,
                 [](GraspRequest& r, double v) { r.plan.fge.num_angles = static_cast<int>(v); })},
      {"num_height_steps", Overrides("fge", "num_height_steps", 1, true,
                                     [](GraspRequest& r, double v) {
                                       r.plan.fge.num_height_steps = static_cast<int>(v);
                                     })},
      {"height_step_mm",
       Overrides("fge", "height_step_m", 1000, false,
                 [](GraspRequest& r, double v) { r.plan.fge.height_step_m = v / 1000.0; })},
      {"grip_depth_mm",
       Overrides("fge", "grip_depth_m", 1000, false,
                 [](GraspRequest& r, double v) { r.plan.fge.grip_depth_m = v / 1000.0; })},
      {"min_depth_m", Overrides("depth", "min_depth_m", 1, false,
                                [](GraspRequest& r, double v) { r.plan.min_depth_m = v; })},
  };
  return options;
}

constexpr const char* kIntrinsicKeys[] = {"fx", "fy", "cx", "cy"};

core::Result<core::Camera> ResolveCamera(const RequestFields& fields,
                                         const config::ServiceConfig& config,
                                         const core::DepthImage& depth, std::string* source) {
  core::Camera camera = config.default_camera;
  *source = "default";
  if (fields.intrinsics_json) {
    auto parsed = io::ParseIntrinsicsJson(*fields.intrinsics_json);
    if (!parsed.ok()) {
      core::Error e = parsed.error();
      e.message = "intrinsics: " + e.message;
      return e;
    }
    camera = parsed.value();
    *source = "request";
  }
  int given = 0;
  for (const char* key : kIntrinsicKeys) given += fields.values.count(key) ? 1 : 0;
  if (given != 0 && given != 4) {
    return MakeError(ErrorCode::kInvalidArgument, "give all of fx, fy, cx, cy or none of them",
                     "fx");
  }
  if (given == 4) {
    double* targets[] = {&camera.fx, &camera.fy, &camera.cx, &camera.cy};
    for (int i = 0; i < 4; ++i) {
      const bool focal = i < 2;
      auto v = ParseNumber(kIntrinsicKeys[i], fields.values.at(kIntrinsicKeys[i]),
                           focal ? 1e-6 : -1e6, 1e6);
      if (!v.ok()) return v.error();
      *targets[i] = v.value();
    }
    *source = "request";
  }
  if (*source == "request" && fields.intrinsics_json &&
      (camera.width != depth.width() || camera.height != depth.height())) {
    return MakeError(ErrorCode::kUnprocessable,
                     "intrinsics are for " + std::to_string(camera.width) + "x" +
                         std::to_string(camera.height) + " but the depth image is " +
                         std::to_string(depth.width()) + "x" + std::to_string(depth.height()),
                     "intrinsics");
  }
  if (*source == "default" && (camera.width != depth.width() || camera.height != depth.height())) {
    // Same focal lengths, principal point at the centre of this image.
    camera.cx = (depth.width() - 1) / 2.0;
    camera.cy = (depth.height() - 1) / 2.0;
  }
  camera.width = depth.width();
  camera.height = depth.height();
  return camera;
}

// Fields every depth upload may carry besides the image: the intrinsics and the PNG unit.
bool IsUploadField(const std::string& key) {
  if (key == "png_unit_m") return true;
  for (const char* k : kIntrinsicKeys) {
    if (key == k) return true;
  }
  return false;
}

core::Result<DepthUpload> DecodeUpload(const RequestFields& fields,
                                       const config::ServiceConfig& config) {
  double png_unit_m = config.png_unit_m;
  if (const auto unit = fields.values.find("png_unit_m"); unit != fields.values.end()) {
    auto v = ParseNumber("png_unit_m", unit->second, 1e-6, 1.0);
    if (!v.ok()) return v.error();
    png_unit_m = v.value();
  }
  DepthUpload out;
  auto format = io::SniffDepthFormat(*fields.depth_bytes);
  if (!format.ok()) return format.error();
  out.depth_format = format.value();
  io::DepthDecodeOptions decode;
  decode.png_unit_m = png_unit_m;
  decode.max_pixels = config.max_image_pixels;
  auto depth = io::DecodeDepth(*fields.depth_bytes, decode);
  if (!depth.ok()) return depth.error();
  out.depth = std::move(depth).value();

  auto camera = ResolveCamera(fields, config, out.depth, &out.camera_source);
  if (!camera.ok()) return camera.error();
  out.camera = camera.value();
  return out;
}

constexpr std::array<const char*, 3> kMethodNames = {"model", "pcl", "fused"};
constexpr std::array<std::optional<segmentation::Method>, 3> kMethods = {
    segmentation::Method::kModel, segmentation::Method::kPcl, segmentation::Method::kFused};

// A label image upload: a 16-bit PNG of the depth's size, counts = instance ids (0 = none).
core::Result<cv::Mat1w> DecodeLabels(const std::string& bytes, const config::ServiceConfig& config,
                                     const core::DepthImage& depth) {
  const auto relabel = [](core::Error e) {
    e.field = "labels";
    return e;
  };
  auto format = io::SniffDepthFormat(bytes);
  if (!format.ok()) return relabel(format.error());
  if (format.value() != io::DepthFormat::kPng16) {
    return MakeError(ErrorCode::kUnsupportedFormat,
                     "labels must be a 16-bit PNG (POST /v1/segmentation?format=labels), got " +
                         std::string(io::DepthFormatName(format.value())),
                     "labels");
  }
  io::DepthDecodeOptions decode;
  decode.png_unit_m = 1.0;  // counts are ids, exact in float
  decode.max_pixels = config.max_image_pixels;
  auto counts = io::DecodeDepth(bytes, decode);
  if (!counts.ok()) {
    core::Error e = relabel(counts.error());
    if (e.message.find("16-bit") != std::string::npos) {
      e.message = "labels must be a 16-bit PNG (POST /v1/segmentation?format=labels): " + e.message;
    }
    return e;
  }
  const cv::Mat1f& ids = counts.value().depth_m;
  if (ids.cols != depth.width() || ids.rows != depth.height()) {
    return MakeError(ErrorCode::kUnprocessable,
                     "labels are " + std::to_string(ids.cols) + "x" + std::to_string(ids.rows) +
                         " but the depth image is " + std::to_string(depth.width()) + "x" +
                         std::to_string(depth.height()),
                     "labels");
  }
  cv::Mat1f zeroed = ids.clone();
  cv::patchNaNs(zeroed, 0.0);  // 0 decodes as missing
  cv::Mat1w labels;
  zeroed.convertTo(labels, CV_16U);
  return labels;
}

// "U,V": a pixel of the image (column, row), integers.
core::Result<cv::Point> ParseTargetPixel(const std::string& text, cv::Size image) {
  const auto bad = [&] {
    return MakeError(ErrorCode::kInvalidArgument,
                     "target_px must be the pixel 'U,V' (column, row; integers) of an object in "
                     "the " +
                         std::to_string(image.width) + "x" + std::to_string(image.height) +
                         " image, got '" + text + "'",
                     "target_px");
  };
  const std::size_t comma = text.find(',');
  if (comma == std::string::npos) return bad();
  auto u = ParseNumber("target_px", text.substr(0, comma), 0, image.width - 1);
  auto v = ParseNumber("target_px", text.substr(comma + 1), 0, image.height - 1);
  if (!u.ok() || !v.ok() || u.value() != std::floor(u.value()) ||
      v.value() != std::floor(v.value())) {
    return bad();
  }
  return cv::Point(static_cast<int>(u.value()), static_cast<int>(v.value()));
}

}  // namespace

namespace {

using Stage = std::optional<core::Error>;

// "strategy": a registered name (default: the last one the loaded models serve), and that
// strategy's own fields into its options.
Stage ParseStrategyFields(const RequestFields& fields, const engine::Models& models,
                          engine::PlanOptions* plan) {
  const auto f = fields.values.find("strategy");
  auto strategy = f == fields.values.end()
                      ? core::Result<const engine::Strategy*>(&engine::DefaultStrategy(models))
                      : engine::StrategyNamed(f->second);
  if (!strategy.ok()) return strategy.error();
  plan->strategy = strategy.value()->info().name;
  auto options = ParseStrategyOptions(*strategy.value(), fields.values);
  if (!options.ok()) return options.error();
  plan->strategy_options = std::move(options).value();
  return std::nullopt;
}

// The gripper's, FGE's and min_depth_m: numbers within their settings' limits. Any other field
// that no stage reads is unknown.
Stage ParseNumericFields(const RequestFields& fields, GraspRequest* out) {
  for (const auto& [key, text] : fields.values) {
    if (key == "format" || key == "strategy" || key == "draw" || key == "overlay" ||
        key == "mean_stiffness" || key == "instances" || key == "segmentation" || key == "target" ||
        key == "target_px" || IsStrategyField(key) || IsUploadField(key)) {
      continue;
    }
    const auto option = NumericOptions().find(key);
    if (option == NumericOptions().end()) {
      return MakeError(ErrorCode::kInvalidArgument, "unknown field '" + key + "'", key);
    }
    auto v = ParseNumber(key, text, option->second.min, option->second.max);
    if (!v.ok()) return v.error();
    if (option->second.integer && v.value() != std::floor(v.value())) {
      return MakeError(ErrorCode::kInvalidArgument, key + " must be an integer", key);
    }
    option->second.apply(*out, v.value());
  }
  return std::nullopt;
}

// How to answer: overlay, format, draw, and mean_stiffness (each grasp's mean of the map).
Stage ParseAnswerFields(const http::Request& request, const RequestFields& fields,
                        const engine::Models& models, GraspRequest* out) {
  auto overlay = ParseChoice<OverlayBackground, 3>(
      fields.values, "overlay", OverlayBackground::kDepth, {"depth", "stiffness", "deformability"},
      {OverlayBackground::kDepth, OverlayBackground::kStiffness,
       OverlayBackground::kDeformability});
  if (!overlay.ok()) return overlay.error();
  out->overlay = overlay.value();
  if (out->overlay == OverlayBackground::kDeformability && !models.segmentation) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "overlay 'deformability' needs a segmentation model and none is loaded",
                     "overlay");
  }
  if (out->overlay == OverlayBackground::kStiffness && !models.stiffness) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "overlay 'stiffness' needs a stiffness model and none is loaded", "overlay");
  }
  auto output = ResolveOutput(request, fields.values);
  if (!output.ok()) return output.error();
  out->output = output.value();
  auto draw = ParseChoice<bool, 2>(fields.values, "draw", true, {"grasps", "none"}, {true, false});
  if (!draw.ok()) return draw.error();
  out->draw_grasps = draw.value();
  auto report = ParseChoice<bool, 2>(fields.values, "mean_stiffness", false, {"true", "false"},
                                     {true, false});
  if (!report.ok()) return report.error();
  out->plan.mean_stiffness = report.value();
  if (out->plan.mean_stiffness && !models.stiffness) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "mean_stiffness needs a stiffness model and none is loaded", "mean_stiffness");
  }
  return std::nullopt;
}

// The depth, its camera and the segmask part.
Stage DecodeGraspUpload(const RequestFields& fields, const config::ServiceConfig& config,
                        GraspRequest* out) {
  auto upload = DecodeUpload(fields, config);
  if (!upload.ok()) return upload.error();
  out->upload = std::move(upload).value();
  if (fields.segmask_bytes) {
    auto mask = io::DecodeMask(*fields.segmask_bytes, config.max_image_pixels);
    if (!mask.ok()) return mask.error();
    out->plan.region_of_interest = std::move(mask).value();  // its size is the engine's to check
  }
  return std::nullopt;
}

// "target": an instance id from 1.
Stage ParseTargetId(const RequestFields& fields, engine::PlanOptions* plan) {
  const auto target = fields.values.find("target");
  if (target == fields.values.end()) return std::nullopt;
  auto id = ParseNumber("target", target->second, 1, 65535);
  if (!id.ok()) return id.error();
  if (id.value() != std::floor(id.value())) {
    return MakeError(
        ErrorCode::kInvalidArgument,
        "target must be an instance id (an integer from 1), got '" + target->second + "'",
        "target");
  }
  plan->target_id = static_cast<int>(id.value());
  return std::nullopt;
}

// Instances: instances, segmentation, target or target_px, and the labels part.
Stage ParseInstanceFields(const RequestFields& fields, const config::ServiceConfig& config,
                          GraspRequest* out) {
  engine::PlanOptions& plan = out->plan;
  auto instances =
      ParseChoice<bool, 2>(fields.values, "instances", false, {"true", "false"}, {true, false});
  if (!instances.ok()) return instances.error();
  plan.report_instances = instances.value();
  auto method = ParseChoice<std::optional<segmentation::Method>, 3>(
      fields.values, "segmentation", std::nullopt, kMethodNames, kMethods);
  if (!method.ok()) return method.error();
  plan.instances.method = method.value();
  if (auto error = ParseTargetId(fields, &plan)) return error;
  if (const auto px = fields.values.find("target_px"); px != fields.values.end()) {
    if (plan.target_id > 0) {
      return MakeError(ErrorCode::kInvalidArgument, "give either target or target_px, not both",
                       "target_px");
    }
    auto point = ParseTargetPixel(px->second, out->upload.depth.depth_m.size());
    if (!point.ok()) return point.error();
    plan.target_px = point.value();
  }
  if (fields.labels_bytes) {
    auto labels = DecodeLabels(*fields.labels_bytes, config, out->upload.depth);
    if (!labels.ok()) return labels.error();
    plan.instances.labels = std::move(labels).value();
    if (plan.instances.method) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "give either a labels part or segmentation, not both: labels are used "
                       "as they are",
                       "segmentation");
    }
    plan.report_instances = true;  // a labels part asks for each grasp's instance
  }
  return std::nullopt;
}

}  // namespace

core::Result<GraspRequest> ParseGraspRequest(const http::Request& request,
                                             const config::ServiceConfig& config,
                                             const engine::Models& models) {
  auto collected = CollectFields(request);
  if (!collected.ok()) return collected.error();
  const RequestFields& fields = collected.value();
  GraspRequest out;
  out.plan.gripper = config.default_gripper;
  out.plan.fge = config.fge;
  out.plan.min_depth_m = config.min_depth_m;
  if (auto error = ParseNumericFields(fields, &out)) return *error;
  if (auto error = ParseStrategyFields(fields, models, &out.plan)) return *error;
  if (auto error = ParseAnswerFields(request, fields, models, &out)) return *error;
  if (auto error = DecodeGraspUpload(fields, config, &out)) return *error;
  if (auto error = ParseInstanceFields(fields, config, &out)) return *error;
  return out;
}

core::Result<StiffnessRequest> ParseStiffnessRequest(const http::Request& request,
                                                     const config::ServiceConfig& config) {
  auto collected = CollectFields(request);
  if (!collected.ok()) return collected.error();
  const RequestFields& fields = collected.value();
  for (const auto& [key, text] : fields.values) {
    if (key != "format" && !IsUploadField(key)) {
      return MakeError(ErrorCode::kInvalidArgument, "unknown field '" + key + "'", key);
    }
  }
  if (fields.segmask_bytes || fields.labels_bytes) {
    const char* part = fields.segmask_bytes ? "segmask" : "labels";
    return MakeError(ErrorCode::kInvalidArgument,
                     std::string("unknown field '") + part + "' (it applies to /v1/grasps)", part);
  }
  StiffnessRequest out;
  auto format = ParseChoice<StiffnessFormat, 4>(fields.values, "format", StiffnessFormat::kPng8,
                                                {"png8", "png16", "npy", "color"},
                                                {StiffnessFormat::kPng8, StiffnessFormat::kPng16,
                                                 StiffnessFormat::kNpy, StiffnessFormat::kColor});
  if (!format.ok()) return format.error();
  out.format = format.value();
  auto upload = DecodeUpload(fields, config);
  if (!upload.ok()) return upload.error();
  out.upload = std::move(upload).value();
  return out;
}

core::Result<SegmentationRequest> ParseSegmentationRequest(const http::Request& request,
                                                           const config::ServiceConfig& config) {
  auto collected = CollectFields(request);
  if (!collected.ok()) return collected.error();
  const RequestFields& fields = collected.value();
  for (const auto& [key, text] : fields.values) {
    if (key != "format" && key != "method" && key != "encoding" && !IsUploadField(key)) {
      return MakeError(ErrorCode::kInvalidArgument, "unknown field '" + key + "'", key);
    }
  }
  if (fields.segmask_bytes || fields.labels_bytes) {
    const char* part = fields.segmask_bytes ? "segmask" : "labels";
    return MakeError(ErrorCode::kInvalidArgument,
                     std::string("unknown field '") + part + "' (it applies to /v1/grasps)", part);
  }
  SegmentationRequest out;
  auto method = ParseChoice<std::optional<segmentation::Method>, 3>(
      fields.values, "method", std::nullopt, kMethodNames, kMethods);
  if (!method.ok()) return method.error();
  out.method = method.value();
  auto format = ParseChoice<SegmentationFormat, 4>(
      fields.values, "format", SegmentationFormat::kJson,
      {"json", "labels", "overlay", "deformability"},
      {SegmentationFormat::kJson, SegmentationFormat::kLabels, SegmentationFormat::kOverlay,
       SegmentationFormat::kDeformability});
  if (!format.ok()) return format.error();
  out.format = format.value();
  auto encoding = ParseChoice<StiffnessFormat, 4>(fields.values, "encoding", StiffnessFormat::kPng8,
                                                  {"png8", "png16", "npy", "color"},
                                                  {StiffnessFormat::kPng8, StiffnessFormat::kPng16,
                                                   StiffnessFormat::kNpy, StiffnessFormat::kColor});
  if (!encoding.ok()) return encoding.error();
  out.encoding = encoding.value();
  if (fields.values.count("encoding") && out.format != SegmentationFormat::kDeformability) {
    return MakeError(ErrorCode::kInvalidArgument, "encoding applies to format=deformability only",
                     "encoding");
  }
  if (out.method == segmentation::Method::kPcl &&
      out.format == SegmentationFormat::kDeformability) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "format 'deformability' needs method 'model': the PCL baseline estimates no "
                     "deformability",
                     "format");
  }
  auto upload = DecodeUpload(fields, config);
  if (!upload.ok()) return upload.error();
  out.upload = std::move(upload).value();
  return out;
}

}  // namespace softgrasp::rest
