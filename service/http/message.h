#pragma once
/// HTTP/1.1 request and response values. Knows nothing of grasps.

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace softgrasp::http {

/// Header fields in arrival order; names compare case-insensitively.
using Headers = std::vector<std::pair<std::string, std::string>>;

/// Case-insensitive lookup of the first field with this name.
std::optional<std::string_view> FindHeader(const Headers& headers, std::string_view name);

struct Request {
  std::string method;        ///< "GET", "POST", ...
  std::string target;        ///< request-target as sent, e.g. "/v1/grasps?format=png"
  std::string path;          ///< percent-decoded path, e.g. "/v1/grasps"
  std::string query_string;  ///< raw query, without '?'
  std::vector<std::pair<std::string, std::string>> query;  ///< decoded key/value pairs, in order
  Headers headers;
  std::string body;        ///< de-chunked body
  std::string request_id;  ///< assigned by the server (or taken from X-Request-Id), echoed back
  std::map<std::string, std::string> path_params;  ///< filled by the Router from "{name}" segments

  std::optional<std::string_view> header(std::string_view name) const {
    return FindHeader(headers, name);
  }
  /// First query parameter with this key.
  std::optional<std::string> query_param(std::string_view key) const;
};

struct Response {
  int status = 200;
  Headers headers;  ///< Content-Length, Connection, Date and X-Request-Id are added by the server
  std::string body;

  Response& set_header(std::string name, std::string value);
  static Response Json(int status, std::string json_body);
  static Response Bytes(int status, std::string content_type, std::string body);
};

/// The JSON error body every 4xx/5xx uses:
/// {"error": {"code": "...", "message": "...", "field": "..."}}; "field" omitted when empty.
std::string ErrorJson(std::string_view code, std::string_view message, std::string_view field = {});
Response ErrorResponse(int status, std::string_view code, std::string_view message,
                       std::string_view field = {});

/// Standard reason phrase ("OK", "Payload Too Large", ...).
const char* ReasonPhrase(int status);

/// Percent-decoding; '+' becomes ' ' only when `plus_is_space` (query strings). Returns
/// std::nullopt for malformed escapes such as "%G1" or a trailing "%".
std::optional<std::string> PercentDecode(std::string_view in, bool plus_is_space);

/// One part of a multipart/form-data body.
struct MultipartPart {
  std::string name;          ///< from Content-Disposition
  std::string filename;      ///< from Content-Disposition, empty when absent
  std::string content_type;  ///< empty when absent
  Headers headers;
  std::string data;
};

struct MultipartResult {
  std::vector<MultipartPart> parts;
  std::string error;  ///< non-empty when the body is malformed; says what is wrong
  bool ok() const { return error.empty(); }
};

/// Parses a multipart/form-data body given the request's Content-Type header value
/// (which carries the boundary).
MultipartResult ParseMultipart(std::string_view content_type, std::string_view body);

}  // namespace softgrasp::http
