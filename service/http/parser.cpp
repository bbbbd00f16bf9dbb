#include "service/http/parser.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

// Deliberate choices (RFC 9112), all aimed at leaving no framing ambiguity:
//  - every line must end in CRLF: a bare LF or a stray CR is a 400, never a line break;
//  - obsolete line folding (a field line starting with SP/HTAB) is a 400;
//  - whitespace between a field name and ':' is a 400;
//  - Content-Length together with Transfer-Encoding is a 400, as is more than one Content-Length;
//  - the only Transfer-Encoding accepted is exactly "chunked" (anything else is a 501), and not
//    in HTTP/1.0 requests (400);
//  - HTTP/1.1 requests need exactly one Host field (400 otherwise);
//  - chunked trailer fields are checked for syntax and then dropped, so they can never change
//    the meaning of headers already read;
//  - empty lines before a request line are skipped (RFC 9112 section 2.2) but count against
//    the header limit.
// Limit errors (414, 431) are reported at the byte that crosses the limit, so the outcome does
// not depend on how the stream was split into Feed() calls.

namespace softgrasp::http {
namespace {

constexpr std::size_t kNpos = std::string_view::npos;
/// A chunk-size line, extensions and CRLF included, may not be longer than this.
constexpr std::size_t kMaxChunkLineBytes = 4096;

char ToLowerAscii(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return ToLowerAscii(x) == ToLowerAscii(y);
         });
}

bool StartsWithIgnoreCase(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && EqualsIgnoreCase(s.substr(0, prefix.size()), prefix);
}

bool IsOws(char c) { return c == ' ' || c == '\t'; }

std::string_view TrimOws(std::string_view s) {
  while (!s.empty() && IsOws(s.front())) s.remove_prefix(1);
  while (!s.empty() && IsOws(s.back())) s.remove_suffix(1);
  return s;
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

/// tchar from RFC 9110 section 5.6.2.
bool IsTokenChar(char c) {
  if (IsDigit(c) || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z')) return true;
  return std::string_view("!#$%&'*+-.^_`|~").find(c) != kNpos;
}

bool IsToken(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), IsTokenChar);
}

/// field-value characters: VCHAR, obs-text, SP and HTAB (no CR, LF, NUL or other controls).
bool IsFieldValue(std::string_view s) {
  return std::all_of(s.begin(), s.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u == '\t' || (u >= 0x20 && u != 0x7f);
  });
}

/// Calls f(element) for each trimmed, non-empty element of a comma-separated field value.
template <class F>
void ForEachListElement(std::string_view value, F f) {
  while (true) {
    const std::size_t comma = value.find(',');
    const std::string_view element = TrimOws(value.substr(0, comma));
    if (!element.empty()) f(element);
    if (comma == kNpos) return;
    value.remove_prefix(comma + 1);
  }
}

/// 1*DIGIT, saturating at SIZE_MAX (a huge length is still a length: 413, not 400).
bool ParseDecimal(std::string_view s, std::size_t* out) {
  if (s.empty() || !std::all_of(s.begin(), s.end(), IsDigit)) return false;
  constexpr std::size_t kMax = std::numeric_limits<std::size_t>::max();
  std::size_t v = 0;
  for (const char c : s) {
    const auto d = static_cast<std::size_t>(c - '0');
    v = (v > (kMax - d) / 10) ? kMax : v * 10 + d;
  }
  *out = v;
  return true;
}

int HexDigit(char c) {
  if (IsDigit(c)) return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// "a=1&b=x+y" into decoded pairs in order; empty pieces ("a&&b") are skipped.
bool ParseQuery(std::string_view raw, std::vector<std::pair<std::string, std::string>>* out) {
  while (true) {
    const std::size_t amp = raw.find('&');
    const std::string_view piece = raw.substr(0, amp);
    if (!piece.empty()) {
      const std::size_t eq = piece.find('=');
      auto key = PercentDecode(piece.substr(0, eq), true);
      auto value = eq == kNpos ? std::optional<std::string>(std::string())
                               : PercentDecode(piece.substr(eq + 1), true);
      if (!key || !value) return false;
      out->emplace_back(std::move(*key), std::move(*value));
    }
    if (amp == kNpos) return true;
    raw.remove_prefix(amp + 1);
  }
}

}  // namespace

