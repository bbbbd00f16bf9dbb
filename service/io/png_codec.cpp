// 16-bit grayscale PNG depth (counts x png_unit_m metres). The IHDR chunk is read by hand first so
// that the size and pixel format are checked before anything is decompressed; then libpng decodes
// from memory with its messages captured (nothing is printed). cv::imencode writes PNGs.
#include <png.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

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
    case 0:
      return "grayscale";
    case 2:
      return "RGB";
    case 3:
      return "palette";
    case 4:
      return "grayscale+alpha";
    case 6:
      return "RGBA";
    default:
      return "colour type " + std::to_string(color_type);
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
    return DepthError(ErrorCode::kUnsupportedFormat,
                      "PNG depth must be 16-bit single channel (got " +
                          std::to_string(header.bit_depth) + "-bit " +
                          ColorTypeName(header.color_type) + ")");
  }
  return detail::CheckImageSize(header.height, header.width, max_pixels, "PNG");
}

/// State shared with libpng's callbacks. libpng reports errors by longjmp, so it is kept plain.
struct PngSource {
  std::string_view bytes;
  std::size_t pos = 0;
  char error[160] = "";
};

void ReadFromMemory(png_structp png, png_bytep out, png_size_t count) {
  auto& source = *static_cast<PngSource*>(png_get_io_ptr(png));
  if (count > source.bytes.size() - source.pos) png_error(png, "the file is truncated");
  std::memcpy(out, source.bytes.data() + source.pos, count);
  source.pos += count;
}

[[noreturn]] void OnPngError(png_structp png, png_const_charp message) {
  auto& source = *static_cast<PngSource*>(png_get_error_ptr(png));
  std::snprintf(source.error, sizeof(source.error), "%s", message);
  png_longjmp(png, 1);
}

void OnPngWarning(png_structp, png_const_charp) {}

/// Decodes the image `header` describes into `rows` as host-order 16-bit samples; false after a
/// libpng error. libpng longjmps back to the setjmp here: nothing in this frame has a destructor.
bool ReadRows(png_structp png, png_infop info, const PngHeader& header, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_benign_errors(png, 0);  // e.g. missing image data is an error, not a warning
  png_read_info(png, info);
  if (png_get_image_width(png, info) != header.width ||
      png_get_image_height(png, info) != header.height || png_get_bit_depth(png, info) != 16 ||
      png_get_color_type(png, info) != kColorGray) {
    png_error(png, "the image header changed while decoding");
  }
  if (std::endian::native == std::endian::little) png_set_swap(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  png_read_image(png, rows);
  return true;
}

struct PngReadStruct {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngReadStruct() { png_destroy_read_struct(&png, &info, nullptr); }
};

/// The 16-bit counts of a PNG whose IHDR `header` has been checked.
core::Result<cv::Mat1w> DecodeCounts(std::string_view bytes, const PngHeader& header) {
  cv::Mat1w counts(static_cast<int>(header.height), static_cast<int>(header.width));
  std::vector<png_bytep> rows(static_cast<std::size_t>(counts.rows));
  for (int r = 0; r < counts.rows; ++r) rows[static_cast<std::size_t>(r)] = counts.ptr<png_byte>(r);

  PngSource source{bytes};
  PngReadStruct reader;
  reader.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &source, OnPngError, OnPngWarning);
  if (reader.png) reader.info = png_create_info_struct(reader.png);
  if (!reader.info) return DepthError(ErrorCode::kInternal, "cannot create a PNG reader");
  png_set_read_fn(reader.png, &source, ReadFromMemory);
  if (!ReadRows(reader.png, reader.info, header, rows.data())) {
    return DepthError(ErrorCode::kInvalidArgument,
                      "corrupt or truncated PNG: " + detail::Printable(source.error, 120));
  }
  return counts;
}

constexpr int kColorPalette = 3;
constexpr int kColorMaskAlpha = 4;  // bit of the colour type: an alpha channel follows

core::Error MaskError(core::Error error) {
  error.field = "segmask";
  error.message = "segmask: " + error.message;
  return error;
}

/// Samples per pixel after the mask transforms (palette expanded, alpha stripped).
int MaskChannels(int color_type) {
  if (color_type == kColorPalette) return 3;
  return (color_type & 2) ? 3 : 1;  // colour bit set: RGB(A); otherwise grey(+alpha)
}

