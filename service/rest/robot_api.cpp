#include "service/rest/robot_api.h"

#include <cctype>
#include <nlohmann/json.hpp>

#include "service/codec/json_codec.h"
#include "service/rest/api.h"
#include "service/rest/robot_request.h"

namespace softgrasp::rest {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

constexpr char kAuthenticate[] = "Bearer realm=\"softgrasp-robot\"";
// Heartbeats come every 0.5 s and a lease is 2 s: a robot that is coming back is seen by then.
constexpr char kRetryAfterS[] = "2";

double UnixSeconds(std::int64_t unix_ns) { return static_cast<double>(unix_ns) * 1e-9; }

json RecordJson(const robot::CommandRecord& r) {
  const bridge::GraspCommand& c = r.command;
  json out = {
      {"id", c.command_id},
      {"state", robot::CommandStateName(r.state)},
      {"robot_id", c.robot_id},
      {"object_id", c.object_id},
      {"accepted_unix_s", UnixSeconds(r.accepted_unix_ns)},
      {"command", codec::ApiCommandJson(c)},
  };
  if (!r.detail.empty()) out["detail"] = r.detail;
  if (r.timed_out_unix_ns != 0) out["timed_out_unix_s"] = UnixSeconds(r.timed_out_unix_ns);
  if (r.result) {
    const bridge::GraspResult& g = *r.result;
    // The robot's result in its bus form, with the record's clock beside it.
    json result = codec::ToJson(g);
    result["finished_unix_s"] = UnixSeconds(g.finished_unix_ns);
    result["received_unix_s"] = UnixSeconds(r.result_received_unix_ns);
    result["round_trip_s"] = UnixSeconds(r.result_received_unix_ns - r.accepted_unix_ns);
    result["late"] = r.result_late;
    out["result"] = std::move(result);
  }
  return out;
}

http::Response Unavailable(const std::string& message, bool retry) {
  http::Response response = ErrorToResponse(MakeError(ErrorCode::kUnavailable, message));
  if (retry) response.set_header("Retry-After", kRetryAfterS);
  return response;
}

// The error answer, with the headers its status calls for.
http::Response Failure(const core::Error& error) {
  http::Response response = ErrorToResponse(error);
  if (error.code == ErrorCode::kUnauthenticated)
    response.set_header("WWW-Authenticate", kAuthenticate);
  if (error.code == ErrorCode::kUnavailable) response.set_header("Retry-After", kRetryAfterS);
  return response;
}

http::Response CommandResponse(int status, const robot::CommandRecord& record) {
  http::Response response = http::Response::Json(status, RecordJson(record).dump());
  response.set_header("Location", "/v1/robot/grasps/" + record.command.command_id);
  response.set_header("Cache-Control", "no-store");
  return response;
}

bool IsJson(const http::Request& request) {
  std::string type(request.header("Content-Type").value_or(""));
  for (char& ch : type) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return type.rfind("application/json", 0) == 0;
}

http::Response PostGrasp(const http::Request& request, const config::ServiceConfig& config,
                         robot::CommandTracker& tracker) {
  if (auto auth = Authorize(request, config.robot.tokens); !auth) return Failure(auth.error());
  if (!IsJson(request)) {
    return Failure(MakeError(ErrorCode::kUnsupportedFormat, "send the grasp as application/json",
                             "Content-Type"));
  }
  auto parsed = ParseRobotGraspRequest(request.body, config.robot);
  if (!parsed) return Failure(parsed.error());
  auto submitted =
      tracker.Submit(std::move(parsed.value().command), std::move(parsed.value().fingerprint));
  if (!submitted) return Failure(submitted.error());
  // A new command is accepted (202); a repeat of a known one shows where it stands (200).
  return CommandResponse(submitted.value().created ? 202 : 200, submitted.value().record);
}

http::Response GetGrasp(const http::Request& request, const config::ServiceConfig& config,
                        const robot::CommandTracker& tracker) {
  if (auto auth = Authorize(request, config.robot.tokens); !auth) return Failure(auth.error());
  const std::string& id = request.path_params.at("id");
  if (!IsValidClientId(id)) {
    return Failure(MakeError(ErrorCode::kInvalidArgument,
                             "id must be 1 to 64 characters from A-Z a-z 0-9 . _ -", "id"));
  }
  auto record = tracker.Get(id);
  if (!record) {
    return Failure(MakeError(ErrorCode::kNotFound, "no robot command with id '" + id + "'", "id"));
  }
  return CommandResponse(200, *record);
}

http::Response GetRobots(const config::ServiceConfig& config,
                         const robot::CommandTracker& tracker) {
  json robots = json::array();
  for (const bridge::RobotInfo& r : tracker.Robots()) {
    robots.push_back({{"robot_id", r.status.robot_id},
                      {"state", bridge::RobotStateName(r.status.state)},
                      {"simulated", r.status.simulated},
                      {"alive", r.alive},
                      {"heartbeat_age_s", r.heartbeat_age_s},
                      {"heartbeat_seq", r.status.heartbeat_seq},
                      {"current_command_id", r.status.current_command_id},
                      {"detail", r.status.detail},
                      {"workspace", codec::ToJson(r.status.workspace)}});
  }
  const json body = {{"enabled", true},
                     {"domain_id", config.robot.domain_id},
                     {"workspace", codec::ToJson(config.robot.workspace)},
                     {"command_timeout_s", config.robot.command_timeout_s},
                     {"default_force_n", config.robot.default_force_n},
                     {"robots", robots}};
  http::Response response = http::Response::Json(200, body.dump());
  response.set_header("Cache-Control", "no-store");
  return response;
}

}  // namespace