RequestParser::RequestParser(Limits limits) : limits_(limits) {}

RequestParser::State RequestParser::Feed(std::string_view bytes) {
  if (state_ == State::kError) return state_;
  buffer_.append(bytes);
  if (state_ == State::kComplete) return state_;  // kept for after Take()
  return Advance();
}

Request RequestParser::Take() {
  if (state_ != State::kComplete) {
    throw std::logic_error("RequestParser::Take() without a complete request");
  }
  Request out = std::move(current_);
  current_ = Request{};
  keep_alive_ = request_keep_alive_;
  request_keep_alive_ = true;
  expects_continue_ = false;
  http10_ = false;
  header_bytes_ = 0;
  content_length_ = 0;
  chunk_remaining_ = 0;
  scanned_ = 0;
  phase_ = Phase::kRequestLine;
  state_ = State::kNeedMore;
  buffer_.erase(0, pos_);
  pos_ = 0;
  return out;
}

bool RequestParser::in_progress() const {
  return state_ != State::kNeedMore || phase_ != Phase::kRequestLine || header_bytes_ > 0 ||
         pos_ < buffer_.size();
}

RequestParser::State RequestParser::Advance() {
  bool progressed = true;
  while (state_ == State::kNeedMore && progressed) {
    switch (phase_) {
      case Phase::kRequestLine:
        progressed = StepRequestLine();
        break;
      case Phase::kHeaders:
        progressed = StepHeaderLine();
        break;
      case Phase::kBody:
        progressed = StepBody();
        break;
      case Phase::kChunkSize:
        progressed = StepChunkSize();
        break;
      case Phase::kChunkData:
        progressed = StepChunkData();
        break;
      case Phase::kChunkDataEnd:
        progressed = StepChunkDataEnd();
        break;
      case Phase::kTrailers:
        progressed = StepTrailerLine();
        break;
    }
  }
  if (state_ == State::kNeedMore && pos_ > 0) {  // drop consumed bytes; the rest is a partial unit
    buffer_.erase(0, pos_);
    pos_ = 0;
  }
  return state_;
}

bool RequestParser::Fail(int status, std::string message) {
  state_ = State::kError;
  error_status_ = status;
  error_message_ = std::move(message);
  keep_alive_ = false;
  expects_continue_ = false;
  return false;
}

bool RequestParser::Complete() {
  state_ = State::kComplete;
  expects_continue_ = false;
  return false;
}

RequestParser::LineStatus RequestParser::NextLine(std::string_view* line) {
  const std::size_t nl = buffer_.find('\n', pos_ + scanned_);
  if (nl == std::string::npos) {
    scanned_ = buffer_.size() - pos_;  // don't search these bytes again
    *line = std::string_view(buffer_).substr(pos_);
    return LineStatus::kPartial;
  }
  scanned_ = 0;
  if (nl == pos_ || buffer_[nl - 1] != '\r') {
    *line = std::string_view(buffer_).substr(pos_, nl - pos_);  // without the LF
    return LineStatus::kBareLf;
  }
  *line = std::string_view(buffer_).substr(pos_, nl - 1 - pos_);  // without the CRLF
  return LineStatus::kLine;
}

void RequestParser::ConsumeLine(std::string_view line, std::size_t* counter) {
  pos_ += line.size() + 2;
  if (counter != nullptr) *counter += line.size() + 2;
}

// ---- request line and header fields ----

bool RequestParser::CheckRequestLineLimits(std::string_view line, std::size_t line_bytes) {
  // Offsets (within this line) of the first byte that breaks each limit, kNpos when none does.
  std::size_t uri_break = kNpos;
  if (const std::size_t sp = line.find(' '); sp != kNpos) {
    const std::size_t target_end = std::min(line.find_first_of(" \r", sp + 1), line.size());
    if (target_end - (sp + 1) > limits_.max_uri_bytes) uri_break = sp + 1 + limits_.max_uri_bytes;
  }
  std::size_t header_break = kNpos;
  if (header_bytes_ + line_bytes > limits_.max_header_bytes) {
    header_break = limits_.max_header_bytes - header_bytes_;
  }
  if (uri_break == kNpos && header_break == kNpos) return true;
  if (uri_break <= header_break) {
    return Fail(414,
                "request target longer than " + std::to_string(limits_.max_uri_bytes) + " bytes");
  }
  return Fail(431, "request header block larger than " + std::to_string(limits_.max_header_bytes) +
                       " bytes");
}

