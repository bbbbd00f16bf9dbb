// Format sniffing and dispatch for depth uploads, plus the helpers the format decoders share.
#include "service/io/depth_codec.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>
#include <vector>

#include "service/io/depth_codec_internal.h"

namespace softgrasp::io {
namespace detail {

core::Error DepthError(core::ErrorCode code, std::string message) {
  return core::MakeError(code, std::move(message), "depth");
}

std::optional<core::Error> CheckCountUnit(double png_unit_m) {
  if (std::isfinite(png_unit_m) && png_unit_m > 0) return std::nullopt;
  return core::MakeError(core::ErrorCode::kInvalidArgument,
                         "png_unit_m must be a positive number of metres per count", "png_unit_m");
}

std::optional<core::Error> CheckImageSize(std::int64_t height, std::int64_t width,
                                          std::int64_t max_pixels, std::string_view what) {
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if (height <= 0 || width <= 0) {
    return DepthError(core::ErrorCode::kInvalidArgument,
                      std::string(what) + " image is empty (" + size + " pixels)");
  }
  constexpr std::int64_t kMaxSide = std::numeric_limits<int>::max();
  // height * width <= max_pixels  <=>  height <= max_pixels / width (no overflow).
  if (height > kMaxSide || width > kMaxSide || height > max_pixels / width) {
    return DepthError(core::ErrorCode::kTooLarge, std::string(what) + " image of " + size +
                                                      " pixels exceeds the limit of " +
                                                      std::to_string(max_pixels) + " pixels");
  }
  return std::nullopt;
}

std::string Printable(std::string_view text, std::size_t max_chars) {
  std::string out;
  for (const char c : text.substr(0, max_chars)) {
    const bool printable = c >= 0x20 && c < 0x7f;
    out += printable ? c : '?';
  }
  if (text.size() > max_chars) out += "...";
  return out;
}

}  // namespace detail

namespace {

bool StartsWith(std::string_view bytes, std::string_view magic) {
  return bytes.substr(0, magic.size()) == magic;
}

/// 0, negative, NaN and infinite values are missing measurements: NaN.
void MarkMissing(cv::Mat1f& depth) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  depth.forEach([](float& z, const int*) {
    if (!(std::isfinite(z) && z > 0.0f)) z = kNaN;
  });
}

// A depth image whose median reading lies farther than this is in the wrong unit (millimetres
// read as metres): no scene this service plans for is 100 m from the camera.
constexpr double kMaxMedianDepthM = 100.0;
constexpr int kMedianSamples = 10000;  // pixels sampled (evenly strided) for the median

/// The median of the valid (finite, positive) depths among about kMedianSamples pixels; NaN when
/// none is valid.
double SampledMedianDepth(const cv::Mat1f& depth) {
  const std::size_t total = depth.total();
  const std::size_t stride = std::max<std::size_t>(1, total / kMedianSamples);
  std::vector<float> valid;
  valid.reserve(total / stride + 1);
  const cv::Mat1f continuous = depth.isContinuous() ? depth : depth.clone();
  const float* z = continuous[0];
  for (std::size_t i = 0; i < total; i += stride) {
    if (std::isfinite(z[i]) && z[i] > 0.0f) valid.push_back(z[i]);
  }
  if (valid.empty()) return std::numeric_limits<double>::quiet_NaN();
  auto middle = valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2);
  std::nth_element(valid.begin(), middle, valid.end());
  return *middle;
}

}  // namespace

const char* DepthFormatName(DepthFormat format) {
  switch (format) {
    case DepthFormat::kNpy:
      return "npy";
    case DepthFormat::kPng16:
      return "png16";
    case DepthFormat::kTiff:
      return "tiff";
  }
  return "unknown";
}

core::Result<DepthFormat> SniffDepthFormat(std::string_view bytes) {
  using namespace std::string_view_literals;
  if (StartsWith(bytes, "\x93NUMPY"sv)) return DepthFormat::kNpy;
  if (StartsWith(bytes, "\x89PNG\r\n\x1a\n"sv)) return DepthFormat::kPng16;
  // Classic TIFF ("II*\0", "MM\0*") and BigTIFF ("II+\0", "MM\0+"), both read by libtiff.
  for (const auto magic : {"II*\0"sv, "MM\0*"sv, "II+\0"sv, "MM\0+"sv}) {
    if (StartsWith(bytes, magic)) return DepthFormat::kTiff;
  }
  if (bytes.empty()) {
    return detail::DepthError(core::ErrorCode::kUnsupportedFormat, "the depth upload is empty");
  }
  return detail::DepthError(
      core::ErrorCode::kUnsupportedFormat,
      "unrecognised depth format: expected .npy (float32, float64 or uint16), 16-bit PNG or "
      "32-bit float TIFF");
}

core::Result<core::DepthImage> DecodeDepth(std::string_view bytes,
                                           const DepthDecodeOptions& options) {
  auto format = SniffDepthFormat(bytes);
  if (!format) return format.error();
  core::Result<cv::Mat1f> image = cv::Mat1f();
  switch (format.value()) {
    case DepthFormat::kNpy:
      image = detail::DecodeNpy(bytes, options);
      break;
    case DepthFormat::kPng16:
      image = detail::DecodePng16(bytes, options);
      break;
    case DepthFormat::kTiff:
      image = detail::DecodeTiff(bytes, options.max_pixels);
      break;
  }
  if (!image) return image.error();
  core::DepthImage depth{std::move(image).value()};
  MarkMissing(depth.depth_m);
  if (const double median = SampledMedianDepth(depth.depth_m); median > kMaxMedianDepthM) {
    char value[32];
    std::snprintf(value, sizeof(value), "%.4g", median);
    return detail::DepthError(
        core::ErrorCode::kInvalidArgument,
        std::string("the depth's median reading is ") + value +
            " m: send metres (float NPY or TIFF) or counts of png_unit_m (16-bit PNG, uint16 "
            "NPY; millimetres by default); millimetres in a float file must be divided by 1000");
  }
  return depth;
}

}  // namespace softgrasp::io
