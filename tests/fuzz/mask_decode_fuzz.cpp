// Fuzzes the region-of-interest mask decoder (POST /v1/grasps part "segmask"). A successful
// decode must respect the pixel limit and hold only 0 and 255.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "service/io/depth_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::int64_t kMaxPixels = 1 << 16;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const auto mask = softgrasp::io::DecodeMask(bytes, kMaxPixels);
  if (!mask.ok()) return 0;
  const cv::Mat1b& m = mask.value();
  if (m.empty() || static_cast<std::int64_t>(m.total()) > kMaxPixels) std::abort();
  for (const std::uint8_t v : m) {
    if (v != 0 && v != 255) std::abort();
  }
  return 0;
}
