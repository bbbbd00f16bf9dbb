#include "sim/robot/robot_http.h"

#include <cstdint>
#include <nlohmann/json.hpp>

#include "service/io/depth_codec.h"
#include "sim/dataset/dataset.h"

namespace softgrasp::sim {
namespace {

using nlohmann::json;

// An image of the current view, tagged with the generation it shows.
http::Response Image(const SimRobotView& view, const char* content_type, std::string bytes) {
  http::Response response = http::Response::Bytes(200, content_type, std::move(bytes));
  response.set_header("X-Scene-Generation", std::to_string(view.generation));
  response.set_header("Cache-Control", "no-store");
  return response;
}

http::Response Manifest(const SimRobotView& view) {
  http::Response response = http::Response::Json(200, view.manifest.dump());
  response.set_header("X-Scene-Generation", std::to_string(view.generation));
  response.set_header("Cache-Control", "no-store");
  return response;
}

// POST /reset body: empty, {} or {"seed": N} with N a non-negative integer.
core::Result<std::optional<std::uint64_t>> ResetSeed(const std::string& body) {
  if (body.find_first_not_of(" \t\r\n") == std::string::npos) return std::optional<std::uint64_t>();
  const json doc = json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return core::MakeError(core::ErrorCode::kInvalidArgument,
                           "the body must be empty or a JSON object {\"seed\": N}");
  }
  for (const auto& [key, value] : doc.items()) {
    if (key != "seed") {
      return core::MakeError(core::ErrorCode::kInvalidArgument, "unknown key '" + key + "'", key);
    }
    if (!value.is_number_unsigned()) {
      return core::MakeError(core::ErrorCode::kInvalidArgument,
                             "seed must be a non-negative integer", "seed");
    }
    return std::optional<std::uint64_t>(value.get<std::uint64_t>());
  }
  return std::optional<std::uint64_t>();
}

}  // namespace

std::string IntrinsicsJson(const core::Camera& camera) {
  return json{{"_frame", kCameraFrame}, {"_fx", camera.fx},        {"_fy", camera.fy},
              {"_cx", camera.cx},       {"_cy", camera.cy},        {"_skew", 0.0},
              {"_width", camera.width}, {"_height", camera.height}}
      .dump();
}

void AddSimRobotRoutes(http::Router& router, SimRobot& robot) {
  router.Add("GET", "/", [](const http::Request&) {
    return http::Response::Json(
        200, json{{"robot", "softgrasp-sim robot (SIMULATED)"},
                  {"routes",
                   {"GET /depth.npy", "GET /depth.png", "GET /camera.intr", "GET /scene.json",
                    "GET /stiffness.png", "GET /labels.png", "POST /reset"}},
                  {"docs", "docs/sim-robot.md"}}
                 .dump());
  });
  router.Add("GET", "/depth.npy", [&robot](const http::Request&) {
    const auto view = robot.view();
    return Image(*view, "application/x-npy", io::EncodeNpy(view->views.depth.depth_m));
  });
  router.Add("GET", "/depth.png", [&robot](const http::Request&) {
    const auto view = robot.view();
    return Image(*view, "image/png", io::EncodePng(DepthToMillimetres(view->views.depth.depth_m)));
  });
  router.Add("GET", "/stiffness.png", [&robot](const http::Request&) {
    const auto view = robot.view();
    return Image(*view, "image/png", io::EncodePng(UnitToByte(view->views.stiffness)));
  });
  router.Add("GET", "/labels.png", [&robot](const http::Request&) {
    const auto view = robot.view();
    return Image(*view, "image/png", io::EncodePng(view->views.labels));
  });
  router.Add("GET", "/camera.intr", [&robot](const http::Request&) {
    return http::Response::Json(200, IntrinsicsJson(robot.view()->camera));
  });
  router.Add("GET", "/scene.json",
             [&robot](const http::Request&) { return Manifest(*robot.view()); });
  router.Add("POST", "/reset", [&robot](const http::Request& request) {
    auto seed = ResetSeed(request.body);
    if (!seed.ok()) {
      return http::ErrorResponse(400, "invalid_argument", seed.error().message, seed.error().field);
    }
    if (auto reset = robot.Reset(seed.value()); !reset.ok()) {
      return http::ErrorResponse(422, "unprocessable", reset.error().message, reset.error().field);
    }
    return Manifest(*robot.view());
  });
}

}  // namespace softgrasp::sim
