// Fuzzes the depth upload decoders and the intrinsics parser with the same bytes. Successful
// decodes must respect the pixel limit and hold only NaN or positive finite depths.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "service/io/depth_codec.h"

namespace {

constexpr std::int64_t kMaxPixels = 1 << 16;

void CheckDecoded(const softgrasp::core::DepthImage& depth) {
  if (depth.empty() || static_cast<std::int64_t>(depth.depth_m.total()) > kMaxPixels) std::abort();
  for (const float z : depth.depth_m) {
    if (!std::isnan(z) && !(std::isfinite(z) && z > 0.0f)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  softgrasp::io::DepthDecodeOptions options;
  options.max_pixels = kMaxPixels;

  const auto format = softgrasp::io::SniffDepthFormat(bytes);
  const auto depth = softgrasp::io::DecodeDepth(bytes, options);
  if (depth.ok() && !format.ok()) std::abort();  // decoded bytes of no known format
  if (depth.ok()) CheckDecoded(depth.value());

  (void)softgrasp::io::ParseIntrinsicsJson(bytes);
  return 0;
}
