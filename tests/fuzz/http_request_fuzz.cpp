// Fuzzes the HTTP request parser: the input is one connection's byte stream. It is fed whole,
// byte by byte, in two halves and in uneven chunks, with the default and with small limits.
// Every complete request is taken and run through ParseMultipart, PercentDecode and a Router.
// Besides never crashing, all split patterns must give the same requests and the same final
// state: a parser whose result depends on TCP segmentation would be a smuggling risk.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "service/http/message.h"
#include "service/http/parser.h"
#include "service/http/router.h"

namespace {

using softgrasp::http::Limits;
using softgrasp::http::Request;
using softgrasp::http::RequestParser;
using softgrasp::http::Response;
using softgrasp::http::Router;

/// What one split pattern produced, flattened for comparison.
struct Summary {
  std::vector<std::string> requests;
  RequestParser::State state = RequestParser::State::kNeedMore;
  int status = 0;
  bool operator==(const Summary&) const = default;
};

const Router& TestRouter() {
  static const Router router = [] {
    Router r;
    const auto ok = [](const Request&) { return Response::Json(200, "{}"); };
    r.Add("GET", "/", ok);
    r.Add("GET", "/v1/grasps/{id}", ok);
    r.Add("POST", "/v1/grasps", ok);
    r.Add("GET", "/v1/robots/{robot}/grasps/{id}", ok);
    return r;
  }();
  return router;
}

/// Runs the other parsers and the router over a request; returns a digest of the results.
std::string Exercise(Request& request) {
  std::string digest;
  const auto content_type = request.header("Content-Type");
  const auto multipart = softgrasp::http::ParseMultipart(
      content_type ? *content_type : "multipart/form-data; boundary=b", request.body);
  digest += multipart.ok() ? "M" + std::to_string(multipart.parts.size()) : "E";
  for (const auto& part : multipart.parts) digest += "|" + part.name + "|" + part.data;
  const auto decoded = softgrasp::http::PercentDecode(request.target, true);
  digest += decoded ? "D" : "d";
  digest += std::to_string(TestRouter().Dispatch(request).status);
  return digest;
}

std::string Flatten(const Request& request, bool keep_alive, const std::string& digest) {
  std::string out = request.method + ' ' + request.target + ' ' + request.path + '?' +
                    request.query_string + (keep_alive ? " K" : " C");
  for (const auto& [key, value] : request.query) out += '&' + key + '=' + value;
  for (const auto& [name, value] : request.headers) out += '\n' + name + ':' + value;
  out += "\n\n" + request.body + "\n" + digest;
  return out;
}

/// Feeds `data` in chunks of the sizes `sizes` yields (cycled), taking every complete request.
template <class ChunkSize>
Summary Run(std::string_view data, const Limits& limits, ChunkSize next_size) {
  RequestParser parser(limits);
  Summary summary;
  std::size_t offset = 0;
  do {
    const std::size_t n = std::min(next_size(), data.size() - offset);
    parser.Feed(data.substr(offset, n));
    offset += n;
    while (parser.state() == RequestParser::State::kComplete) {
      Request request = parser.Take();
      const std::string digest = Exercise(request);
      summary.requests.push_back(Flatten(request, parser.keep_alive(), digest));
      parser.Feed("");
    }
    // Exercise the other accessors too.
    (void)parser.in_progress();
    (void)parser.expects_continue();
  } while (offset < data.size());
  summary.state = parser.state();
  summary.status = parser.error_status();
  if (summary.state == RequestParser::State::kError && parser.error_message().empty()) std::abort();
  return summary;
}

void CheckAllSplits(std::string_view data, const Limits& limits) {
  const Summary whole = Run(data, limits, [&] { return data.size(); });
  const Summary halves = Run(data, limits, [&] { return data.size() / 2 + 1; });
  static constexpr std::size_t kUneven[] = {1, 2, 3, 5, 8, 13, 21, 34};
  std::size_t i = data.empty() ? 0 : static_cast<unsigned char>(data[0]);
  const Summary uneven = Run(data, limits, [&] { return kUneven[i++ % 8]; });
  if (!(whole == halves) || !(whole == uneven)) std::abort();
  if (data.size() <= 4096) {
    const Summary bytewise = Run(data, limits, [] { return std::size_t{1}; });
    if (!(whole == bytewise)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  CheckAllSplits(bytes, Limits{});
  Limits small;
  small.max_header_bytes = 256;
  small.max_uri_bytes = 64;
  small.max_body_bytes = 128;
  CheckAllSplits(bytes, small);
  // The multipart parser on raw input as well, with boundaries from the input's start.
  const std::size_t split = size == 0 ? 0 : data[0] % 80;
  if (split < size) {
    softgrasp::http::ParseMultipart(bytes.substr(0, split), bytes.substr(split));
  }
  softgrasp::http::ParseMultipart("multipart/form-data; boundary=b", bytes);
  return 0;
}
