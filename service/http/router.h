#pragma once
/// Method + path-pattern routing. Patterns are literal segments and "{name}" captures.

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "service/http/message.h"

namespace softgrasp::http {

using Handler = std::function<Response(const Request&)>;

class Router {
 public:
  /// Registers `handler` for `method` and `pattern`, e.g. ("GET", "/v1/robot/grasps/{id}").
  void Add(std::string method, std::string pattern, Handler handler);

  /// Finds the route, fills request.path_params, calls the handler. Unknown path: 404 JSON error;
  /// known path with another method: 405 with an Allow header. HEAD falls back to GET.
  Response Dispatch(Request& request) const;

  /// (method, pattern) of every route, in registration order.
  std::vector<std::pair<std::string, std::string>> Routes() const;

 private:
  struct Route {
    std::string method;
    std::string pattern;
    std::vector<std::string> segments;
    Handler handler;
  };
  std::vector<Route> routes_;
};

}  // namespace softgrasp::http
