// Holds the server to openapi.yaml: every documented route is served, every served route is
// documented, and real responses match their documented schemas.
#include <set>
#include <string>
#include <utility>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "service/rest/api.h"
#include "tests/rest/server_fixture.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;

json YamlToJson(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Map: {
      json out = json::object();
      for (const auto& kv : node) out[kv.first.as<std::string>()] = YamlToJson(kv.second);
      return out;
    }
    case YAML::NodeType::Sequence: {
      json out = json::array();
      for (const auto& item : node) out.push_back(YamlToJson(item));
      return out;
    }
    case YAML::NodeType::Scalar: {
      const std::string text = node.Scalar();
      if (node.Tag() == "!") return text;  // quoted: always a string
      long long i = 0;
      double d = 0;
      if (YAML::convert<long long>::decode(node, i)) return i;
      if (YAML::convert<double>::decode(node, d)) return d;
      if (text == "true" || text == "false") return text == "true";
      return text;
    }
    default:
      return nullptr;
  }
}

json LoadSpec() {
  return YamlToJson(YAML::LoadFile(std::string(SOFTGRASP_SOURCE_DIR) + "/openapi.yaml"));
}

// A small validator for the JSON Schema subset openapi.yaml uses: $ref, type, required,
// properties, items, enum, minItems, maxItems. Appends one line per violation.
class SchemaValidator {
 public:
  explicit SchemaValidator(json spec) : spec_(std::move(spec)) {}

  std::vector<std::string> Validate(const json& value, const json& schema) const {
    std::vector<std::string> problems;
    Check(value, schema, "$", problems);
    return problems;
  }

  const json& Resolve(const json& schema) const {
    if (!schema.contains("$ref")) return schema;
    const std::string ref = schema["$ref"];  // "#/components/schemas/Name"
    return Resolve(spec_.at(json::json_pointer(ref.substr(1))));
  }

 private:
  void Check(const json& value, const json& raw_schema, const std::string& at,
             std::vector<std::string>& problems) const {
    const json& schema = Resolve(raw_schema);
    if (schema.contains("type")) {
      const std::string type = schema["type"];
      const bool ok = (type == "object" && value.is_object()) ||
                      (type == "array" && value.is_array()) ||
                      (type == "string" && value.is_string()) ||
                      (type == "integer" && value.is_number_integer()) ||
                      (type == "number" && value.is_number()) ||
                      (type == "boolean" && value.is_boolean());
      if (!ok) {
        problems.push_back(at + ": expected " + type + ", got " + value.dump());
        return;
      }
    }
    if (schema.contains("enum")) {
      bool found = false;
      for (const auto& e : schema["enum"]) found = found || e == value;
      if (!found) problems.push_back(at + ": " + value.dump() + " not in enum");
    }
    if (value.is_object()) {
      for (const auto& name : schema.value("required", json::array())) {
        if (!value.contains(name.get<std::string>())) {
          problems.push_back(at + ": missing required " + name.get<std::string>());
        }
      }
      if (schema.contains("properties")) {
        for (const auto& [name, sub] : schema["properties"].items()) {
          if (value.contains(name)) Check(value[name], sub, at + "." + name, problems);
        }
      }
    }
    if (value.is_array()) {
      if (schema.contains("minItems") && value.size() < schema["minItems"].get<std::size_t>()) {
        problems.push_back(at + ": too few items");
      }
      if (schema.contains("maxItems") && value.size() > schema["maxItems"].get<std::size_t>()) {
        problems.push_back(at + ": too many items");
      }
      if (schema.contains("items")) {
        for (std::size_t i = 0; i < value.size(); ++i) {
          Check(value[i], schema["items"], at + "[" + std::to_string(i) + "]", problems);
        }
      }
    }
  }
  json spec_;
};

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
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
  for (const auto& [method, pattern] : BuildRouter(ServiceConfig{}).Routes()) {
    served.emplace(Lower(method), pattern);
  }
  EXPECT_EQ(documented, served);
}

TEST(OpenApiContractTest, ResponsesMatchTheirSchemas) {
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const auto schema_of = [&](const std::string& path, const std::string& method,
                             const std::string& status) -> const json& {
    const json& response =
        validator.Resolve(spec["paths"][path][method]["responses"][status]);
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

  const auto grasps = server.Send(testing::MultipartRequest(
      "/v1/grasps",
      {{"depth", testing::ReadFileBytes(testing::SharedData("gqcnn/primesense/single_depth_0.npy")), "d.npy"},
       {"intrinsics", testing::ReadFileBytes(testing::SharedData("gqcnn/primesense/primesense.intr")), "p.intr"}}));
  ASSERT_EQ(grasps.status, 200) << grasps.body;
  const json grasps_body = json::parse(grasps.body);
  ASSERT_FALSE(grasps_body["grasps"].empty());
  EXPECT_EQ(validator.Validate(grasps_body, schema_of("/v1/grasps", "post", "200")),
            std::vector<std::string>{});

  const auto bad = server.Send(testing::RawRequest("POST", "/v1/grasps", "application/x-npy", "not npy"));
  EXPECT_EQ(bad.status, 415);
  EXPECT_EQ(validator.Validate(json::parse(bad.body), schema_of("/v1/grasps", "post", "415")),
            std::vector<std::string>{});

  // Errors from the HTTP layer (unknown route) have the same shape.
  const auto missing = server.Send(testing::RawRequest("GET", "/nope"));
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(validator.Validate(json::parse(missing.body),
                               spec["components"]["schemas"]["Error"]),
            std::vector<std::string>{});
}

TEST(OpenApiContractTest, ValidatorCatchesAMismatch) {
  const json spec = LoadSpec();
  const SchemaValidator validator(spec);
  const json schema = spec["components"]["schemas"]["Grasp"];
  EXPECT_FALSE(validator.Validate(json{{"rank", "first"}}, schema).empty());
}

}  // namespace
}  // namespace softgrasp::rest