bool RequestParser::CheckFieldLineLimit(std::size_t line_bytes) {
  if (header_bytes_ + line_bytes <= limits_.max_header_bytes) return true;
  return Fail(431, "request header block larger than " + std::to_string(limits_.max_header_bytes) +
                       " bytes");
}

bool RequestParser::StepRequestLine() {
  std::string_view line;
  switch (NextLine(&line)) {
    case LineStatus::kPartial:
      CheckRequestLineLimits(line, line.size());
      return false;
    case LineStatus::kBareLf:
      if (!CheckRequestLineLimits(line, line.size() + 1)) return false;
      return Fail(400, "request line must end with CRLF");
    case LineStatus::kLine:
      break;
  }
  if (!CheckRequestLineLimits(line, line.size() + 2)) return false;
  if (line.empty()) {  // an empty line before the request line is skipped
    ConsumeLine(line, &header_bytes_);
    return true;
  }
  if (!ParseRequestLine(line)) return false;
  ConsumeLine(line, &header_bytes_);
  phase_ = Phase::kHeaders;
  return true;
}

bool RequestParser::ParseRequestLine(std::string_view line) {
  // request-line = method SP request-target SP HTTP-version, single spaces only.
  const std::size_t sp1 = line.find(' ');
  const std::size_t sp2 = sp1 == kNpos ? kNpos : line.find(' ', sp1 + 1);
  if (sp1 == kNpos || sp2 == kNpos) return Fail(400, "malformed request line");
  const std::string_view method = line.substr(0, sp1);
  const std::string_view target = line.substr(sp1 + 1, sp2 - sp1 - 1);
  const std::string_view version = line.substr(sp2 + 1);
  if (!IsToken(method)) return Fail(400, "malformed request method");
  if (target.empty()) return Fail(400, "empty request target");

  const bool version_syntax = version.size() == 8 && version.substr(0, 5) == "HTTP/" &&
                              IsDigit(version[5]) && version[6] == '.' && IsDigit(version[7]);
  if (!version_syntax) return Fail(400, "malformed HTTP version");
  if (version[5] != '1' || (version[7] != '0' && version[7] != '1')) {
    return Fail(
        505, "HTTP version " + std::string(version.substr(5)) + " not supported; use 1.1 or 1.0");
  }
  http10_ = version[7] == '0';
  current_.method = std::string(method);
  return ParseTarget(target);
}

bool RequestParser::ParseTarget(std::string_view target) {
  const bool visible_ascii = std::all_of(target.begin(), target.end(),
                                         [](char c) { return c > 0x20 && c < 0x7f && c != '#'; });
  if (!visible_ascii) return Fail(400, "invalid character in request target");
  current_.target = std::string(target);

  std::string_view path_and_query = target;
  if (target == "*") {  // asterisk-form, OPTIONS only
    if (current_.method != "OPTIONS") return Fail(400, "request target '*' is for OPTIONS only");
  } else if (StartsWithIgnoreCase(target, "http://") || StartsWithIgnoreCase(target, "https://")) {
    // absolute-form: keep only the path and query
    const std::size_t authority = target.find("//") + 2;
    const std::size_t path_start = target.find_first_of("/?", authority);
    path_and_query = path_start == kNpos ? std::string_view() : target.substr(path_start);
  } else if (target.front() != '/') {
    return Fail(400, "request target must be an absolute path");
  }

  const std::size_t question = path_and_query.find('?');
  std::string_view raw_path = path_and_query.substr(0, question);
  if (raw_path.empty()) raw_path = "/";
  auto path = PercentDecode(raw_path, false);
  if (!path || path->find('\0') != std::string::npos) {
    return Fail(400, "malformed percent-encoding in request path");
  }
  current_.path = std::move(*path);
  if (question != kNpos) {
    current_.query_string = std::string(path_and_query.substr(question + 1));
    if (!ParseQuery(current_.query_string, &current_.query)) {
      return Fail(400, "malformed percent-encoding in query string");
    }
  }
  return true;
}

