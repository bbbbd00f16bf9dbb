#pragma once
/// Helpers shared by the io tests and the fuzz-corpus generator: hand-made and patched files.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tiffio.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::io::test {

/// `result` failed with `code`, field "depth" and a message containing `substring`.
inline void ExpectError(const core::Result<core::DepthImage>& result, core::ErrorCode code,
                        const std::string& substring) {
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, code) << result.error().message;
  EXPECT_THAT(result.error().message, ::testing::HasSubstr(substring));
  EXPECT_EQ(result.error().field, "depth");
}

inline std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << path;
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline std::string LittleEndian(std::uint32_t value, int size) {
  std::string out;
  for (int i = 0; i < size; ++i) out += static_cast<char>((value >> (8 * i)) & 0xffu);
  return out;
}

/// An .npy file with the given dict text (a '\n' is appended) and raw data.
inline std::string MakeNpy(const std::string& dict, const std::string& data, int major = 1) {
  std::string out("\x93NUMPY", 6);
  out += static_cast<char>(major);
  out += '\0';
  out += LittleEndian(static_cast<std::uint32_t>(dict.size() + 1), major == 1 ? 2 : 4);
  return out + dict + "\n" + data;
}

inline std::string NpyDict(const std::string& descr, const std::string& shape,
                           bool fortran = false) {
  return "{'descr': '" + descr + "', 'fortran_order': " + (fortran ? "True" : "False") +
         ", 'shape': " + shape + ", }";
}

/// Raw float32 bytes of `values` (row-major), little- or big-endian.
inline std::string FloatBytes(const cv::Mat1f& values, bool big_endian = false) {
  std::string out;
  for (const float v : values) {
    std::string bytes = LittleEndian(std::bit_cast<std::uint32_t>(v), 4);
    if (big_endian) bytes = std::string(bytes.rbegin(), bytes.rend());
    out += bytes;
  }
  return out;
}

/// Little- or big-endian bytes of each value as T (e.g. double, std::uint16_t).
template <typename T>
std::string ElementBytes(const std::vector<T>& values, bool big_endian = false) {
  std::string out;
  for (const T v : values) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &v, sizeof(T));
    if (big_endian != (std::endian::native == std::endian::big)) {
      std::reverse(bytes, bytes + sizeof(T));
    }
    out.append(bytes, sizeof(T));
  }
  return out;
}

inline std::string EncodeWithOpenCv(const std::string& extension, const cv::Mat& image) {
  std::vector<uchar> buffer;
  EXPECT_TRUE(cv::imencode(extension, image, buffer));
  return {buffer.begin(), buffer.end()};
}

inline void PutBigEndian32(std::string& bytes, std::size_t offset, std::uint32_t value) {
  for (std::size_t i = 0; i < 4; ++i) bytes[offset + i] = static_cast<char>(value >> (24 - 8 * i));
}

/// Sets a PNG's IHDR width and height (without fixing the CRC: decoders must refuse it earlier).
inline void PatchPngSize(std::string& png, std::uint32_t width, std::uint32_t height) {
  PutBigEndian32(png, 16, width);
  PutBigEndian32(png, 20, height);
}

inline std::uint32_t LittleEndianAt(const std::string& bytes, std::size_t offset, int size) {
  std::uint32_t value = 0;
  for (int i = size - 1; i >= 0; --i) {
    value = (value << 8) | static_cast<unsigned char>(bytes[offset + static_cast<std::size_t>(i)]);
  }
  return value;
}

inline void PutLittleEndian(std::string& bytes, std::size_t offset, std::uint32_t value, int size) {
  const std::string encoded = LittleEndian(value, size);
  bytes.replace(offset, encoded.size(), encoded);
}

/// Rewrites entry `tag` of a little-endian TIFF's first directory as the LONG `value`.
inline void PatchTiffTag(std::string& tiff, std::uint16_t tag, std::uint32_t value) {
  ASSERT_EQ(tiff.substr(0, 4), std::string("II*\0", 4));
  const std::uint32_t ifd = LittleEndianAt(tiff, 4, 4);
  const std::uint32_t entries = LittleEndianAt(tiff, ifd, 2);
  for (std::uint32_t i = 0; i < entries; ++i) {
    const std::size_t entry = ifd + 2 + 12 * i;
    if (LittleEndianAt(tiff, entry, 2) != tag) continue;
    PutLittleEndian(tiff, entry + 2, TIFF_LONG, 2);
    PutLittleEndian(tiff, entry + 4, 1, 4);
    PutLittleEndian(tiff, entry + 8, value, 4);
    return;
  }
  FAIL() << "tag " << tag << " not found";
}

/// A float TIFF written by libtiff itself ("wb" big-endian, "wl" little), optionally tiled 16x16.
inline std::string WriteTiffWithLibtiff(const cv::Mat1f& image, const char* mode, bool tiled,
                                        std::uint16_t compression) {
  const softgrasp::testing::TempDir temp("io-test");
  const auto path = temp / "libtiff.tiff";
  TIFF* tif = TIFFOpen(path.c_str(), mode);
  EXPECT_NE(tif, nullptr);
  if (!tif) return {};
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(image.cols));
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(image.rows));
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 32);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tif, TIFFTAG_COMPRESSION, compression);
  if (tiled) {
    constexpr int kTile = 16;
    TIFFSetField(tif, TIFFTAG_TILEWIDTH, std::uint32_t{kTile});
    TIFFSetField(tif, TIFFTAG_TILELENGTH, std::uint32_t{kTile});
    cv::Mat1f padded;
    cv::copyMakeBorder(image, padded, 0, kTile, 0, kTile, cv::BORDER_CONSTANT, 0);
    cv::Mat1f tile(kTile, kTile);
    for (int y = 0; y < image.rows; y += kTile) {
      for (int x = 0; x < image.cols; x += kTile) {
        padded(cv::Rect(x, y, kTile, kTile)).copyTo(tile);
        EXPECT_GT(TIFFWriteTile(tif, tile.ptr(), static_cast<std::uint32_t>(x),
                                static_cast<std::uint32_t>(y), 0, 0),
                  0);
      }
    }
  } else {
    TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, std::uint32_t{3});
    cv::Mat1f copy = image.clone();
    for (int r = 0; r < copy.rows; ++r) {
      EXPECT_EQ(TIFFWriteScanline(tif, copy[r], static_cast<std::uint32_t>(r), 0), 1);
    }
  }
  TIFFClose(tif);
  return ReadFile(path);
}

/// Depth rising along the rows from 0.5 m, with a 0 (missing) top-left and a NaN bottom-right.
inline cv::Mat1f TestDepth(int rows, int cols) {
  cv::Mat1f image(rows, cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) image(r, c) = 0.5f + 0.001f * static_cast<float>(r * cols + c);
  }
  image(0, 0) = 0.0f;
  image(rows - 1, cols - 1) = std::numeric_limits<float>::quiet_NaN();
  return image;
}

/// 16-bit counts with one 0 (missing) and one 65535.
inline cv::Mat1w TestCounts(int rows = 9, int cols = 13) {
  cv::Mat1w counts(rows, cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) counts(r, c) = static_cast<std::uint16_t>(500 + 37 * r + c);
  }
  counts(2, 3) = 0;
  counts(rows - 1, cols - 1) = 65535;
  return counts;
}

}  // namespace softgrasp::io::test
