#pragma once
/// The strategies' request fields, read from their rooms' tables (engine/strategy.h): parsing a
/// request's values into the chosen strategy's options, and the tables as /v1/info shows them.
/// No strategy is named here.

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "service/core/status.h"
#include "service/engine/strategy.h"
#include "service/rest/form_fields.h"

namespace softgrasp::rest {

/// Whether a registered strategy's table has a field of this name.
bool IsStrategyField(std::string_view name);

/// `text` as `field` (of `owner`'s table) says: a number or an integer in [min, max], one of the
/// choices, or up to max_count comma-separated increasing numbers in the range; kInvalidArgument
/// naming the field.
core::Result<engine::FieldValue> ParseStrategyField(const engine::Strategy& owner,
                                                    const engine::StrategyField& field,
                                                    const std::string& text);

/// The options of `chosen`: its defaults with every field of `values` from its table set. The
/// fields of other strategies' tables are checked the same way and not used. Null for a strategy
/// without options of its own.
core::Result<std::shared_ptr<const engine::StrategyOptions>> ParseStrategyOptions(
    const engine::Strategy& chosen, const FieldValues& values);

/// {name: {field: default, ...}} for the strategies with fields (/v1/info "defaults").
nlohmann::json StrategyDefaultsJson();

/// Every registered strategy with its summary, the models it needs and its fields (name, kind,
/// unit, range, choices, default, doc): what the page builds its form from (/v1/info
/// "strategy_fields").
nlohmann::json StrategyTablesJson();

}  // namespace softgrasp::rest
