#include "service/http/router.h"

#include <algorithm>
#include <optional>
#include <stdexcept>
#include <string_view>

namespace softgrasp::http {
namespace {

/// "/a/b/" -> {"a", "b", ""}; "/" -> {""}.
std::vector<std::string_view> SplitPath(std::string_view path) {
  if (!path.empty() && path.front() == '/') path.remove_prefix(1);
  std::vector<std::string_view> out;
  while (true) {
    const std::size_t slash = path.find('/');
    out.push_back(path.substr(0, slash));
    if (slash == std::string_view::npos) return out;
    path.remove_prefix(slash + 1);
  }
}

bool IsCapture(std::string_view segment) {
  return segment.size() > 2 && segment.front() == '{' && segment.back() == '}';
}

/// The request path as decoded segments. Splits the raw target (when it is origin-form) before
/// decoding, so an encoded "%2F" stays inside its segment; otherwise uses the decoded path as is.
std::optional<std::vector<std::string>> RequestSegments(const Request& request) {
  std::vector<std::string> out;
  if (!request.target.empty() && request.target.front() == '/') {
    const std::string_view raw =
        std::string_view(request.target).substr(0, request.target.find('?'));
    for (const std::string_view segment : SplitPath(raw)) {
      if (segment.find('%') == std::string_view::npos) {
        out.emplace_back(segment);  // nothing to decode
        continue;
      }
      auto decoded = PercentDecode(segment, false);
      if (!decoded) return std::nullopt;
      out.push_back(std::move(*decoded));
    }
  } else {
    for (const std::string_view segment : SplitPath(request.path)) out.emplace_back(segment);
  }
  return out;
}

/// How many literal segments of `pattern` match, or -1 when the pattern does not match.
/// Captures match any non-empty segment.
int MatchScore(const std::vector<std::string>& pattern, const std::vector<std::string>& path) {
  if (pattern.size() != path.size()) return -1;
  int literals = 0;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    if (IsCapture(pattern[i])) {
      if (path[i].empty()) return -1;
    } else if (pattern[i] == path[i]) {
      ++literals;
    } else {
      return -1;
    }
  }
  return literals;
}

std::string Join(const std::vector<std::string>& items, std::string_view separator) {
  std::string out;
  for (const auto& item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

}  // namespace

void Router::Add(std::string method, std::string pattern, Handler handler, Execution execution) {
  if (pattern.empty() || pattern.front() != '/') {
    throw std::invalid_argument("route pattern must start with '/': " + pattern);
  }
  Route route;
  for (const std::string_view segment : SplitPath(pattern)) route.segments.emplace_back(segment);
  route.method = std::move(method);
  route.pattern = std::move(pattern);
  route.handler = std::move(handler);
  route.execution = execution;
  routes_.push_back(std::move(route));
}

const Router::Route* Router::Find(const Request& request, const std::vector<std::string>* segments,
                                  std::vector<std::string>* allowed) const {
  // Among routes whose pattern matches, the one for this method with the most literal segments
  // wins (ties: first registered). A GET route stands in for a missing HEAD route.
  const Route* best = nullptr;
  const Route* best_get = nullptr;
  int best_score = -1;
  int best_get_score = -1;
  for (const Route& route : routes_) {
    const int score = segments != nullptr ? MatchScore(route.segments, *segments) : -1;
    if (score < 0) continue;
    if (allowed != nullptr &&
        std::find(allowed->begin(), allowed->end(), route.method) == allowed->end()) {
      allowed->push_back(route.method);
    }
    if (route.method == request.method && score > best_score) {
      best = &route;
      best_score = score;
    }
    if (route.method == "GET" && score > best_get_score) {
      best_get = &route;
      best_get_score = score;
    }
  }
  if (best == nullptr && request.method == "HEAD") best = best_get;
  return best;
}

bool Router::AnswersInline(const Request& request) const {
  const auto segments = RequestSegments(request);
  const Route* route = Find(request, segments ? &*segments : nullptr, nullptr);
  return route != nullptr && route->execution == Execution::kInline;
}

Response Router::Dispatch(Request& request) const {
  const auto segments = RequestSegments(request);
  std::vector<std::string> allowed;
  const Route* best = Find(request, segments ? &*segments : nullptr, &allowed);
  if (best != nullptr) {
    request.path_params.clear();
    for (std::size_t i = 0; i < best->segments.size(); ++i) {
      const std::string& segment = best->segments[i];
      if (IsCapture(segment)) {
        request.path_params[segment.substr(1, segment.size() - 2)] = (*segments)[i];
      }
    }
    return best->handler(request);
  }
  if (allowed.empty()) {
    return ErrorResponse(404, "not_found", "no resource at " + request.path);
  }
  const bool has_get = std::find(allowed.begin(), allowed.end(), "GET") != allowed.end();
  const bool has_head = std::find(allowed.begin(), allowed.end(), "HEAD") != allowed.end();
  if (has_get && !has_head) allowed.emplace_back("HEAD");
  const std::string allow = Join(allowed, ", ");
  Response response = ErrorResponse(
      405, "method_not_allowed",
      "method " + request.method + " is not allowed for " + request.path + "; allowed: " + allow);
  response.set_header("Allow", allow);
  return response;
}

std::vector<std::pair<std::string, std::string>> Router::Routes() const {
  std::vector<std::pair<std::string, std::string>> out;
  out.reserve(routes_.size());
  for (const Route& route : routes_) out.emplace_back(route.method, route.pattern);
  return out;
}

}  // namespace softgrasp::http
