// 32-bit float TIFF depth in metres, read and written with libtiff over memory buffers.
// libtiff's messages are captured per handle (never printed): the first error ends up in ours.
#include <tiffio.h>

#include <algorithm>
#include <climits>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "service/io/depth_codec_internal.h"

namespace softgrasp::io {
namespace {

using core::ErrorCode;
using detail::DepthError;

/// A file in memory: reads from `input`, or writes to `output` when `writing`.
struct MemoryFile {
  std::string_view input;
  std::string output;
  bool writing = false;
  std::uint64_t pos = 0;

  std::string_view Data() const { return writing ? std::string_view(output) : input; }
};

constexpr std::uint64_t kMaxWriteSize = std::uint64_t{1} << 32;

MemoryFile& FileOf(thandle_t handle) { return *static_cast<MemoryFile*>(handle); }

tmsize_t ReadProc(thandle_t handle, void* buffer, tmsize_t size) {
  MemoryFile& file = FileOf(handle);
  const std::string_view data = file.Data();
  if (size <= 0 || file.pos >= data.size()) return 0;
  const std::size_t count =
      std::min<std::uint64_t>(static_cast<std::uint64_t>(size), data.size() - file.pos);
  std::memcpy(buffer, data.data() + file.pos, count);
  file.pos += count;
  return static_cast<tmsize_t>(count);
}

tmsize_t WriteProc(thandle_t handle, void* buffer, tmsize_t size) {
  MemoryFile& file = FileOf(handle);
  if (!file.writing || size < 0) return -1;
  const std::uint64_t end = file.pos + static_cast<std::uint64_t>(size);
  if (end > kMaxWriteSize) return -1;
  if (end > file.output.size()) file.output.resize(end);
  std::memcpy(file.output.data() + file.pos, buffer, static_cast<std::size_t>(size));
  file.pos = end;
  return size;
}

toff_t SeekProc(thandle_t handle, toff_t offset, int whence) {
  MemoryFile& file = FileOf(handle);
  std::uint64_t base = 0;
  if (whence == SEEK_CUR) base = file.pos;
  if (whence == SEEK_END) base = file.Data().size();
  if (offset > kMaxWriteSize || base + offset > kMaxWriteSize) return static_cast<toff_t>(-1);
  file.pos = base + offset;
  return file.pos;
}

int CloseProc(thandle_t) { return 0; }
toff_t SizeProc(thandle_t handle) { return FileOf(handle).Data().size(); }
int MapProc(thandle_t, void**, toff_t*) { return 0; }
void UnmapProc(thandle_t, void*, toff_t) {}

/// Keeps the first error libtiff reports for this handle; returning 1 stops the global handler.
int CaptureError(TIFF*, void* user_data, const char* module, const char* format, va_list args) {
  auto& first_error = *static_cast<std::string*>(user_data);
  if (!first_error.empty()) return 1;
  char text[256];
  std::vsnprintf(text, sizeof(text), format, args);
  first_error = detail::Printable(std::string(module ? module : "libtiff") + ": " + text, 200);
  return 1;
}

int IgnoreWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

struct TiffCloser {
  void operator()(TIFF* tif) const { TIFFClose(tif); }
};
struct OptionsFreer {
  void operator()(TIFFOpenOptions* options) const { TIFFOpenOptionsFree(options); }
};
using TiffPtr = std::unique_ptr<TIFF, TiffCloser>;

/// Opens `file` ("r" or "w"); libtiff errors go to `first_error`. max_alloc 0 = libtiff default.
TiffPtr OpenMemory(MemoryFile& file, const char* mode, std::string& first_error,
                   tmsize_t max_alloc) {
  const std::unique_ptr<TIFFOpenOptions, OptionsFreer> options(TIFFOpenOptionsAlloc());
  TIFFOpenOptionsSetErrorHandlerExtR(options.get(), CaptureError, &first_error);
  TIFFOpenOptionsSetWarningHandlerExtR(options.get(), IgnoreWarning, nullptr);
  if (max_alloc > 0) TIFFOpenOptionsSetMaxSingleMemAlloc(options.get(), max_alloc);
  // "m": never memory-map, every read goes through ReadProc.
  const std::string full_mode = std::string(mode) + "m";
  return TiffPtr(TIFFClientOpenExt("memory", full_mode.c_str(), &file, ReadProc, WriteProc,
                                   SeekProc, CloseProc, SizeProc, MapProc, UnmapProc,
                                   options.get()));
}

std::string SampleFormatName(int format) {
  switch (format) {
    case SAMPLEFORMAT_UINT:
      return "unsigned integer";
    case SAMPLEFORMAT_INT:
      return "signed integer";
    case SAMPLEFORMAT_IEEEFP:
      return "float";
    case SAMPLEFORMAT_VOID:
      return "untyped";
    default:
      return "sample format " + std::to_string(format);
  }
}

std::optional<core::Error> CheckSampleLayout(TIFF* tif) {
  std::uint16_t bits = 1, samples = 1, format = SAMPLEFORMAT_UINT;
  TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &format);
  if (bits == 32 && samples == 1 && format == SAMPLEFORMAT_IEEEFP) return std::nullopt;
  return DepthError(ErrorCode::kUnsupportedFormat,
                    "TIFF depth must be 32-bit float with one sample per pixel (got " +
                        std::to_string(bits) + "-bit " + SampleFormatName(format) + ", " +
                        std::to_string(samples) + " sample(s) per pixel)");
}

core::Error Corrupt(const std::string& what, const std::string& first_error) {
  return DepthError(ErrorCode::kInvalidArgument,
                    "corrupt or truncated TIFF: " + what +
                        (first_error.empty() ? std::string() : " (" + first_error + ")"));
}

std::optional<core::Error> ReadStrips(TIFF* tif, cv::Mat1f& image, const std::string& errors) {
  const auto height = static_cast<std::uint32_t>(image.rows);
  const tmsize_t row_bytes = static_cast<tmsize_t>(image.cols) * 4;
  if (TIFFScanlineSize(tif) != row_bytes) return Corrupt("unexpected scanline size", errors);
  std::uint32_t rows_per_strip = height;
  TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rows_per_strip);
  rows_per_strip = std::clamp<std::uint32_t>(rows_per_strip, 1, height);
  for (std::uint32_t row = 0; row < height; row += rows_per_strip) {
    const std::uint32_t rows = std::min(rows_per_strip, height - row);
    const tmsize_t wanted = row_bytes * rows;
    const tmsize_t got = TIFFReadEncodedStrip(tif, TIFFComputeStrip(tif, row, 0),
                                              image[static_cast<int>(row)], wanted);
    if (got != wanted)
      return Corrupt("cannot read the strip at row " + std::to_string(row), errors);
  }
  return std::nullopt;
}

