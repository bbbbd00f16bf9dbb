#include "service/engine/strategy.h"

#include <cstdint>

namespace softgrasp::engine {

const std::vector<StrategyField>& Strategy::fields() const {
  static const std::vector<StrategyField> none;
  return none;
}

std::optional<core::Error> Strategy::Validate(const StrategyOptions* /*options*/,
                                              const PlanOptions& /*common*/,
                                              const core::Camera& /*camera*/) const {
  return std::nullopt;
}

nlohmann::json FieldValueJson(const StrategyField& field, const FieldValue& value) {
  switch (field.kind) {
    case StrategyField::Kind::kInteger:
      return static_cast<std::int64_t>(std::get<double>(value));
    case StrategyField::Kind::kChoice:
      return field.choices.at(static_cast<std::size_t>(std::get<double>(value)));
    case StrategyField::Kind::kNumberList:
      return std::get<std::vector<double>>(value);
    case StrategyField::Kind::kNumber:
      break;
  }
  return std::get<double>(value);
}

}  // namespace softgrasp::engine
