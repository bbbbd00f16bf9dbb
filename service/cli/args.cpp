#include "service/cli/args.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace softgrasp::cli {
namespace {

bool IsOptionName(const std::string& token) { return token.size() > 2 && token.starts_with("--"); }

std::string FieldOf(std::string_view name) {
  while (name.starts_with('-')) name.remove_prefix(1);
  return std::string(name);
}

/// A bound as people write it: 0.05, 5, 1000, 1e-06.
std::string Format(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", x);
  return buffer;
}

}  // namespace

bool Bounds::Contains(double x) const {
  if (!std::isfinite(x)) return false;
  if (lo_open ? !(x > lo) : !(x >= lo)) return false;
  return hi_open ? x < hi : x <= hi;
}

std::string Bounds::Describe() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi) {
    return "in " + std::string(lo_open ? "(" : "[") + Format(lo) + ", " + Format(hi) +
           (hi_open ? ")" : "]");
  }
  if (has_lo) return (lo_open ? "> " : ">= ") + Format(lo);
  if (has_hi) return (hi_open ? "< " : "<= ") + Format(hi);
  return "";
}

bool ParseInteger(std::string_view text, long long* out) {
  const std::string s(text);
  if (s.empty() || std::isspace(static_cast<unsigned char>(s.front()))) return false;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (errno == ERANGE || end != s.c_str() + s.size()) return false;
  *out = v;
  return true;
}

bool ParseNumber(std::string_view text, double* out) {
  const std::string s(text);
  if (s.empty() || std::isspace(static_cast<unsigned char>(s.front()))) return false;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

std::optional<std::string> Args::Take(std::string_view name, bool has_value) {
  if (error_) return std::nullopt;
  std::optional<std::string> found;
  for (std::size_t i = 0; i < rest_.size();) {
    if (rest_[i] != name) {
      ++i;
      continue;
    }
    if (found) {
      Fail(std::string(name) + " given twice", name);
      return std::nullopt;
    }
    std::size_t taken = 1;
    if (has_value) {
      if (i + 1 >= rest_.size() || IsOptionName(rest_[i + 1])) {
        Fail(std::string(name) + " needs a value", name);
        return std::nullopt;
      }
      found = rest_[i + 1];
      taken = 2;
    } else {
      found = std::string();
    }
    rest_.erase(rest_.begin() + static_cast<std::ptrdiff_t>(i),
                rest_.begin() + static_cast<std::ptrdiff_t>(i + taken));
  }
  return found;
}

bool Args::Flag(std::string_view name) { return Take(name, false).has_value(); }

bool Args::Text(std::string_view name, std::string* out) {
  auto value = Take(name, true);
  if (!value) return false;
  *out = std::move(*value);
  return true;
}

bool Args::Required(std::string_view name, std::string_view meta, std::string* out) {
  if (Text(name, out)) return true;
  return Fail(std::string(name) + " " + std::string(meta) + " is required", name);
}

std::vector<std::string> Args::All(std::string_view name) {
  std::vector<std::string> values;
  if (error_) return values;
  for (std::size_t i = 0; i < rest_.size();) {
    if (rest_[i] != name) {
      ++i;
      continue;
    }
    if (i + 1 >= rest_.size() || IsOptionName(rest_[i + 1])) {
      Fail(std::string(name) + " needs a value", name);
      return {};
    }
    values.push_back(rest_[i + 1]);
    rest_.erase(rest_.begin() + static_cast<std::ptrdiff_t>(i),
                rest_.begin() + static_cast<std::ptrdiff_t>(i + 2));
  }
  return values;
}

bool Args::TakeInteger(std::string_view name, long long lo, long long hi, std::string_view what,
                       long long* out) {
  std::string value;
  if (!Text(name, &value)) return false;
  long long v = 0;
  if (!ParseInteger(value, &v) || v < lo || v > hi) {
    const std::string range = hi == kNoLimit
                                  ? " >= " + std::to_string(lo)
                                  : " in " + std::to_string(lo) + ".." + std::to_string(hi);
    return Fail(std::string(name) + " must be " + std::string(what) + range, name);
  }
  *out = v;
  return true;
}

bool Args::TakeNumber(std::string_view name, const Bounds& bounds, double* out) {
  std::string value;
  if (!Text(name, &value)) return false;
  double v = 0;
  if (!ParseNumber(value, &v) || !bounds.Contains(v)) {
    const std::string range = bounds.Describe();
    return Fail(std::string(name) + " must be a number" + (range.empty() ? "" : " " + range), name);
  }
  *out = v;
  return true;
}

bool Args::TakeSpan(std::string_view name, long long lo, long long hi, long long* min,
                    long long* max) {
  std::string value;
  if (!Text(name, &value)) return false;
  long long a = 0, b = 0;
  // The dash between MIN and MAX is the first one after the first character (MIN may be "-1").
  const std::size_t dash = value.find('-', 1);
  const bool parsed = dash == std::string::npos
                          ? ParseInteger(value, &a) && ((b = a), true)
                          : ParseInteger(std::string_view(value).substr(0, dash), &a) &&
                                ParseInteger(std::string_view(value).substr(dash + 1), &b);
  if (!parsed || a < lo || b > hi || a > b) {
    return Fail(std::string(name) + " must be N or MIN-MAX within " + std::to_string(lo) + "-" +
                    std::to_string(hi),
                name);
  }
  *min = a;
  *max = b;
  return true;
}

bool Args::FailChoice(std::string_view name, const std::vector<std::string_view>& words) {
  std::string list;
  for (const std::string_view word : words) {
    list += (list.empty() ? "" : ", ") + std::string(word);
  }
  return Fail(std::string(name) + " must be one of " + list, name);
}

bool Args::Fail(std::string message, std::string_view name) {
  if (!error_) {
    error_ = core::MakeError(core::ErrorCode::kInvalidArgument, std::move(message), FieldOf(name));
  }
  return false;
}

std::optional<core::Error> Args::Finish() const {
  if (error_) return error_;
  if (!rest_.empty()) {
    return core::MakeError(core::ErrorCode::kInvalidArgument, "unknown argument " + rest_.front(),
                           FieldOf(rest_.front()));
  }
  return std::nullopt;
}

}  // namespace softgrasp::cli
