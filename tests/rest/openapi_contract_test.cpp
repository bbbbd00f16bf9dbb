// Holds the server to openapi.yaml: every documented route is served, every served route is
// documented, and real responses match their documented schemas.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <utility>

#include "service/engine/engine.h"
#include "service/models/segmentation_model.h"
#include "service/rest/api.h"
#include "tests/rest/openapi_schema.h"
#include "tests/rest/server_fixture.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;
using testing::LoadSpec;
using testing::Lower;
using testing::SchemaValidator;

// The Primesense frame 0 and its intrinsics, then `extra` form fields: the upload every test
// here sends.
std::vector<testing::FormPart> PrimesenseUpload(std::vector<testing::FormPart> extra = {}) {
  std::vector<testing::FormPart> parts{
      {"depth", testing::ReadFileBytes(testing::TestData("gqcnn/primesense/single_depth_0.npy")),
       "d.npy"},
      {"intrinsics", testing::ReadFileBytes(testing::TestData("gqcnn/primesense/primesense.intr")),
       "p.intr"}};
  parts.insert(parts.end(), extra.begin(), extra.end());
  return parts;
}

TEST(OpenApiContractTest, EveryDocumentedRouteIsServedAndViceVersa) {
  const json spec = LoadSpec();
  std::set<std::pair<std::string, std::string>> documented;
  for (const auto& [path, item] : spec["paths"].items()) {
    for (const auto& [method, operation] : item.items()) {
      if (method == "parameters") continue;
      documented.emplace(Lower(method), path);
    }
  }
  std::set<std::pair<std::string, std::string>> served;
  for (const auto& [method, pattern] : BuildRouter(config::ServiceConfig{}).Routes()) {
    served.emplace(Lower(method), pattern);
  }
  EXPECT_EQ(documented, served);
}

// The strategies' field tables (their rooms, service/engine/strategies/) and openapi.yaml agree:
// every table field is a documented query parameter and multipart field of POST /v1/grasps with
// the table's type, range, default and doc line ("strategy=NAME: DOC"), and every parameter
// documented for one strategy is in that strategy's table.
TEST(OpenApiContractTest, StrategyFieldTablesAreWhatTheSpecDocuments) {
  const json spec = LoadSpec();
  const json& grasps = spec["paths"]["/v1/grasps"]["post"];
  std::map<std::string, json> parameters;
  for (const json& p : grasps["parameters"]) parameters[p["name"].get<std::string>()] = p;
  const json& form =
      grasps["requestBody"]["content"]["multipart/form-data"]["schema"]["properties"];
  std::set<std::string> in_tables;
  for (const engine::Strategy* strategy : engine::Strategies()) {
    const std::string name = strategy->info().name;
    const auto defaults = strategy->DefaultOptions();
    for (const engine::StrategyField& f : strategy->fields()) {
      SCOPED_TRACE(name + "." + f.name);
      in_tables.insert(f.name);
      ASSERT_TRUE(parameters.count(f.name)) << "not a documented query parameter";
      ASSERT_TRUE(form.contains(f.name)) << "not a documented multipart field";
      const json& p = parameters[f.name];
      EXPECT_EQ(p.value("description", ""), "strategy=" + name + ": " + f.doc);
      const json& schema = p["schema"];
      const json expected_default = engine::FieldValueJson(f, f.get(*defaults));
      using Kind = engine::StrategyField::Kind;
      switch (f.kind) {
        case Kind::kChoice:
          EXPECT_EQ(schema["type"], "string");
          EXPECT_EQ(schema["enum"], json(f.choices));
          EXPECT_EQ(schema["default"], expected_default);
          break;
        case Kind::kNumberList: {
          EXPECT_EQ(schema["type"], "string");
          std::string joined;
          for (const json& v : expected_default) {
            std::ostringstream text;
            text << v.get<double>();
            joined += (joined.empty() ? "" : ",") + text.str();
          }
          EXPECT_EQ(schema["default"], joined);
          break;
        }
        case Kind::kNumber:
        case Kind::kInteger:
          EXPECT_EQ(schema["type"], f.kind == Kind::kInteger ? "integer" : "number");
          EXPECT_EQ(form[f.name]["type"], schema["type"]);
          EXPECT_DOUBLE_EQ(schema["minimum"].get<double>(), f.min);
          EXPECT_DOUBLE_EQ(schema["maximum"].get<double>(), f.max);
          EXPECT_DOUBLE_EQ(schema["default"].get<double>(), expected_default.get<double>());
          break;
      }
    }
  }
  for (const auto& [field, p] : parameters) {
    const std::string description = p.value("description", "");
    if (description.rfind("strategy=", 0) != 0) continue;
    EXPECT_TRUE(in_tables.count(field)) << field << " is documented for a strategy that has no "
                                        << "such field in its table";
  }
}

