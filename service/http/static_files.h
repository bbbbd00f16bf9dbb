#pragma once
/// Files from one folder over HTTP (the built web page): content types, ETags, Cache-Control,
/// If-None-Match -> 304, HEAD. Only regular files strictly inside the folder are served: no
/// directory listing, no "..", no hidden files, no symlinks that lead out. Knows nothing of grasps.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "service/http/message.h"

namespace softgrasp::http {

struct StaticFilesOptions {
  std::string root;  ///< the folder served; it may appear or be rebuilt while the server runs
  /// Files under this relative folder carry a content hash in their names (the web build makes
  /// sure of it), so they are cached for a year as immutable. Everything else is "no-cache":
  /// browsers revalidate it with If-None-Match every time.
  std::string immutable_dir = "assets";
  std::size_t max_file_bytes = std::size_t{64} << 20;  ///< larger files answer 500, not OOM
};

class StaticFiles {
 public:
  explicit StaticFiles(StaticFilesOptions options);

  /// Answers GET/HEAD for root/segments[0]/.../segments[n-1]. `segments` are decoded path
  /// segments, e.g. {"assets", "app-3KX7Q2ZB.js"}. 404 JSON error for anything that is not a
  /// regular file inside the root; 405 for other methods.
  Response Serve(const Request& request, const std::vector<std::string>& segments) const;

  const StaticFilesOptions& options() const { return options_; }

 private:
  StaticFilesOptions options_;
};

/// "text/html; charset=utf-8", "text/javascript; charset=utf-8", ...; by extension, case
/// insensitive; "application/octet-stream" when unknown.
std::string ContentTypeForFile(std::string_view file_name);

/// A strong entity tag for these bytes: "\"<16 hex digits of FNV-1a 64>-<size in hex>\"".
std::string EntityTagFor(std::string_view bytes);

/// Whether an If-None-Match header value matches `etag` ("*", or a list; weak comparison).
bool IfNoneMatchHits(std::string_view if_none_match, std::string_view etag);

/// Whether a decoded path segment may name something to serve: not empty, not "." or "..",
/// not hidden (leading '.'), and free of '/', '\\' and NUL.
bool IsSafePathSegment(std::string_view segment);

}  // namespace softgrasp::http
