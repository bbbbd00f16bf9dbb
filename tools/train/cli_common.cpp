#include "tools/train/cli_common.h"

#include <cmath>
#include <iostream>

namespace softgrasp::tools {

int Fail(std::string_view command, const std::string& message) {
  std::cerr << "softgrasp-train" << (command.empty() ? "" : " ") << command << ": " << message
            << "\n";
  return 2;
}

int FailError(std::string_view command, const core::Error& error) {
  return Fail(command, error.message + (error.field.empty() ? "" : " [" + error.field + "]"));
}

nlohmann::json Num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace softgrasp::tools