TEST(OpenApiContractTest, ResponsesMatchTheirSchemas) {
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const auto schema_of = [&](const std::string& path, const std::string& method,
                             const std::string& status) -> const json& {
    const json& response = validator.Resolve(spec["paths"][path][method]["responses"][status]);
    return response["content"]["application/json"]["schema"];
  };
  testing::RunningServer server;

  const auto health = server.Send(testing::RawRequest("GET", "/healthz"));
  ASSERT_EQ(health.status, 200);
  EXPECT_EQ(validator.Validate(json::parse(health.body), schema_of("/healthz", "get", "200")),
            std::vector<std::string>{});

  const auto info = server.Send(testing::RawRequest("GET", "/v1/info"));
  ASSERT_EQ(info.status, 200);
  EXPECT_EQ(validator.Validate(json::parse(info.body), schema_of("/v1/info", "get", "200")),
            std::vector<std::string>{});

  const auto grasps = server.Send(testing::MultipartRequest("/v1/grasps", PrimesenseUpload()));
  ASSERT_EQ(grasps.status, 200) << grasps.body;
  const json grasps_body = json::parse(grasps.body);
  ASSERT_FALSE(grasps_body["grasps"].empty());
  EXPECT_EQ(validator.Validate(grasps_body, schema_of("/v1/grasps", "post", "200")),
            std::vector<std::string>{});

  const auto bad =
      server.Send(testing::RawRequest("POST", "/v1/grasps", "application/x-npy", "not npy"));
  EXPECT_EQ(bad.status, 415);
  EXPECT_EQ(validator.Validate(json::parse(bad.body), schema_of("/v1/grasps", "post", "415")),
            std::vector<std::string>{});

  const auto fractal =
      server.Send(testing::RawRequest("POST", "/v1/fractals", "application/json",
                                      R"({"seed": 3, "points": 4000, "format": "json"})"));
  ASSERT_EQ(fractal.status, 200) << fractal.body;
  EXPECT_EQ(
      validator.Validate(json::parse(fractal.body), spec["components"]["schemas"]["FractalStats"]),
      std::vector<std::string>{});

  const auto mesh_grasps = server.Send(testing::RawRequest(
      "POST", "/v1/meshes/grasps?num_grasps=10&robust_samples=2", "application/octet-stream",
      testing::ReadFileBytes(testing::TestData("meshes/dexnet_bar_clamp.obj"))));
  ASSERT_EQ(mesh_grasps.status, 200) << mesh_grasps.body;
  EXPECT_EQ(validator.Validate(json::parse(mesh_grasps.body),
                               schema_of("/v1/meshes/grasps", "post", "200")),
            std::vector<std::string>{});

  // Errors from the HTTP layer (unknown route) have the same shape.
  const auto missing = server.Send(testing::RawRequest("GET", "/nope"));
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(validator.Validate(json::parse(missing.body), spec["components"]["schemas"]["Error"]),
            std::vector<std::string>{});
}

