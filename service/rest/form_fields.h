#pragma once
/// Reading the plain fields of an upload request (query parameters and multipart form fields,
/// merged by the caller into one map): numbers within limits, choices among names, and which
/// answer format the client asked for. Errors are kInvalidArgument naming the field.

#include <array>
#include <cstddef>
#include <map>
#include <string>

#include "service/core/status.h"
#include "service/http/message.h"

namespace softgrasp::rest {

using FieldValues = std::map<std::string, std::string>;

/// A whole-string finite number in [min, max]: "FIELD must be a number, got 'x'" or
/// "FIELD must be in [min, max], got x".
core::Result<double> ParseNumber(const std::string& field, const std::string& text, double min,
                                 double max);

/// A field with a fixed set of values: `names[i]` maps to `values[i]`; `fallback` when absent;
/// "KEY must be 'a', 'b' or 'c', got 'x'" otherwise.
template <class T, std::size_t N>
core::Result<T> ParseChoice(const FieldValues& fields, const std::string& key, T fallback,
                            const std::array<const char*, N>& names,
                            const std::array<T, N>& values) {
  const auto f = fields.find(key);
  if (f == fields.end()) return fallback;
  std::string expected;
  for (std::size_t i = 0; i < N; ++i) {
    if (f->second == names[i]) return values[i];
    expected += std::string(i == 0 ? "" : (i + 1 == N ? " or " : ", ")) + "'" + names[i] + "'";
  }
  return core::MakeError(core::ErrorCode::kInvalidArgument,
                         key + " must be " + expected + ", got '" + f->second + "'", key);
}

enum class OutputFormat { kJson, kPng };

/// The field "format" (json | png) when given, else PNG when the Accept header asks for
/// image/png and not application/json, else JSON.
core::Result<OutputFormat> ResolveOutput(const http::Request& request, const FieldValues& fields);

}  // namespace softgrasp::rest
