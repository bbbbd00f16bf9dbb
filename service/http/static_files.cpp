#include "service/http/static_files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <climits>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <utility>

namespace softgrasp::http {
namespace {

constexpr const char* kImmutableCache = "public, max-age=31536000, immutable";
constexpr const char* kRevalidateCache = "no-cache";

struct ContentType {
  std::string_view extension;
  std::string_view type;
};

// What a browser needs to load the page; anything else is served as opaque bytes.
constexpr std::array<ContentType, 19> kContentTypes{{
    {"html", "text/html; charset=utf-8"},
    {"htm", "text/html; charset=utf-8"},
    {"js", "text/javascript; charset=utf-8"},
    {"mjs", "text/javascript; charset=utf-8"},
    {"css", "text/css; charset=utf-8"},
    {"json", "application/json"},
    {"map", "application/json"},
    {"txt", "text/plain; charset=utf-8"},
    {"svg", "image/svg+xml"},
    {"png", "image/png"},
    {"jpg", "image/jpeg"},
    {"jpeg", "image/jpeg"},
    {"gif", "image/gif"},
    {"webp", "image/webp"},
    {"ico", "image/x-icon"},
    {"woff", "font/woff"},
    {"woff2", "font/woff2"},
    {"wasm", "application/wasm"},
    {"webmanifest", "application/manifest+json"},
}};

std::string LowerAscii(std::string_view s) {
  std::string out(s);
  for (char& c : out) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return out;
}

std::string_view TrimOws(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

/// Weak comparison (RFC 9110 8.8.3.2): W/"x" matches "x".
std::string_view OpaqueTag(std::string_view tag) {
  if (tag.substr(0, 2) == "W/") tag.remove_prefix(2);
  return tag;
}

struct FreeDeleter {
  void operator()(char* p) const { std::free(p); }
};

/// The canonical absolute path (symlinks resolved), or nullopt when it does not exist.
std::optional<std::string> RealPath(const std::string& path) {
  std::unique_ptr<char, FreeDeleter> resolved(::realpath(path.c_str(), nullptr));
  if (!resolved) return std::nullopt;
  return std::string(resolved.get());
}

struct FileDescriptor {
  int fd = -1;
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
};

enum class ReadOutcome { kOk, kNotAFile, kTooLarge, kFailed };

/// Reads a regular file whole. O_NONBLOCK so that a FIFO cannot stall a worker in open().
ReadOutcome ReadRegularFile(const std::string& path, std::size_t max_bytes, std::string* out) {
  FileDescriptor file;
  file.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (file.fd < 0) return ReadOutcome::kNotAFile;
  struct stat info {};
  if (::fstat(file.fd, &info) != 0 || !S_ISREG(info.st_mode)) return ReadOutcome::kNotAFile;
  if (static_cast<std::uintmax_t>(info.st_size) > max_bytes) return ReadOutcome::kTooLarge;
  out->resize(static_cast<std::size_t>(info.st_size));
  std::size_t done = 0;
  while (done < out->size()) {
    const ssize_t n = ::read(file.fd, out->data() + done, out->size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return ReadOutcome::kFailed;
    if (n == 0) break;  // the file shrank while we read it: serve what is there
    done += static_cast<std::size_t>(n);
  }
  out->resize(done);
  return ReadOutcome::kOk;
}

Response NotFound(const Request& request) {
  return ErrorResponse(404, "not_found", "no resource at " + request.path);
}

}  // namespace

StaticFiles::StaticFiles(StaticFilesOptions options) : options_(std::move(options)) {}

Response StaticFiles::Serve(const Request& request,
                            const std::vector<std::string>& segments) const {
  if (request.method != "GET" && request.method != "HEAD") {
    Response response = ErrorResponse(405, "method_not_allowed",
                                      "method " + request.method + " is not allowed for " +
                                          request.path + "; allowed: GET, HEAD");
    response.set_header("Allow", "GET, HEAD");
    return response;
  }
  if (segments.empty() || options_.root.empty()) return NotFound(request);
  std::string relative;
  for (const std::string& segment : segments) {
    if (!IsSafePathSegment(segment)) return NotFound(request);
    relative += (relative.empty() ? "" : "/") + segment;
  }
  // Resolve both sides so that symlinks are followed before the containment check: a link inside
  // the root that points outside it is refused like "..".
  const auto root = RealPath(options_.root);
  if (!root) return NotFound(request);
  const auto file = RealPath(*root + "/" + relative);
  if (!file || file->size() <= root->size() + 1 || file->compare(0, root->size(), *root) != 0 ||
      (*root != "/" && (*file)[root->size()] != '/')) {
    return NotFound(request);
  }

  std::string bytes;
  switch (ReadRegularFile(*file, options_.max_file_bytes, &bytes)) {
    case ReadOutcome::kOk:
      break;
    case ReadOutcome::kNotAFile:
      return NotFound(request);
    case ReadOutcome::kTooLarge:
      return ErrorResponse(500, "internal",
                           "the file at " + request.path + " is too large to serve");
    case ReadOutcome::kFailed:
      return ErrorResponse(500, "internal", "could not read the file at " + request.path);
  }

  const bool immutable = !options_.immutable_dir.empty() && segments.size() > 1 &&
                         segments.front() == options_.immutable_dir;
  const std::string etag = EntityTagFor(bytes);
  Response response;
  response.set_header("ETag", etag);
  response.set_header("Cache-Control", immutable ? kImmutableCache : kRevalidateCache);
  if (const auto condition = request.header("If-None-Match");
      condition && IfNoneMatchHits(*condition, etag)) {
    response.status = 304;
    return response;
  }
  response.status = 200;
  response.set_header("Content-Type", ContentTypeForFile(segments.back()));
  response.set_header("X-Content-Type-Options", "nosniff");
  response.body = std::move(bytes);
  return response;
}

std::string ContentTypeForFile(std::string_view file_name) {
  const std::size_t dot = file_name.rfind('.');
  if (dot == std::string_view::npos || dot == 0) return "application/octet-stream";
  const std::string extension = LowerAscii(file_name.substr(dot + 1));
  for (const ContentType& entry : kContentTypes) {
    if (entry.extension == extension) return std::string(entry.type);
  }
  return "application/octet-stream";
}

std::string EntityTagFor(std::string_view bytes) {
  std::uint64_t hash = 14695981039346656037ULL;  // FNV-1a 64
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ULL;
  }
  char text[48];
  std::snprintf(text, sizeof text, "\"%016llx-%zx\"", static_cast<unsigned long long>(hash),
                bytes.size());
  return text;
}

bool IfNoneMatchHits(std::string_view if_none_match, std::string_view etag) {
  if (TrimOws(if_none_match) == "*") return true;
  while (!if_none_match.empty()) {
    const std::size_t comma = if_none_match.find(',');
    const std::string_view candidate = TrimOws(if_none_match.substr(0, comma));
    if (!candidate.empty() && OpaqueTag(candidate) == OpaqueTag(etag)) return true;
    if (comma == std::string_view::npos) break;
    if_none_match.remove_prefix(comma + 1);
  }
  return false;
}

bool IsSafePathSegment(std::string_view segment) {
  if (segment.empty() || segment.front() == '.') return false;  // ".", "..", hidden files
  for (const char c : segment) {
    if (c == '/' || c == '\\' || c == '\0') return false;
  }
  return true;
}

}  // namespace softgrasp::http