TEST(OpenApiContractTest, StiffnessAnswersMatchTheirSchemas) {
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const json& error_schema = spec["components"]["schemas"]["Error"];
  testing::RunningServer with_model({}, nullptr, nullptr, testing::ShippedStiffnessModel());

  const auto info = with_model.Send(testing::RawRequest("GET", "/v1/info"));
  ASSERT_EQ(info.status, 200);
  EXPECT_EQ(validator.Validate(json::parse(info.body), spec["components"]["schemas"]["Info"]),
            std::vector<std::string>{});
  const auto grasps = with_model.Send(testing::MultipartRequest("/v1/grasps", PrimesenseUpload()));
  ASSERT_EQ(grasps.status, 200) << grasps.body;
  const json body = json::parse(grasps.body);
  ASSERT_FALSE(body["grasps"].empty());
  EXPECT_EQ(validator.Validate(body, spec["components"]["schemas"]["GraspResponse"]),
            std::vector<std::string>{});

  const json& stiffness_200 = spec["paths"]["/v1/stiffness"]["post"]["responses"]["200"];
  for (const auto& [format, type] :
       std::vector<std::pair<std::string, std::string>>{{"png8", "image/png"},
                                                        {"png16", "image/png"},
                                                        {"npy", "application/x-npy"},
                                                        {"color", "image/png"}}) {
    auto parts = PrimesenseUpload();
    parts.push_back({"format", format, ""});
    const auto reply = with_model.Send(testing::MultipartRequest("/v1/stiffness", parts));
    EXPECT_EQ(reply.status, 200) << format;
    EXPECT_EQ(reply.header("Content-Type").value_or(""), type) << format;
    EXPECT_TRUE(stiffness_200["content"].contains(type)) << type;
  }
  const auto bad =
      with_model.Send(testing::MultipartRequest("/v1/stiffness", {{"format", "gif", ""}}));
  EXPECT_EQ(bad.status, 400);
  EXPECT_EQ(validator.Validate(json::parse(bad.body), error_schema), std::vector<std::string>{});

  testing::RunningServer without_model;
  const auto unavailable =
      without_model.Send(testing::MultipartRequest("/v1/stiffness", PrimesenseUpload()));
  EXPECT_EQ(unavailable.status, 503);
  EXPECT_EQ(validator.Validate(json::parse(unavailable.body), error_schema),
            std::vector<std::string>{});
  EXPECT_TRUE(spec["paths"]["/v1/stiffness"]["post"]["responses"].contains("503"));
}

TEST(OpenApiContractTest, SegmentationAnswersMatchTheirSchemas) {
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const json& error_schema = spec["components"]["schemas"]["Error"];
  testing::RunningServer server;  // no models: the PCL baseline

  const auto info = server.Send(testing::RawRequest("GET", "/v1/info"));
  EXPECT_EQ(validator.Validate(json::parse(info.body), spec["components"]["schemas"]["Info"]),
            std::vector<std::string>{});

  const json& operation = spec["paths"]["/v1/segmentation"]["post"];
  const auto segmented =
      server.Send(testing::MultipartRequest("/v1/segmentation", PrimesenseUpload()));
  ASSERT_EQ(segmented.status, 200) << segmented.body;
  const json body = json::parse(segmented.body);
  ASSERT_FALSE(body["instances"].empty());
  EXPECT_EQ(validator.Validate(
                body, validator.Resolve(
                          operation["responses"]["200"])["content"]["application/json"]["schema"]),
            std::vector<std::string>{});
  // The documented example is a valid answer too.
  EXPECT_EQ(
      validator.Validate(operation["responses"]["200"]["content"]["application/json"]["example"],
                         spec["components"]["schemas"]["SegmentationResponse"]),
      std::vector<std::string>{});
  for (const char* format : {"labels", "overlay"}) {
    const auto reply = server.Send(
        testing::MultipartRequest("/v1/segmentation", PrimesenseUpload({{"format", format, ""}})));
    EXPECT_EQ(reply.status, 200) << format;
    EXPECT_EQ(reply.header("Content-Type").value_or(""), "image/png") << format;
  }
  for (const auto& [extra, status] :
       std::vector<std::pair<testing::FormPart, int>>{{{"method", "model", ""}, 503},
                                                      {{"format", "deformability", ""}, 503},
                                                      {{"format", "gif", ""}, 400}}) {
    const auto reply =
        server.Send(testing::MultipartRequest("/v1/segmentation", PrimesenseUpload({extra})));
    EXPECT_EQ(reply.status, status) << extra.name << "=" << extra.data;
    EXPECT_EQ(validator.Validate(json::parse(reply.body), error_schema),
              std::vector<std::string>{});
    EXPECT_TRUE(operation["responses"].contains(std::to_string(status)));
  }

  // Grasps with their instances, and with a target.
  for (const auto& extra :
       std::vector<testing::FormPart>{{"instances", "true", ""}, {"target", "1", ""}}) {
    const auto grasps =
        server.Send(testing::MultipartRequest("/v1/grasps", PrimesenseUpload({extra})));
    ASSERT_EQ(grasps.status, 200) << grasps.body;
    const json grasps_body = json::parse(grasps.body);
    EXPECT_FALSE(grasps_body["segmentation"].is_null());
    EXPECT_EQ(validator.Validate(grasps_body, spec["components"]["schemas"]["GraspResponse"]),
              std::vector<std::string>{});
  }
  const auto unknown = server.Send(
      testing::MultipartRequest("/v1/grasps", PrimesenseUpload({{"target", "999", ""}})));
  EXPECT_EQ(unknown.status, 422);
  EXPECT_EQ(validator.Validate(json::parse(unknown.body), error_schema),
            std::vector<std::string>{});
}