bool TokenMatches(std::string_view presented, const std::vector<std::string>& tokens) {
  bool any = false;
  for (const std::string& token : tokens) {
    // Loop over the configured token's length only, reading `presented` cyclically, so the time
    // does not depend on the presented bytes; a length difference is folded in at the end.
    unsigned diff = presented.size() == token.size() ? 0U : 1U;
    for (std::size_t i = 0; i < token.size(); ++i) {
      const char p = presented.empty() ? '\0' : presented[i % presented.size()];
      diff |= static_cast<unsigned char>(p ^ token[i]);
    }
    any |= diff == 0;  // no early exit: every token is compared
  }
  return any;
}

core::Result<bridge::Ok> Authorize(const http::Request& request,
                                   const std::vector<std::string>& tokens) {
  const auto header = request.header("Authorization");
  if (!header) {
    return MakeError(ErrorCode::kUnauthenticated,
                     "this route needs 'Authorization: Bearer <token>' (a robot token)",
                     "Authorization");
  }
  std::string_view value = *header;
  constexpr std::string_view kScheme = "bearer ";
  bool bearer = value.size() > kScheme.size();
  for (std::size_t i = 0; bearer && i < kScheme.size(); ++i) {
    bearer = std::tolower(static_cast<unsigned char>(value[i])) == kScheme[i];
  }
  if (!bearer) {
    return MakeError(ErrorCode::kUnauthenticated,
                     "the Authorization header must be 'Bearer <token>'", "Authorization");
  }
  value.remove_prefix(kScheme.size());
  while (!value.empty() && value.front() == ' ') value.remove_prefix(1);
  while (!value.empty() && value.back() == ' ') value.remove_suffix(1);
  if (!TokenMatches(value, tokens)) {
    return MakeError(ErrorCode::kPermissionDenied, "the token is not accepted", "Authorization");
  }
  return bridge::Ok{};
}

void AddRobotRoutes(http::Router& router, const config::ServiceConfig& config,
                    std::shared_ptr<robot::CommandTracker> tracker) {
  std::string reason = config::RobotDisabledReason(config.robot);
  if (reason.empty() && !tracker) {
    reason = "the robot endpoints are not running in this process (no robot bus)";
  }
  if (!reason.empty()) {
    const http::Handler disabled = [reason](const http::Request&) {
      return Unavailable(reason, /*retry=*/false);
    };
    router.Add("POST", "/v1/robot/grasps", disabled);
    router.Add("GET", "/v1/robot/grasps/{id}", disabled);
    router.Add("GET", "/v1/robot", disabled);
    return;
  }
  router.Add("POST", "/v1/robot/grasps",
             [config, tracker](const http::Request& r) { return PostGrasp(r, config, *tracker); });
  router.Add("GET", "/v1/robot/grasps/{id}",
             [config, tracker](const http::Request& r) { return GetGrasp(r, config, *tracker); });
  router.Add("GET", "/v1/robot",
             [config, tracker](const http::Request&) { return GetRobots(config, *tracker); });
}

}  // namespace softgrasp::rest
