#pragma once
// openapi.yaml as JSON, and a small validator for the JSON Schema subset it uses, shared by the
// contract test and the robot API test.

#include <yaml-cpp/yaml.h>

#include <cctype>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace softgrasp::rest::testing {

using nlohmann::json;

inline json YamlToJson(const YAML::Node& node) {
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

inline json LoadSpec() {
  return YamlToJson(YAML::LoadFile(std::string(SOFTGRASP_SOURCE_DIR) + "/openapi.yaml"));
}

// A small validator for the JSON Schema subset openapi.yaml uses: $ref, type, required,
// properties, items, enum, minItems, maxItems, nullable. Appends one line per violation.
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
    if (value.is_null() && schema.value("nullable", false)) return;
    if (schema.contains("type")) {
      const std::string type = schema["type"];
      const bool ok =
          (type == "object" && value.is_object()) || (type == "array" && value.is_array()) ||
          (type == "string" && value.is_string()) ||
          (type == "integer" && value.is_number_integer()) ||
          (type == "number" && value.is_number()) || (type == "boolean" && value.is_boolean());
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

inline std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace softgrasp::rest::testing
