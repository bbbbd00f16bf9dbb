// 16-bit grayscale PNG depth (counts x png_unit_m metres). The IHDR chunk is read by hand first so
// that the size and pixel format are checked before anything is decompressed.
#include <climits>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "service/io/depth_codec.h"
#include "service/io/depth_codec_internal.h"

namespace softgrasp::io {
namespace {

using core::ErrorCode;
using detail::DepthError;

struct PngHeader {
  std::int64_t width = 0;
  std::int64_t height = 0;
  int bit_depth = 0;
  int color_type = 0;
};

constexpr std::size_t kSignatureSize = 8;
constexpr std::size_t kIhdrDataSize = 13;
constexpr int kColorGray = 0;

std::uint32_t ReadBigEndian32(std::string_view bytes, std::size_t offset) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    value = (value << 8) | static_cast<unsigned char>(bytes[offset + i]);
  }
  return value;
}

std::string ColorTypeName(int color_type) {
  switch (color_type) {
    case 0: return "grayscale";
    case 2: return "RGB";
    case 3: return "palette";
    case 4: return "grayscale+alpha";
    case 6: return "RGBA";
    default: return "colour type " + std::to_string(color_type);
  }
}

/// Signature, then the IHDR chunk: length 13, "IHDR", width, height, bit depth, colour type, ...
core::Result<PngHeader> ReadIhdr(std::string_view bytes) {
  constexpr std::size_t kChunkData = kSignatureSize + 8;
  if (bytes.size() < kChunkData + kIhdrDataSize) {
    return DepthError(ErrorCode::kInvalidArgument, "PNG file is truncated inside its IHDR chunk");
  }
  if (ReadBigEndian32(bytes, kSignatureSize) != kIhdrDataSize ||
      bytes.substr(kSignatureSize + 4, 4) != "IHDR") {
    return DepthError(ErrorCode::kInvalidArgument,
                      "corrupt PNG: the first chunk is not a 13-byte IHDR");
  }
  PngHeader header;
  header.width = ReadBigEndian32(bytes, kChunkData);
  header.height = ReadBigEndian32(bytes, kChunkData + 4);
  header.bit_depth = static_cast<unsigned char>(bytes[kChunkData + 8]);
  header.color_type = static_cast<unsigned char>(bytes[kChunkData + 9]);
  return header;
}

std::optional<core::Error> CheckHeader(const PngHeader& header, std::int64_t max_pixels) {
  if (header.bit_depth != 16 || header.color_type != kColorGray) {
    return DepthError(ErrorCode::kUnsupportedMediaType,
                      "PNG depth must be 16-bit single channel (got " +
                          std::to_string(header.bit_depth) + "-bit " +
                          ColorTypeName(header.color_type) + ")");
  }
  return detail::CheckImageSize(header.height, header.width, max_pixels, "PNG");
}

core::Result<cv::Mat> DecodeWithOpenCv(std::string_view bytes) {
  if (bytes.size() > static_cast<std::size_t>(INT_MAX)) {
    return DepthError(ErrorCode::kPayloadTooLarge, "PNG file is larger than 2 GiB");
  }
  // imdecode only reads from the buffer; the const_cast is for cv::Mat's constructor.
  const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1,
                        const_cast<char*>(bytes.data()));  // NOLINT(cppcoreguidelines-pro-type-const-cast)
  try {
    cv::Mat decoded = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
    if (!decoded.empty()) return decoded;
  } catch (const cv::Exception& e) {
    return DepthError(ErrorCode::kInvalidArgument, std::string("corrupt PNG: ") + e.what());
  }
  return DepthError(ErrorCode::kInvalidArgument, "corrupt or truncated PNG data");
}

}  // namespace

namespace detail {

core::Result<cv::Mat1f> DecodePng16(std::string_view bytes, const DepthDecodeOptions& options) {
  if (!(std::isfinite(options.png_unit_m) && options.png_unit_m > 0)) {
    return core::MakeError(ErrorCode::kInvalidArgument,
                           "png_unit_m must be a positive number of metres per PNG count",
                           "png_unit_m");
  }
  const auto header = ReadIhdr(bytes);
  if (!header) return header.error();
  if (auto error = CheckHeader(header.value(), options.max_pixels)) return *error;

  const auto decoded = DecodeWithOpenCv(bytes);
  if (!decoded) return decoded.error();
  const cv::Mat& counts = decoded.value();
  if (counts.type() != CV_16UC1 || counts.cols != header.value().width ||
      counts.rows != header.value().height) {
    return DepthError(ErrorCode::kInvalidArgument,
                      "corrupt PNG: decoded pixels do not match the IHDR chunk");
  }
  cv::Mat1f depth;
  counts.convertTo(depth, CV_32F, options.png_unit_m);
  return depth;
}

}  // namespace detail

std::string EncodePng(const cv::Mat& image) {
  const int type = image.type();
  if (image.empty() || (type != CV_8UC1 && type != CV_8UC3 && type != CV_16UC1)) {
    throw std::invalid_argument("EncodePng: expected a non-empty 8UC1, 8UC3 or 16UC1 image, got " +
                                cv::typeToString(type) + " of " + std::to_string(image.cols) +
                                "x" + std::to_string(image.rows));
  }
  std::vector<uchar> buffer;
  if (!cv::imencode(".png", image, buffer)) {
    throw std::runtime_error("EncodePng: cv::imencode failed");
  }
  return std::string(buffer.begin(), buffer.end());
}

}  // namespace softgrasp::io