std::optional<core::Error> ReadTiles(TIFF* tif, cv::Mat1f& image, std::int64_t max_pixels,
                                     const std::string& errors) {
  std::uint32_t tile_w = 0, tile_h = 0;
  TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tile_w);
  TIFFGetField(tif, TIFFTAG_TILELENGTH, &tile_h);
  if (auto error = detail::CheckImageSize(tile_h, tile_w, max_pixels, "TIFF tile")) return *error;
  const std::size_t tile_pixels = std::size_t{tile_w} * tile_h;
  if (TIFFTileSize(tif) != static_cast<tmsize_t>(tile_pixels * 4)) {
    return Corrupt("unexpected tile size", errors);
  }
  std::vector<float> tile(tile_pixels);
  const cv::Mat1f source(static_cast<int>(tile_h), static_cast<int>(tile_w), tile.data());
  for (std::int64_t y = 0; y < image.rows; y += tile_h) {
    for (std::int64_t x = 0; x < image.cols; x += tile_w) {
      const tmsize_t got = TIFFReadTile(tif, tile.data(), static_cast<std::uint32_t>(x),
                                        static_cast<std::uint32_t>(y), 0, 0);
      if (got != static_cast<tmsize_t>(tile_pixels * 4)) {
        return Corrupt("cannot read the tile at x=" + std::to_string(x) + " y=" + std::to_string(y),
                       errors);
      }
      const cv::Rect roi(static_cast<int>(x), static_cast<int>(y),
                         static_cast<int>(std::min<std::int64_t>(tile_w, image.cols - x)),
                         static_cast<int>(std::min<std::int64_t>(tile_h, image.rows - y)));
      source(cv::Rect(0, 0, roi.width, roi.height)).copyTo(image(roi));
    }
  }
  return std::nullopt;
}

/// libtiff may allocate one buffer of about an image's size; refuse anything much larger.
tmsize_t MaxSingleAllocation(std::int64_t max_pixels) {
  const std::int64_t pixels = std::clamp<std::int64_t>(max_pixels, 0, INT_MAX);
  return static_cast<tmsize_t>(pixels * 4 + (std::int64_t{16} << 20));
}

}  // namespace

namespace detail {

core::Result<cv::Mat1f> DecodeTiff(std::string_view bytes, std::int64_t max_pixels) {
  MemoryFile file{bytes, {}, false, 0};
  std::string errors;
  const TiffPtr tif = OpenMemory(file, "r", errors, MaxSingleAllocation(max_pixels));
  if (!tif) return Corrupt("cannot read the header or first directory", errors);

  std::uint32_t width = 0, height = 0;
  TIFFGetField(tif.get(), TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tif.get(), TIFFTAG_IMAGELENGTH, &height);
  if (auto error = CheckImageSize(height, width, max_pixels, "TIFF")) return *error;
  if (auto error = CheckSampleLayout(tif.get())) return *error;

  cv::Mat1f image(static_cast<int>(height), static_cast<int>(width));
  const auto error = TIFFIsTiled(tif.get()) ? ReadTiles(tif.get(), image, max_pixels, errors)
                                            : ReadStrips(tif.get(), image, errors);
  if (error) return *error;
  return image;
}

}  // namespace detail

std::string EncodeTiffFloat(const cv::Mat1f& image) {
  if (image.empty()) throw std::invalid_argument("EncodeTiffFloat: the image is empty");
  MemoryFile file;
  file.writing = true;
  std::string errors;
  TiffPtr tif = OpenMemory(file, "w", errors, 0);
  if (!tif) throw std::runtime_error("EncodeTiffFloat: cannot open a TIFF writer: " + errors);
  TIFF* t = tif.get();
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(image.cols));
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(image.rows));
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 32);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
  TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, TIFFDefaultStripSize(t, 0));
  std::vector<float> row(static_cast<std::size_t>(image.cols));
  for (int r = 0; r < image.rows; ++r) {
    std::copy(image[r], image[r] + image.cols, row.begin());  // libtiff wants a mutable buffer
    if (TIFFWriteScanline(t, row.data(), static_cast<std::uint32_t>(r), 0) < 0) {
      throw std::runtime_error("EncodeTiffFloat: cannot write row " + std::to_string(r) + ": " +
                               errors);
    }
  }
  if (TIFFFlush(t) != 1) throw std::runtime_error("EncodeTiffFloat: cannot finish: " + errors);
  tif.reset();
  return std::move(file.output);
}

}  // namespace softgrasp::io
