#include "service/http/message.h"

#include <algorithm>
#include <nlohmann/json.hpp>

namespace softgrasp::http {
namespace {

char ToLowerAscii(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return ToLowerAscii(x) == ToLowerAscii(y);
         });
}

std::string_view TrimOws(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

std::optional<std::string_view> FindHeader(const Headers& headers, std::string_view name) {
  for (const auto& [key, value] : headers) {
    if (EqualsIgnoreCase(key, name)) return std::string_view(value);
  }
  return std::nullopt;
}

std::optional<std::string> Request::query_param(std::string_view key) const {
  for (const auto& [k, v] : query) {
    if (k == key) return v;
  }
  return std::nullopt;
}

Response& Response::set_header(std::string name, std::string value) {
  for (auto& [key, existing] : headers) {
    if (EqualsIgnoreCase(key, name)) {
      existing = std::move(value);
      return *this;
    }
  }
  headers.emplace_back(std::move(name), std::move(value));
  return *this;
}

Response Response::Json(int status, std::string json_body) {
  return Bytes(status, "application/json", std::move(json_body));
}

Response Response::Bytes(int status, std::string content_type, std::string body) {
  Response r;
  r.status = status;
  r.headers.emplace_back("Content-Type", std::move(content_type));
  r.body = std::move(body);
  return r;
}

std::string ErrorJson(std::string_view code, std::string_view message, std::string_view field) {
  // ordered_json keeps "code", "message", "field" in this order, which reads better in logs.
  nlohmann::ordered_json inner;
  inner["code"] = std::string(code);
  inner["message"] = std::string(message);
  if (!field.empty()) inner["field"] = std::string(field);
  nlohmann::ordered_json outer;
  outer["error"] = std::move(inner);
  // Messages may quote request bytes; invalid UTF-8 is replaced rather than thrown on.
  return outer.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

Response ErrorResponse(int status, std::string_view code, std::string_view message,
                       std::string_view field) {
  return Response::Json(status, ErrorJson(code, message, field));
}

const char* ReasonPhrase(int status) {
  switch (status) {
    case 100:
      return "Continue";
    case 101:
      return "Switching Protocols";
    case 200:
      return "OK";
    case 201:
      return "Created";
    case 202:
      return "Accepted";
    case 204:
      return "No Content";
    case 206:
      return "Partial Content";
    case 301:
      return "Moved Permanently";
    case 302:
      return "Found";
    case 303:
      return "See Other";
    case 304:
      return "Not Modified";
    case 307:
      return "Temporary Redirect";
    case 308:
      return "Permanent Redirect";
    case 400:
      return "Bad Request";
    case 401:
      return "Unauthorized";
    case 403:
      return "Forbidden";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 406:
      return "Not Acceptable";
    case 408:
      return "Request Timeout";
    case 409:
      return "Conflict";
    case 410:
      return "Gone";
    case 411:
      return "Length Required";
    case 412:
      return "Precondition Failed";
    case 413:
      return "Payload Too Large";
    case 414:
      return "URI Too Long";
    case 415:
      return "Unsupported Media Type";
    case 416:
      return "Range Not Satisfiable";
    case 417:
      return "Expectation Failed";
    case 422:
      return "Unprocessable Entity";
    case 426:
      return "Upgrade Required";
    case 428:
      return "Precondition Required";
    case 429:
      return "Too Many Requests";
    case 431:
      return "Request Header Fields Too Large";
    case 500:
      return "Internal Server Error";
    case 501:
      return "Not Implemented";
    case 502:
      return "Bad Gateway";
    case 503:
      return "Service Unavailable";
    case 504:
      return "Gateway Timeout";
    case 505:
      return "HTTP Version Not Supported";
    default:
      break;
  }
  if (status >= 100 && status < 200) return "Informational";
  if (status >= 200 && status < 300) return "Success";
  if (status >= 300 && status < 400) return "Redirection";
  if (status >= 400 && status < 500) return "Client Error";
  return "Server Error";
}

std::optional<std::string> PercentDecode(std::string_view in, bool plus_is_space) {
  std::string out;
  out.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    const char c = in[i];
    if (c == '%') {
      if (in.size() - i < 3) return std::nullopt;  // "%" or "%X" at the end
      const int hi = HexValue(in[i + 1]);
      const int lo = HexValue(in[i + 2]);
      if (hi < 0 || lo < 0) return std::nullopt;
      out.push_back(static_cast<char>(hi * 16 + lo));
      i += 2;
    } else if (c == '+' && plus_is_space) {
      out.push_back(' ');
    } else {
      out.push_back(c);
    }
  }
  return out;
}

// ---- multipart/form-data (RFC 7578 over RFC 2046) ----

namespace {

struct Param {
  std::string name;  ///< lower-cased
  std::string value;
};

struct Parameterized {
  std::string_view type;  ///< e.g. "multipart/form-data" or "form-data"
  std::vector<Param> params;
};

/// Reads a quoted-string starting at s[*i] == '"'; leaves *i after the closing quote.
std::optional<std::string> ReadQuoted(std::string_view s, std::size_t* i) {
  std::string out;
  for (std::size_t j = *i + 1; j < s.size(); ++j) {
    if (s[j] == '"') {
      *i = j + 1;
      return out;
    }
    if (s[j] == '\\' && j + 1 < s.size()) ++j;  // quoted-pair
    out.push_back(s[j]);
  }
  return std::nullopt;  // unterminated
}

/// Splits `type; a=1; b="x;y"` into the type and its parameters. Parameters without '=' are
/// skipped; an unterminated quoted string or junk after one makes the whole value malformed.
std::optional<Parameterized> ParseParameterized(std::string_view s) {
  Parameterized out;
  std::size_t i = s.find(';');
  out.type = TrimOws(s.substr(0, i));
  while (i < s.size()) {
    ++i;  // past ';'
    const std::size_t eq = s.find_first_of("=;", i);
    if (eq == std::string_view::npos || s[eq] == ';') {  // bare word: ignore
      i = eq;
      continue;
    }
    std::string name(TrimOws(s.substr(i, eq - i)));
    std::transform(name.begin(), name.end(), name.begin(), ToLowerAscii);
    i = eq + 1;
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    std::string value;
    if (i < s.size() && s[i] == '"') {
      auto quoted = ReadQuoted(s, &i);
      if (!quoted) return std::nullopt;
      value = std::move(*quoted);
      while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
      if (i < s.size() && s[i] != ';') return std::nullopt;
    } else {
      const std::size_t end = std::min(s.find(';', i), s.size());
      value = std::string(TrimOws(s.substr(i, end - i)));
      i = end;
    }
    out.params.push_back({std::move(name), std::move(value)});
  }
  return out;
}

const std::string* FindParam(const Parameterized& p, std::string_view name) {
  for (const auto& param : p.params) {
    if (param.name == name) return &param.value;
  }
  return nullptr;
}

/// One boundary delimiter line found in the body.
struct Delimiter {
  std::size_t begin = 0;  ///< first byte of the delimiter (its leading CRLF, or 0 at body start)
  std::size_t end = 0;    ///< first byte after the delimiter line
  bool close = false;     ///< "--boundary--": the last one
};

/// Checks that "--boundary" at `at` is followed by "--" (close) or transport padding and CRLF.
std::optional<Delimiter> DelimiterAt(std::string_view body, std::size_t at, std::size_t dash_len,
                                     std::size_t begin) {
  std::size_t i = at + dash_len;
  if (body.substr(i, 2) == "--") return Delimiter{begin, i + 2, true};
  while (i < body.size() && (body[i] == ' ' || body[i] == '\t')) ++i;
  if (body.substr(i, 2) == "\r\n") return Delimiter{begin, i + 2, false};
  return std::nullopt;  // "--boundary" followed by other bytes is data, not a delimiter
}

/// The first delimiter at or after `from`. Only the very first one may lack the leading CRLF.
std::optional<Delimiter> FindDelimiter(std::string_view body, std::string_view dash_boundary,
                                       std::size_t from) {
  if (from == 0 && body.substr(0, dash_boundary.size()) == dash_boundary) {
    if (auto d = DelimiterAt(body, 0, dash_boundary.size(), 0)) return d;
  }
  const std::string needle = "\r\n" + std::string(dash_boundary);
  for (std::size_t p = body.find(needle, from); p != std::string_view::npos;
       p = body.find(needle, p + 1)) {
    if (auto d = DelimiterAt(body, p + 2, dash_boundary.size(), p)) return d;
  }
  return std::nullopt;
}

/// Parses the header lines of one part into `part->headers`. Returns an error message or "".
std::string ParsePartHeaders(std::string_view head, MultipartPart* part) {
  while (!head.empty()) {
    const std::size_t eol = std::min(head.find("\r\n"), head.size());
    const std::string_view line = head.substr(0, eol);
    head.remove_prefix(std::min(eol + 2, head.size()));
    if (line.front() == ' ' || line.front() == '\t')
      return "folded part header lines are not supported";
    const std::size_t colon = line.find(':');
    const bool bad_name = colon == 0 || colon == std::string_view::npos ||
                          line.substr(0, colon).find_first_of(" \t\r\n") != std::string_view::npos;
    if (bad_name || line.find_first_of("\r\n") != std::string_view::npos) {
      return "malformed part header line";
    }
    part->headers.emplace_back(std::string(line.substr(0, colon)),
                               std::string(TrimOws(line.substr(colon + 1))));
  }
  return {};
}

/// Fills one part from its bytes between two delimiters. Returns an error message or "".
std::string ParsePart(std::string_view content, MultipartPart* part) {
  std::string_view head;
  std::string_view data;
  if (content.substr(0, 2) == "\r\n") {  // no header lines at all
    data = content.substr(2);
  } else {
    const std::size_t end = content.find("\r\n\r\n");
    if (end == std::string_view::npos) return "part headers are not followed by an empty line";
    head = content.substr(0, end);
    data = content.substr(end + 4);
  }
  if (std::string error = ParsePartHeaders(head, part); !error.empty()) return error;

  const auto disposition_value = FindHeader(part->headers, "Content-Disposition");
  if (!disposition_value) return "part has no Content-Disposition header";
  const auto disposition = ParseParameterized(*disposition_value);
  if (!disposition || !EqualsIgnoreCase(disposition->type, "form-data")) {
    return "part Content-Disposition is not form-data";
  }
  const std::string* name = FindParam(*disposition, "name");
  if (name == nullptr) return "part Content-Disposition has no name";
  part->name = *name;
  if (const std::string* filename = FindParam(*disposition, "filename")) part->filename = *filename;
  if (const auto type = FindHeader(part->headers, "Content-Type")) part->content_type = *type;
  part->data = std::string(data);
  return {};
}

MultipartResult MultipartError(std::string message) {
  MultipartResult r;
  r.error = std::move(message);
  return r;
}

}  // namespace

MultipartResult ParseMultipart(std::string_view content_type, std::string_view body) {
  const auto type = ParseParameterized(content_type);
  if (!type) return MultipartError("malformed Content-Type parameters");
  if (!EqualsIgnoreCase(type->type, "multipart/form-data")) {
    return MultipartError("Content-Type is not multipart/form-data");
  }
  const std::string* boundary = FindParam(*type, "boundary");
  if (boundary == nullptr) return MultipartError("Content-Type has no boundary parameter");
  if (boundary->empty() || boundary->size() > 70 ||
      boundary->find_first_of("\r\n") != std::string::npos) {
    return MultipartError("multipart boundary must be 1 to 70 characters on one line");
  }
  const std::string dash_boundary = "--" + *boundary;

  auto delimiter = FindDelimiter(body, dash_boundary, 0);  // bytes before it are the preamble
  if (!delimiter) return MultipartError("multipart body has no opening boundary");
  MultipartResult result;
  while (!delimiter->close) {
    const std::size_t part_begin = delimiter->end;
    delimiter = FindDelimiter(body, dash_boundary, part_begin);
    if (!delimiter) return MultipartError("multipart body has no closing boundary");
    MultipartPart part;
    const std::string error =
        ParsePart(body.substr(part_begin, delimiter->begin - part_begin), &part);
    if (!error.empty()) {
      return MultipartError("part " + std::to_string(result.parts.size() + 1) + ": " + error);
    }
    result.parts.push_back(std::move(part));
  }
  return result;  // bytes after the close delimiter are the epilogue, ignored
}

}  // namespace softgrasp::http
