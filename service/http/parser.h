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
  /// True while the body (or its chunks and trailers) of a request whose header block is complete
  /// is still arriving: the header deadline is over, the body deadline applies.
  bool reading_body() const {
    return state_ == State::kNeedMore && phase_ != Phase::kRequestLine && phase_ != Phase::kHeaders;
  }
  /// Whether the connection may stay open after answering the last taken request.
  bool keep_alive() const { return keep_alive_; }
  /// The request asked for "Expect: 100-continue" and the body has not been read yet.
  bool expects_continue() const { return expects_continue_; }

 private:
  /// Where in the request the next byte belongs.
  enum class Phase {
    kRequestLine,   ///< request line (leading empty lines skipped)
    kHeaders,       ///< header field lines up to the empty line
    kBody,          ///< Content-Length body
    kChunkSize,     ///< chunk-size line (with optional extensions)
    kChunkData,     ///< chunk-data bytes
    kChunkDataEnd,  ///< the CRLF after chunk-data
    kTrailers,      ///< trailer field lines up to the empty line
  };
  /// Result of looking for the next CRLF-terminated line.
  enum class LineStatus { kLine, kPartial, kBareLf };

  // Each Step*() consumes what it can of the current phase; it returns true when it made progress
  // (call again), false when it needs more bytes or the state left kNeedMore.
  State Advance();
  bool Fail(int status, std::string message);  ///< enters kError; always returns false
  LineStatus NextLine(std::string_view* line);
  void ConsumeLine(std::string_view line, std::size_t* counter);
  /// A complete CRLF-terminated header or trailer line within the header-block limit; false
  /// when more bytes are needed or the line is refused (`kind` names it in the error).
  bool NextFieldLine(std::string_view* line, const char* kind);
  bool StepRequestLine();
  bool StepHeaderLine();
  bool StepHeadersDone();
  bool StepBody();
  bool StepChunkSize();
  bool StepChunkData();
  bool StepChunkDataEnd();
  bool StepTrailerLine();
  bool CheckRequestLineLimits(std::string_view line, std::size_t line_bytes);
  bool CheckFieldLineLimit(std::size_t line_bytes);
  bool ParseRequestLine(std::string_view line);
  bool ParseTarget(std::string_view target);
  bool ParseFieldLine(std::string_view line, Headers* out);
  bool Complete();

  std::string buffer_;            ///< received bytes; [pos_, end) not yet consumed
  std::size_t pos_ = 0;           ///< first unconsumed byte of buffer_
  std::size_t scanned_ = 0;       ///< bytes after pos_ already searched for '\n'
  std::size_t header_bytes_ = 0;  ///< request line + fields (+ trailers) consumed so far
  Limits limits_;
  State state_ = State::kNeedMore;
  int error_status_ = 0;
  std::string error_message_;
  bool keep_alive_ = true;          ///< of the last taken request
  bool request_keep_alive_ = true;  ///< of the request being parsed
  bool expects_continue_ = false;
  bool http10_ = false;  ///< the request being parsed is HTTP/1.0
  Phase phase_ = Phase::kRequestLine;
  std::size_t content_length_ = 0;   ///< body bytes still to read (kBody)
  std::size_t chunk_remaining_ = 0;  ///< chunk-data bytes still to read (kChunkData)
  Request current_;
};

}  // namespace softgrasp::http
