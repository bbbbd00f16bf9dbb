// Fuzzes the response writer: a Response whose status, headers, body and framing come from the
// input. Whatever a handler puts in it, the bytes must stay one well-framed HTTP/1.1 response:
// a status line, header lines without a stray CR or LF, each server header exactly once, a
// Content-Length that matches the body that follows (none for 1xx/204/304), nothing else after.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "service/http/message.h"
#include "service/http/response_writer.h"

namespace {

using softgrasp::http::Response;
using softgrasp::http::ResponseFraming;

void Check(bool ok) {
  if (!ok) std::abort();
}

/// Splits on '\x1f' (unit separator): [status+flags byte pair, request id, name, value, ...,
/// body].
std::vector<std::string_view> Fields(std::string_view bytes) {
  std::vector<std::string_view> out;
  while (true) {
    const std::size_t cut = bytes.find('\x1f');
    out.push_back(bytes.substr(0, cut));
    if (cut == std::string_view::npos) return out;
    bytes.remove_prefix(cut + 1);
  }
}

std::size_t Count(std::string_view haystack, std::string_view needle) {
  std::size_t n = 0;
  for (std::size_t at = haystack.find(needle); at != std::string_view::npos;
       at = haystack.find(needle, at + 1)) {
    ++n;
  }
  return n;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  Response response;
  response.status =
      100 +
      (static_cast<unsigned char>(bytes[0]) * 256 + static_cast<unsigned char>(bytes[1])) % 500;
  const auto flags = static_cast<unsigned char>(bytes[1]);
  const std::vector<std::string_view> fields = Fields(bytes.substr(2));
  const std::string request_id(fields.front());
  std::size_t i = 1;
  for (; i + 2 < fields.size(); i += 2) {
    response.headers.emplace_back(std::string(fields[i]), std::string(fields[i + 1]));
  }
  if (fields.size() > 1) response.body = std::string(fields.back());
  const ResponseFraming framing{request_id, (flags & 1) != 0, (flags & 2) != 0};

  std::size_t body_bytes = 0;
  const std::string out = softgrasp::http::SerializeResponse(response, framing, &body_bytes);

  const std::size_t end = out.find("\r\n\r\n");
  Check(end != std::string::npos);
  const std::string_view head = std::string_view(out).substr(0, end + 2);
  const std::string_view body = std::string_view(out).substr(end + 4);
  Check(head.rfind("HTTP/1.1 " + std::to_string(response.status) + " ", 0) == 0);
  // Every line ends in CRLF; no CR or LF inside a line.
  for (std::size_t start = 0; start < head.size();) {
    const std::size_t crlf = head.find("\r\n", start);
    Check(crlf != std::string_view::npos);
    const std::string_view line = head.substr(start, crlf - start);
    Check(line.find_first_of("\r\n") == std::string_view::npos);
    Check(line.find('\0') == std::string_view::npos);
    start = crlf + 2;
  }
  const bool bodiless = response.status < 200 || response.status == 204 || response.status == 304;
  Check(Count(head, "\r\nDate: ") == 1);
  Check(Count(head, "\r\nConnection: ") == 1);
  Check(Count(head, "\r\nContent-Length: ") == (bodiless ? 0u : 1u));
  Check(Count(head, "\r\nX-Request-Id: ") <= 1);
  if (!bodiless) {
    Check(Count(head, "\r\nContent-Length: " + std::to_string(response.body.size()) + "\r\n") == 1);
  }
  const bool with_body = !bodiless && !framing.head;
  Check(body_bytes == (with_body ? response.body.size() : 0));
  Check(body == (with_body ? std::string_view(response.body) : std::string_view()));
  return 0;
}
