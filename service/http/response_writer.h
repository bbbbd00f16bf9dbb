#pragma once
/// The bytes of an HTTP/1.1 response, without sockets: status line, the handler's headers (those
/// the server owns or that could break the framing dropped), the server's headers and the body.
/// Unit-tested and fuzzed like the request parser.

#include <chrono>
#include <cstddef>
#include <string>
#include <string_view>

#include "service/http/message.h"

namespace softgrasp::http {

/// How one response goes on the wire.
struct ResponseFraming {
  /// X-Request-Id; left out when empty or when it holds a byte that could break the framing.
  std::string_view request_id;
  bool keep_alive = false;  ///< "Connection: keep-alive", else "Connection: close"
  bool head = false;        ///< the answer to a HEAD request: headers only
};

/// Serialises `response`. The handler's Content-Length, Transfer-Encoding, Connection, Date and
/// X-Request-Id are dropped (the server writes its own), and so is any header whose name is
/// empty or holds a control character, space, ':' or DEL, or whose value holds CR, LF or NUL.
/// 1xx, 204 and 304 answers carry neither Content-Length nor body. `*body_bytes` receives the
/// number of body bytes included (0 for HEAD and bodiless statuses).
std::string SerializeResponse(const Response& response, const ResponseFraming& framing,
                              std::size_t* body_bytes);

/// IMF-fixdate for the Date header, e.g. "Sun, 06 Nov 1994 08:49:37 GMT". Formatted once per
/// second per thread: every answer needs it.
std::string HttpDate(std::chrono::system_clock::time_point time);

}  // namespace softgrasp::http
