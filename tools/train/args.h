#pragma once
/// The small argument parser of softgrasp-train's commands: "--name value" pairs and flags taken
/// out of the list one by one, so what is left over is an unknown argument.

#include <cstdlib>
#include <string>
#include <vector>

namespace softgrasp::tools {

struct Args {
  std::vector<std::string> rest;
  bool Take(const std::string& name, std::string* value) {
    for (std::size_t i = 0; i < rest.size(); ++i) {
      if (rest[i] == name && i + 1 < rest.size()) {
        *value = rest[i + 1];
        rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i),
                   rest.begin() + static_cast<std::ptrdiff_t>(i) + 2);
        return true;
      }
    }
    return false;
  }
  bool Flag(const std::string& name) {
    for (std::size_t i = 0; i < rest.size(); ++i) {
      if (rest[i] == name) {
        rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
        return true;
      }
    }
    return false;
  }
};

inline bool ParseInt(const std::string& s, long long lo, long long hi, long long* out) {
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || v < lo || v > hi) return false;
  *out = v;
  return true;
}

inline bool ParseDouble(const std::string& s, double* out) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !(v == v)) return false;
  *out = v;
  return true;
}

}  // namespace softgrasp::tools