bool RequestParser::ParseFieldLine(std::string_view line, Headers* out) {
  if (IsOws(line.front())) return Fail(400, "obsolete header line folding is not supported");
  const std::size_t colon = line.find(':');
  if (colon == kNpos) return Fail(400, "header line without ':'");
  const std::string_view name = line.substr(0, colon);
  if (!IsToken(name)) return Fail(400, "malformed header name");
  const std::string_view value = TrimOws(line.substr(colon + 1));
  if (!IsFieldValue(value)) return Fail(400, "invalid character in header value");
  if (out != nullptr) out->emplace_back(std::string(name), std::string(value));
  return true;
}

bool RequestParser::NextFieldLine(std::string_view* line, const char* kind) {
  switch (NextLine(line)) {
    case LineStatus::kPartial:
      CheckFieldLineLimit(line->size());
      return false;
    case LineStatus::kBareLf:
      if (!CheckFieldLineLimit(line->size() + 1)) return false;
      return Fail(400, std::string(kind) + " line must end with CRLF");
    case LineStatus::kLine:
      break;
  }
  return CheckFieldLineLimit(line->size() + 2);
}

bool RequestParser::StepHeaderLine() {
  std::string_view line;
  if (!NextFieldLine(&line, "header")) return false;
  if (line.empty()) {
    ConsumeLine(line, &header_bytes_);
    return StepHeadersDone();
  }
  if (!ParseFieldLine(line, &current_.headers)) return false;
  ConsumeLine(line, &header_bytes_);
  return true;
}

bool RequestParser::StepHeadersDone() {
  std::size_t hosts = 0;
  std::size_t content_lengths = 0;
  std::string_view content_length;
  bool has_transfer_encoding = false;
  std::vector<std::string_view> codings;
  bool connection_close = false;
  bool connection_keep_alive = false;
  for (const auto& [name, value] : current_.headers) {
    if (EqualsIgnoreCase(name, "Host")) {
      ++hosts;
    } else if (EqualsIgnoreCase(name, "Content-Length")) {
      ++content_lengths;
      content_length = value;
    } else if (EqualsIgnoreCase(name, "Transfer-Encoding")) {
      has_transfer_encoding = true;
      ForEachListElement(value, [&](std::string_view c) { codings.push_back(c); });
    } else if (EqualsIgnoreCase(name, "Connection")) {
      ForEachListElement(value, [&](std::string_view option) {
        connection_close = connection_close || EqualsIgnoreCase(option, "close");
        connection_keep_alive = connection_keep_alive || EqualsIgnoreCase(option, "keep-alive");
      });
    }
  }
  if (hosts > 1) return Fail(400, "more than one Host header");
  if (hosts == 0 && !http10_) return Fail(400, "HTTP/1.1 request without a Host header");
  request_keep_alive_ = http10_ ? (connection_keep_alive && !connection_close) : !connection_close;

  // Message framing: exactly one of nothing, Content-Length, or chunked.
  bool chunked = false;
  if (has_transfer_encoding) {
    if (content_lengths > 0) return Fail(400, "both Content-Length and Transfer-Encoding");
    if (http10_) return Fail(400, "Transfer-Encoding in an HTTP/1.0 request");
    if (codings.empty()) return Fail(400, "empty Transfer-Encoding");
    if (codings.size() != 1 || !EqualsIgnoreCase(codings.front(), "chunked")) {
      return Fail(501, "unsupported Transfer-Encoding; only \"chunked\" is implemented");
    }
    chunked = true;
  }
  content_length_ = 0;
  if (content_lengths > 1) return Fail(400, "more than one Content-Length");
  if (content_lengths == 1) {
    if (!ParseDecimal(content_length, &content_length_)) return Fail(400, "invalid Content-Length");
    if (content_length_ > limits_.max_body_bytes) {
      return Fail(413,
                  "request body larger than " + std::to_string(limits_.max_body_bytes) + " bytes");
    }
  }

  const bool has_body = chunked || content_length_ > 0;
  const auto expect = current_.header("Expect");
  expects_continue_ = has_body && expect && EqualsIgnoreCase(*expect, "100-continue");
  if (chunked) {
    phase_ = Phase::kChunkSize;
  } else if (content_length_ > 0) {
    phase_ = Phase::kBody;
  } else {
    return Complete();
  }
  return true;
}

