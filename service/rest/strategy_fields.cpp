#include "service/rest/strategy_fields.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "service/engine/engine.h"

namespace softgrasp::rest {
namespace {

using engine::StrategyField;
using Kind = StrategyField::Kind;

core::Error Bad(const StrategyField& field, const std::string& message) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, message, field.name);
}

std::string Shortest(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// A list field's default, e.g. "0.5,0.75,1".
std::string JoinedDefault(const engine::Strategy& owner, const StrategyField& field) {
  std::string out;
  const engine::FieldValue value = field.get(*owner.DefaultOptions());
  for (double v : std::get<std::vector<double>>(value)) {
    out += (out.empty() ? "" : ",") + Shortest(v);
  }
  return out;
}

core::Result<engine::FieldValue> ParseList(const engine::Strategy& owner,
                                           const StrategyField& field, const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return Bad(field, field.name + " must be up to " + std::to_string(field.max_count) +
                          " comma-separated numbers in " + (field.min_exclusive ? "(" : "[") +
                          Shortest(field.min) + ", " + Shortest(field.max) + "], increasing (" +
                          field.doc + "; e.g. " + JoinedDefault(owner, field) + "): " + why +
                          ", got '" + text + "'");
  };
  std::vector<double> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    auto v = ParseNumber(field.name, text.substr(start, comma - start), field.min, field.max);
    if (!v.ok() || (field.min_exclusive && !(v.value() > field.min))) {
      return bad("each must be a number in the range");
    }
    if (!out.empty() && !(v.value() > out.back())) return bad("not increasing");
    out.push_back(v.value());
    if (static_cast<int>(out.size()) > field.max_count) return bad("too many");
    start = comma + 1;
  }
  return engine::FieldValue(std::move(out));
}

}  // namespace

bool IsStrategyField(std::string_view name) {
  for (const engine::Strategy* s : engine::Strategies()) {
    for (const StrategyField& f : s->fields()) {
      if (f.name == name) return true;
    }
  }
  return false;
}

core::Result<engine::FieldValue> ParseStrategyField(const engine::Strategy& owner,
                                                    const StrategyField& field,
                                                    const std::string& text) {
  switch (field.kind) {
    case Kind::kChoice: {
      std::string expected;
      for (std::size_t i = 0; i < field.choices.size(); ++i) {
        if (text == field.choices[i]) return engine::FieldValue(static_cast<double>(i));
        expected += std::string(i == 0 ? "" : (i + 1 == field.choices.size() ? " or " : ", ")) +
                    "'" + field.choices[i] + "'";
      }
      return Bad(field, field.name + " must be " + expected + ", got '" + text + "'");
    }
    case Kind::kNumberList:
      return ParseList(owner, field, text);
    case Kind::kNumber:
    case Kind::kInteger:
      break;
  }
  auto v = ParseNumber(field.name, text, field.min, field.max);
  if (!v.ok()) return v.error();
  if (field.kind == Kind::kInteger && v.value() != std::floor(v.value())) {
    return Bad(field, field.name + " must be an integer");
  }
  return engine::FieldValue(v.value());
}

core::Result<std::shared_ptr<const engine::StrategyOptions>> ParseStrategyOptions(
    const engine::Strategy& chosen, const FieldValues& values) {
  std::shared_ptr<engine::StrategyOptions> options = chosen.DefaultOptions();
  for (const engine::Strategy* s : engine::Strategies()) {
    for (const StrategyField& field : s->fields()) {
      const auto given = values.find(field.name);
      if (given == values.end()) continue;
      auto value = ParseStrategyField(*s, field, given->second);
      if (!value.ok()) return value.error();
      if (s == &chosen) field.set(*options, value.value());
    }
  }
  return std::shared_ptr<const engine::StrategyOptions>(std::move(options));
}

nlohmann::json StrategyDefaultsJson() {
  nlohmann::json out = nlohmann::json::object();
  for (const engine::Strategy* s : engine::Strategies()) {
    if (s->fields().empty()) continue;
    const auto defaults = s->DefaultOptions();
    nlohmann::json fields = nlohmann::json::object();
    for (const StrategyField& f : s->fields()) {
      fields[f.name] = engine::FieldValueJson(f, f.get(*defaults));
    }
    out[s->info().name] = std::move(fields);
  }
  return out;
}

nlohmann::json StrategyTablesJson() {
  nlohmann::json out = nlohmann::json::array();
  for (const engine::Strategy* s : engine::Strategies()) {
    const engine::StrategyInfo& info = s->info();
    nlohmann::json needs = nlohmann::json::array();
    if (info.needs_stiffness_model) needs.push_back("stiffness");
    if (info.needs_segmentation_model) needs.push_back("segmentation");
    if (info.needs_gqcnn_model) needs.push_back("gqcnn");
    const auto defaults = s->DefaultOptions();
    nlohmann::json fields = nlohmann::json::array();
    for (const StrategyField& f : s->fields()) {
      static constexpr const char* kKinds[] = {"number", "integer", "choice", "number_list"};
      nlohmann::json row = {{"name", f.name},
                            {"kind", kKinds[static_cast<int>(f.kind)]},
                            {"unit", f.unit},
                            {"default", engine::FieldValueJson(f, f.get(*defaults))},
                            {"doc", f.doc}};
      if (f.kind == Kind::kChoice) {
        row["choices"] = f.choices;
      } else {
        row["minimum"] = f.min;
        row["maximum"] = f.max;
        if (f.min_exclusive) row["minimum_exclusive"] = true;
        if (f.kind == Kind::kNumberList) row["max_count"] = f.max_count;
      }
      fields.push_back(std::move(row));
    }
    out.push_back({{"name", info.name},
                   {"summary", info.summary},
                   {"needs_models", needs},
                   {"plans_target", info.plans_target},
                   {"fields", fields}});
  }
  return out;
}

}  // namespace softgrasp::rest
