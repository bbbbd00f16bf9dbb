#pragma once
/// The REST API of openapi.yaml: HTTP <-> engine. Handlers stay short: decode, call, encode.

#include <memory>

#include "service/config/config.h"
#include "service/core/status.h"
#include "service/http/message.h"
#include "service/http/router.h"
#include "service/models/gqcnn_model.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "service/robot/command_tracker.h"

namespace softgrasp::rest {

/// The one mapping from expected failures to HTTP: status and the JSON error body.
int HttpStatusFor(core::ErrorCode code);
http::Response ErrorToResponse(const core::Error& error);

/// A router serving every route documented in openapi.yaml. The robot routes answer 503 (no
/// robot bus in this process).
http::Router BuildRouter(const config::ServiceConfig& config);
/// The same, with the robot routes served by `robot` (null: 503, as above), the stiffness
/// map and strategy=stiffness served by `stiffness_model` (null: POST /v1/stiffness answers 503
/// and /v1/grasps plans with classic FGE only), and object instances segmented by
/// `segmentation_model` (null: POST /v1/segmentation and the instance options of /v1/grasps use
/// the PCL baseline; method=model answers 503), and strategy=gqcnn ranked by `gqcnn_model` (null:
/// strategy=gqcnn is refused with a 400 naming the flag that loads one).
http::Router BuildRouter(
    const config::ServiceConfig& config, std::shared_ptr<robot::CommandTracker> robot,
    std::shared_ptr<const models::StiffnessModel> stiffness_model = nullptr,
    std::shared_ptr<const models::SegmentationModel> segmentation_model = nullptr,
    std::shared_ptr<const models::GqcnnModel> gqcnn_model = nullptr);

}  // namespace softgrasp::rest