// strategy=deformability with the shipped segmentation model (skipped without one).
TEST(OpenApiContractTest, DeformabilityAnswersMatchTheirSchemas) {
  const std::string path = std::string(SOFTGRASP_SOURCE_DIR) + "/models/segmentation.pt";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no segmentation model at " << path;
  auto loaded = models::SegmentationModel::Load(path);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  auto model = std::make_shared<const models::SegmentationModel>(std::move(loaded).value());
  testing::RunningServer server({}, nullptr, nullptr, nullptr, model);
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const auto info = server.Send(testing::RawRequest("GET", "/v1/info"));
  EXPECT_EQ(validator.Validate(json::parse(info.body), spec["components"]["schemas"]["Info"]),
            std::vector<std::string>{});
  for (const char* policy : {"highest", "least_deformable"}) {
    const auto grasps = server.Send(
        testing::MultipartRequest("/v1/grasps", PrimesenseUpload({{"target_policy", policy, ""}})));
    ASSERT_EQ(grasps.status, 200) << grasps.body;
    const json body = json::parse(grasps.body);
    EXPECT_EQ(body["strategy"], "deformability");
    ASSERT_FALSE(body["grasps"].empty());
    EXPECT_EQ(validator.Validate(body, spec["components"]["schemas"]["GraspResponse"]),
              std::vector<std::string>{});
  }
}

// strategy=gqcnn with the shipped GQ-CNN (skipped without one): its grasp and answer fields,
// and the model's decision threshold in /v1/info.
TEST(OpenApiContractTest, GqcnnAnswersMatchTheirSchemas) {
  const auto model = testing::ShippedGqcnnModel();
  if (!model) GTEST_SKIP() << "no shipped GQ-CNN (models/gqcnn.pt)";
  testing::RunningServer server({}, nullptr, nullptr, nullptr, nullptr, model);
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const auto info = server.Send(testing::RawRequest("GET", "/v1/info"));
  EXPECT_EQ(validator.Validate(json::parse(info.body), spec["components"]["schemas"]["Info"]),
            std::vector<std::string>{});
  const auto grasps = server.Send(testing::MultipartRequest(
      "/v1/grasps", PrimesenseUpload({{"strategy", "gqcnn", ""}, {"min_depth_m", "0.6", ""}})));
  ASSERT_EQ(grasps.status, 200) << grasps.body;
  const json body = json::parse(grasps.body);
  ASSERT_FALSE(body["grasps"].empty());
  EXPECT_TRUE(body["grasps"][0]["gqcnn"].contains("predicted_success"));
  EXPECT_EQ(validator.Validate(body, spec["components"]["schemas"]["GraspResponse"]),
            std::vector<std::string>{});
}

TEST(OpenApiContractTest, DisabledRobotRoutesAnswerTheDocumented503) {
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  testing::RunningServer server;  // no tokens, no robot bus
  for (const auto& [method, target] : std::vector<std::pair<std::string, std::string>>{
           {"POST", "/v1/robot/grasps"}, {"GET", "/v1/robot/grasps/abc"}, {"GET", "/v1/robot"}}) {
    const auto reply = server.Send(testing::RawRequest(method, target, "application/json", "{}"));
    EXPECT_EQ(reply.status, 503) << target;
    EXPECT_EQ(validator.Validate(json::parse(reply.body), spec["components"]["schemas"]["Error"]),
              std::vector<std::string>{});
  }
  for (const char* path : {"/v1/robot/grasps", "/v1/robot/grasps/{id}", "/v1/robot"}) {
    for (const auto& [method, operation] : spec["paths"][path].items()) {
      EXPECT_TRUE(operation["responses"].contains("503")) << method << " " << path;
    }
  }
}

TEST(OpenApiContractTest, ValidatorCatchesAMismatch) {
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const json schema = spec["components"]["schemas"]["Grasp"];
  EXPECT_FALSE(validator.Validate(json{{"rank", "first"}}, schema).empty());
}

}  // namespace
}  // namespace softgrasp::rest
