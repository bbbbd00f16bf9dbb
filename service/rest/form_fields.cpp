#include "service/rest/form_fields.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace softgrasp::rest {

core::Result<double> ParseNumber(const std::string& field, const std::string& text, double min,
                                 double max) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || errno != 0 || end != text.c_str() + text.size() || !std::isfinite(v)) {
    return core::MakeError(core::ErrorCode::kInvalidArgument,
                           field + " must be a number, got '" + text + "'", field);
  }
  if (v < min || v > max) {
    return core::MakeError(core::ErrorCode::kInvalidArgument,
                           field + " must be in [" + std::to_string(min) + ", " +
                               std::to_string(max) + "], got " + text,
                           field);
  }
  return v;
}

core::Result<OutputFormat> ResolveOutput(const http::Request& request, const FieldValues& fields) {
  if (fields.count("format")) {
    return ParseChoice<OutputFormat, 2>(fields, "format", OutputFormat::kJson, {"json", "png"},
                                        {OutputFormat::kJson, OutputFormat::kPng});
  }
  const std::string accept(request.header("Accept").value_or(""));
  if (accept.find("image/png") != std::string::npos &&
      accept.find("application/json") == std::string::npos) {
    return OutputFormat::kPng;
  }
  return OutputFormat::kJson;
}

}  // namespace softgrasp::rest