// ---- bodies ----

bool RequestParser::StepBody() {
  const std::size_t available = buffer_.size() - pos_;
  if (available == 0) return false;
  const std::size_t n = std::min(available, content_length_);
  current_.body.append(buffer_, pos_, n);
  pos_ += n;
  content_length_ -= n;
  expects_continue_ = false;
  if (content_length_ == 0) return Complete();
  return true;
}

bool RequestParser::StepChunkSize() {
  // chunk-size [ BWS ";" chunk-ext ] CRLF; extensions are checked for stray controls and ignored.
  std::string_view line;
  const LineStatus status = NextLine(&line);
  if (status == LineStatus::kPartial) {
    if (line.size() > kMaxChunkLineBytes) Fail(400, "chunk size line too long");
    return false;
  }
  const bool bare_lf = status == LineStatus::kBareLf;
  if (line.size() + (bare_lf ? 1 : 2) > kMaxChunkLineBytes) {
    return Fail(400, "chunk size line too long");
  }
  if (bare_lf) return Fail(400, "chunk size line must end with CRLF");
  expects_continue_ = false;

  std::size_t size = 0;
  std::size_t digits = 0;
  for (; digits < line.size() && HexDigit(line[digits]) >= 0; ++digits) {
    if (size > (std::numeric_limits<std::size_t>::max() >> 4)) {
      return Fail(400, "chunk size too large");
    }
    size = size * 16 + static_cast<std::size_t>(HexDigit(line[digits]));
  }
  if (digits == 0) return Fail(400, "malformed chunk size");
  std::string_view rest = line.substr(digits);
  while (!rest.empty() && IsOws(rest.front())) rest.remove_prefix(1);
  if (!rest.empty() && rest.front() != ';') return Fail(400, "malformed chunk size");
  if (!IsFieldValue(rest)) return Fail(400, "invalid character in chunk extension");
  ConsumeLine(line, nullptr);

  if (size == 0) {
    phase_ = Phase::kTrailers;
    return true;
  }
  if (size > limits_.max_body_bytes - current_.body.size()) {
    return Fail(413,
                "request body larger than " + std::to_string(limits_.max_body_bytes) + " bytes");
  }
  chunk_remaining_ = size;
  phase_ = Phase::kChunkData;
  return true;
}

bool RequestParser::StepChunkData() {
  const std::size_t available = buffer_.size() - pos_;
  if (available == 0) return false;
  const std::size_t n = std::min(available, chunk_remaining_);
  current_.body.append(buffer_, pos_, n);
  pos_ += n;
  chunk_remaining_ -= n;
  if (chunk_remaining_ == 0) phase_ = Phase::kChunkDataEnd;
  return true;
}

bool RequestParser::StepChunkDataEnd() {
  const std::size_t available = buffer_.size() - pos_;
  if (available == 0) return false;
  if (buffer_[pos_] != '\r' || (available >= 2 && buffer_[pos_ + 1] != '\n')) {
    return Fail(400, "chunk data not followed by CRLF");
  }
  if (available < 2) return false;
  pos_ += 2;
  phase_ = Phase::kChunkSize;
  return true;
}

bool RequestParser::StepTrailerLine() {
  std::string_view line;
  if (!NextFieldLine(&line, "trailer")) return false;
  ConsumeLine(line, &header_bytes_);
  if (line.empty()) return Complete();
  return ParseFieldLine(line, nullptr);  // trailers are validated, then dropped
}

}  // namespace softgrasp::http
