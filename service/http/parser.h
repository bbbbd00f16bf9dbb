#pragma once
/// Incremental HTTP/1.1 request parser over a byte stream: feed bytes as they arrive, take
/// complete requests out. Unit-testable and fuzzable without sockets.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "service/http/message.h"

namespace softgrasp::http {

struct Limits {
  std::size_t max_header_bytes = 16 * 1024;          ///< request line + header block (431)
  std::size_t max_uri_bytes = 8 * 1024;              ///< request-target (414)
  std::size_t max_body_bytes = 64ull * 1024 * 1024;  ///< decoded body (413)
};

/// Outcome of a parse step. On kError, `error_status` is the HTTP status to answer
/// (400, 413, 414, 431, 501, 505) and `error_message` says why; the connection must then close.
class RequestParser {
 public:
  enum class State { kNeedMore, kComplete, kError };

  explicit RequestParser(Limits limits = {});

  /// Appends bytes and advances. Limits are checked as soon as they can be (a Content-Length over
  /// the body limit fails before the body arrives).
  State Feed(std::string_view bytes);

  /// After kComplete: takes the request out and gets ready for the next one on the same
  /// connection (pipelined bytes already fed are kept and parsed by the next Feed(""), which
  /// callers must make after Take()).
  Request Take();

  State state() const { return state_; }
  int error_status() const { return error_status_; }
  const std::string& error_message() const { return error_message_; }
  /// True once any byte of a request has arrived (used to tell idle keep-alive from a slow client).
  bool in_progress() const;
  /// Whether the connection may stay open after answering the last taken request.
  bool keep_alive() const { return keep_alive_; }
  /// The request asked for "Expect: 100-continue" and the body has not been read yet.
  bool expects_continue() const { return expects_continue_; }

 private:
  struct Impl;
  // Implementation state (buffer, phase, chunk decoding) lives here.
  std::string buffer_;
  std::size_t pos_ = 0;
  Limits limits_;
  State state_ = State::kNeedMore;
  int error_status_ = 0;
  std::string error_message_;
  bool keep_alive_ = true;
  bool expects_continue_ = false;
  int phase_ = 0;
  std::size_t content_length_ = 0;
  std::size_t chunk_remaining_ = 0;
  Request current_;
};

}  // namespace softgrasp::http