/// Decodes a mask PNG into `rows` of `row_bytes` each: 8- or 16-bit samples, grey or RGB, no
/// alpha; false after a libpng error (longjmp target: nothing here has a destructor).
bool ReadMaskRows(png_structp png, png_infop info, const PngHeader& header, png_size_t row_bytes,
                  png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_benign_errors(png, 0);
  png_read_info(png, info);
  const int color_type = png_get_color_type(png, info);
  if (png_get_image_width(png, info) != header.width ||
      png_get_image_height(png, info) != header.height ||
      png_get_bit_depth(png, info) != header.bit_depth || color_type != header.color_type) {
    png_error(png, "the image header changed while decoding");
  }
  if (color_type == kColorPalette) png_set_palette_to_rgb(png);
  if (header.bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (color_type & kColorMaskAlpha) png_set_strip_alpha(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != row_bytes) png_error(png, "unexpected row size");
  png_read_image(png, rows);
  return true;
}

}  // namespace

core::Result<cv::Mat1b> DecodeMask(std::string_view bytes, std::int64_t max_pixels) {
  if (bytes.size() < kSignatureSize ||
      png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, kSignatureSize) != 0) {
    return MaskError(DepthError(ErrorCode::kUnsupportedFormat, "the mask must be a PNG"));
  }
  const auto header = ReadIhdr(bytes);
  if (!header) return MaskError(header.error());
  const PngHeader& h = header.value();
  static constexpr int kValidDepths[] = {1, 2, 4, 8, 16};
  const bool depth_ok = std::find(std::begin(kValidDepths), std::end(kValidDepths), h.bit_depth) !=
                        std::end(kValidDepths);
  if (!depth_ok || h.color_type > 6 || h.color_type == 1 || h.color_type == 5) {
    return MaskError(DepthError(ErrorCode::kInvalidArgument,
                                "corrupt PNG: bit depth " + std::to_string(h.bit_depth) + " with " +
                                    ColorTypeName(h.color_type)));
  }
  if (auto error = detail::CheckImageSize(h.height, h.width, max_pixels, "PNG")) {
    return MaskError(*error);
  }
  const int bytes_per_sample = h.bit_depth == 16 ? 2 : 1;
  const int bytes_per_pixel = MaskChannels(h.color_type) * bytes_per_sample;
  const auto row_bytes =
      static_cast<png_size_t>(h.width) * static_cast<png_size_t>(bytes_per_pixel);
  std::vector<png_byte> buffer(row_bytes * static_cast<std::size_t>(h.height));
  std::vector<png_bytep> rows(static_cast<std::size_t>(h.height));
  for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = buffer.data() + r * row_bytes;

  PngSource source{bytes};
  PngReadStruct reader;
  reader.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &source, OnPngError, OnPngWarning);
  if (reader.png) reader.info = png_create_info_struct(reader.png);
  if (!reader.info)
    return MaskError(DepthError(ErrorCode::kInternal, "cannot create a PNG reader"));
  png_set_read_fn(reader.png, &source, ReadFromMemory);
  if (!ReadMaskRows(reader.png, reader.info, h, row_bytes, rows.data())) {
    return MaskError(
        DepthError(ErrorCode::kInvalidArgument,
                   "corrupt or truncated PNG: " + detail::Printable(source.error, 120)));
  }
  cv::Mat1b mask(static_cast<int>(h.height), static_cast<int>(h.width));
  for (int v = 0; v < mask.rows; ++v) {
    const png_byte* in = rows[static_cast<std::size_t>(v)];
    std::uint8_t* out = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < mask.cols; ++u, in += bytes_per_pixel) {
      std::uint8_t any = 0;
      for (int b = 0; b < bytes_per_pixel; ++b) any |= in[b];
      out[u] = any ? 255 : 0;
    }
  }
  return mask;
}

namespace detail {

core::Result<cv::Mat1f> DecodePng16(std::string_view bytes, const DepthDecodeOptions& options) {
  if (auto error = CheckCountUnit(options.png_unit_m)) return *error;
  const auto header = ReadIhdr(bytes);
  if (!header) return header.error();
  if (auto error = CheckHeader(header.value(), options.max_pixels)) return *error;

  const auto counts = DecodeCounts(bytes, header.value());
  if (!counts) return counts.error();
  cv::Mat1f depth;
  counts.value().convertTo(depth, CV_32F, options.png_unit_m);
  return depth;
}

}  // namespace detail

std::string EncodePng(const cv::Mat& image) {
  const int type = image.type();
  if (image.empty() || (type != CV_8UC1 && type != CV_8UC3 && type != CV_16UC1)) {
    throw std::invalid_argument("EncodePng: expected a non-empty 8UC1, 8UC3 or 16UC1 image, got " +
                                cv::typeToString(type) + " of " + std::to_string(image.cols) + "x" +
                                std::to_string(image.rows));
  }
  std::vector<uchar> buffer;
  if (!cv::imencode(".png", image, buffer)) {
    throw std::runtime_error("EncodePng: cv::imencode failed");
  }
  return std::string(buffer.begin(), buffer.end());
}

}  // namespace softgrasp::io
