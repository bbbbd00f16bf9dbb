#include "service/http/response_writer.h"

#include <algorithm>
#include <cstdio>
#include <ctime>

namespace softgrasp::http {
namespace {

char ToLowerAscii(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return ToLowerAscii(x) == ToLowerAscii(y);
         });
}

/// Header fields the server writes itself; a handler's copies are dropped.
bool IsServerOwnedHeader(std::string_view name) {
  for (const char* owned :
       {"Content-Length", "Transfer-Encoding", "Connection", "Date", "X-Request-Id"}) {
    if (EqualsIgnoreCase(name, owned)) return true;
  }
  return false;
}

bool IsSafeValue(std::string_view value) {
  return value.find_first_of(std::string_view("\r\n\0", 3)) == std::string_view::npos;
}

/// A handler header that could break the response framing (CR, LF, NUL, or a bad name) is dropped.
bool IsSafeHeader(std::string_view name, std::string_view value) {
  const auto is_bad_name_char = [](char c) {
    return static_cast<unsigned char>(c) <= 0x20 || c == ':' || c == 0x7f;
  };
  return !name.empty() && std::none_of(name.begin(), name.end(), is_bad_name_char) &&
         IsSafeValue(value);
}

/// Whether a response with this status carries no body (and so no Content-Length either, except
/// for 304 where it would describe the 200 and we have none to give).
bool StatusHasNoBody(int status) { return status < 200 || status == 204 || status == 304; }

}  // namespace

std::string HttpDate(std::chrono::system_clock::time_point time) {
  static constexpr const char* kDays[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
  static constexpr const char* kMonths[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                            "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  thread_local std::time_t cached_secs = -1;
  thread_local std::string cached;
  const std::time_t secs = std::chrono::system_clock::to_time_t(time);
  if (secs != cached_secs || cached.empty()) {
    std::tm tm{};
    gmtime_r(&secs, &tm);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s, %02d %s %04d %02d:%02d:%02d GMT", kDays[tm.tm_wday % 7],
                  tm.tm_mday, kMonths[tm.tm_mon % 12], tm.tm_year + 1900, tm.tm_hour, tm.tm_min,
                  tm.tm_sec);
    cached = buf;
    cached_secs = secs;
  }
  return cached;
}

std::string SerializeResponse(const Response& response, const ResponseFraming& framing,
                              std::size_t* body_bytes) {
  std::string out =
      "HTTP/1.1 " + std::to_string(response.status) + " " + ReasonPhrase(response.status) + "\r\n";
  for (const auto& [name, value] : response.headers) {
    if (IsServerOwnedHeader(name) || !IsSafeHeader(name, value)) continue;
    out += name + ": " + value + "\r\n";
  }
  const bool no_body = StatusHasNoBody(response.status);
  if (!no_body) out += "Content-Length: " + std::to_string(response.body.size()) + "\r\n";
  out += "Date: " + HttpDate(std::chrono::system_clock::now()) + "\r\n";
  out += framing.keep_alive ? "Connection: keep-alive\r\n" : "Connection: close\r\n";
  if (!framing.request_id.empty() && IsSafeValue(framing.request_id)) {
    out += "X-Request-Id: ";
    out += framing.request_id;
    out += "\r\n";
  }
  out += "\r\n";
  *body_bytes = (no_body || framing.head) ? 0 : response.body.size();
  out.append(response.body, 0, *body_bytes);
  return out;
}

}  // namespace softgrasp::http
