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
  /// Where a route's handler runs. kInline: on the server's I/O thread (ServerOptions::
  /// answer_inline), for handlers that take microseconds and never block; kWorker: the pool.
  enum class Execution { kWorker, kInline };

  /// Registers `handler` for `method` and `pattern`, e.g. ("GET", "/v1/robot/grasps/{id}").
  void Add(std::string method, std::string pattern, Handler handler,
           Execution execution = Execution::kWorker);

  /// Finds the route, fills request.path_params, calls the handler. Unknown path: 404 JSON error;
  /// known path with another method: 405 with an Allow header. HEAD falls back to GET.
  Response Dispatch(Request& request) const;

  /// Whether the route Dispatch() would call for `request` was added as kInline (false for
  /// requests answered 404 or 405).
  bool AnswersInline(const Request& request) const;

  /// (method, pattern) of every route, in registration order.
  std::vector<std::pair<std::string, std::string>> Routes() const;

 private:
  struct Route {
    std::string method;
    std::string pattern;
    std::vector<std::string> segments;
    Handler handler;
    Execution execution = Execution::kWorker;
  };
  /// The route serving `request` (its path split into `segments`), or nullptr; `allowed`, when
  /// given, receives the methods of every route whose pattern matches the path.
  const Route* Find(const Request& request, const std::vector<std::string>* segments,
                    std::vector<std::string>* allowed) const;
  std::vector<Route> routes_;
};

}  // namespace softgrasp::http
