// 16-bit PNG and float TIFF decoding and encoding, format sniffing, broken and hostile files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "service/io/depth_codec.h"
#include "tests/io/io_test_util.h"

namespace softgrasp::io {
namespace {

using core::ErrorCode;
using test::EncodeWithOpenCv;
using test::ExpectError;
using test::PatchPngSize;
using test::PatchTiffTag;
using test::TestCounts;
using test::TestDepth;
using test::WriteTiffWithLibtiff;

void ExpectSameDepth(const core::Result<core::DepthImage>& result, const cv::Mat1f& expected) {
  ASSERT_TRUE(result.ok()) << result.error().message;
  const cv::Mat1f& d = result.value().depth_m;
  ASSERT_EQ(d.size(), expected.size());
  for (int r = 0; r < d.rows; ++r) {
    for (int c = 0; c < d.cols; ++c) {
      const float z = expected(r, c);
      if (std::isfinite(z) && z > 0) {
        EXPECT_FLOAT_EQ(d(r, c), z) << r << "," << c;
      } else {
        EXPECT_TRUE(std::isnan(d(r, c))) << r << "," << c;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------- sniff

TEST(SniffTest, RecognisesMagicBytes) {
  using namespace std::string_literals;
  EXPECT_EQ(SniffDepthFormat("\x93NUMPY\x01\x00"s).value(), DepthFormat::kNpy);
  EXPECT_EQ(SniffDepthFormat("\x89PNG\r\n\x1a\n...."s).value(), DepthFormat::kPng16);
  EXPECT_EQ(SniffDepthFormat("II*\0...."s).value(), DepthFormat::kTiff);
  EXPECT_EQ(SniffDepthFormat("MM\0*...."s).value(), DepthFormat::kTiff);
  EXPECT_STREQ(DepthFormatName(DepthFormat::kNpy), "npy");
  EXPECT_STREQ(DepthFormatName(DepthFormat::kPng16), "png16");
  EXPECT_STREQ(DepthFormatName(DepthFormat::kTiff), "tiff");
}

TEST(SniffTest, RejectsGarbageAndEmptyInput) {
  for (const std::string bytes : {"GIF89a garbage", "\x93NUMP", "", "\xff\xd8\xff\xe0 jpeg"}) {
    const auto format = SniffDepthFormat(bytes);
    ASSERT_FALSE(format.ok());
    EXPECT_EQ(format.error().code, ErrorCode::kUnsupportedFormat);
    EXPECT_EQ(format.error().field, "depth");
    ExpectError(DecodeDepth(bytes), ErrorCode::kUnsupportedFormat, "depth");
  }
  ExpectError(DecodeDepth("P5 1 1 255 garbage"), ErrorCode::kUnsupportedFormat,
              "unrecognised depth format");
}

// ------------------------------------------------------------------------------------------ PNG

TEST(PngTest, RoundTripScalesCountsAndMarksZeroMissing) {
  const cv::Mat1w counts = TestCounts();
  for (const double unit : {0.001, 0.0001}) {
    DepthDecodeOptions options;
    options.png_unit_m = unit;
    const auto result = DecodeDepth(EncodePng(counts), options);
    ASSERT_TRUE(result.ok()) << result.error().message;
    const cv::Mat1f& d = result.value().depth_m;
    ASSERT_EQ(d.size(), counts.size());
    for (int r = 0; r < d.rows; ++r) {
      for (int c = 0; c < d.cols; ++c) {
        if (counts(r, c) == 0) {
          EXPECT_TRUE(std::isnan(d(r, c)));
        } else {
          EXPECT_FLOAT_EQ(d(r, c), static_cast<float>(counts(r, c) * unit));
        }
      }
    }
  }
}

TEST(PngTest, Rejects8BitPng) {
  ExpectError(DecodeDepth(EncodePng(cv::Mat1b(4, 4, 7))), ErrorCode::kUnsupportedFormat,
              "PNG depth must be 16-bit single channel (got 8-bit grayscale)");
  ExpectError(DecodeDepth(EncodePng(cv::Mat3b(4, 4, cv::Vec3b(1, 2, 3)))),
              ErrorCode::kUnsupportedFormat, "(got 8-bit RGB)");
}

TEST(PngTest, Rejects16BitRgbPng) {
  const cv::Mat rgb(4, 4, CV_16UC3, cv::Scalar(1000, 2000, 3000));
  ExpectError(DecodeDepth(EncodeWithOpenCv(".png", rgb)), ErrorCode::kUnsupportedFormat,
              "(got 16-bit RGB)");
}

TEST(PngTest, RefusesDeclaredHugeImageBeforeDecoding) {
  std::string png = EncodePng(TestCounts());
  PatchPngSize(png, 100000, 100000);
  ExpectError(DecodeDepth(png), ErrorCode::kTooLarge, "exceeds the limit");
  DepthDecodeOptions small;
  small.max_pixels = 100;
  ExpectError(DecodeDepth(EncodePng(TestCounts()), small), ErrorCode::kTooLarge,
              "limit of 100 pixels");
}

TEST(PngTest, RejectsZeroSize) {
  std::string png = EncodePng(TestCounts());
  PatchPngSize(png, 0, 13);
  ExpectError(DecodeDepth(png), ErrorCode::kInvalidArgument, "empty");
}

TEST(PngTest, RejectsTruncatedFiles) {
  const std::string png = EncodePng(TestCounts());
  ExpectError(DecodeDepth(png.substr(0, 20)), ErrorCode::kInvalidArgument, "IHDR");
  ExpectError(DecodeDepth(png.substr(0, png.size() / 2)), ErrorCode::kInvalidArgument, "PNG");
  std::string no_ihdr = png;
  no_ihdr[12] = 'X';
  ExpectError(DecodeDepth(no_ihdr), ErrorCode::kInvalidArgument, "IHDR");
}

TEST(PngTest, RejectsCorruptImageDataWithLibpngsReason) {
  std::string png = EncodePng(TestCounts());
  const std::size_t idat = png.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  png[idat + 6] = static_cast<char>(png[idat + 6] ^ 0x5a);
  ExpectError(DecodeDepth(png), ErrorCode::kInvalidArgument, "corrupt or truncated PNG: IDAT");
}

TEST(PngTest, RejectsBadUnit) {
  DepthDecodeOptions options;
  options.png_unit_m = 0;
  const auto result = DecodeDepth(EncodePng(TestCounts()), options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(result.error().field, "png_unit_m");
}

TEST(PngTest, EncoderRefusesOtherTypes) {
  EXPECT_THROW(EncodePng(cv::Mat1f(2, 2, 1.0f)), std::invalid_argument);
  EXPECT_THROW(EncodePng(cv::Mat()), std::invalid_argument);
  EXPECT_NO_THROW(EncodePng(cv::Mat3b(2, 2)));
}

// ----------------------------------------------------------------------------------------- TIFF

TEST(TiffTest, RoundTripKeepsValuesAndMarksMissing) {
  const cv::Mat1f image = TestDepth(11, 17);
  ExpectSameDepth(DecodeDepth(EncodeTiffFloat(image)), image);
}

TEST(TiffTest, DecodesBigEndianTiledAndCompressedFiles) {
  const cv::Mat1f image = TestDepth(37, 21);
  ExpectSameDepth(DecodeDepth(WriteTiffWithLibtiff(image, "wb", false, COMPRESSION_NONE)), image);
  ExpectSameDepth(DecodeDepth(WriteTiffWithLibtiff(image, "wl", true, COMPRESSION_NONE)), image);
  ExpectSameDepth(DecodeDepth(WriteTiffWithLibtiff(image, "wb", true, COMPRESSION_LZW)), image);
  ExpectSameDepth(DecodeDepth(WriteTiffWithLibtiff(image, "wl", false, COMPRESSION_ADOBE_DEFLATE)),
                  image);
}

// Float TIFF depth is in metres: a file in millimetres is refused saying so (NpyTest has the
// same for float NPY and for counts with a unit 1,000 times too large).
TEST(TiffTest, RefusesMillimetresReadAsMetres) {
  const cv::Mat1f metres = TestDepth(20, 20);
  ASSERT_TRUE(DecodeDepth(EncodeTiffFloat(metres)).ok());
  ExpectError(DecodeDepth(EncodeTiffFloat(metres * 1000)), ErrorCode::kInvalidArgument,
              "must be divided by 1000");
}

TEST(TiffTest, RejectsUint16Samples) {
  ExpectError(DecodeDepth(EncodeWithOpenCv(".tiff", cv::Mat1w(4, 4, 1000))),
              ErrorCode::kUnsupportedFormat,
              "TIFF depth must be 32-bit float with one sample per pixel (got 16-bit unsigned");
}

TEST(TiffTest, RejectsTruncatedFiles) {
  const std::string tiff = EncodeTiffFloat(TestDepth(20, 20));
  for (const std::size_t size : {std::size_t{6}, std::size_t{100}, tiff.size() - 10}) {
    SCOPED_TRACE(size);
    ExpectError(DecodeDepth(tiff.substr(0, size)), ErrorCode::kInvalidArgument, "TIFF");
  }
  // The directory is intact but the pixel data runs past the end of the file.
  std::string short_strip = tiff;
  PatchTiffTag(short_strip, TIFFTAG_STRIPOFFSETS, static_cast<std::uint32_t>(tiff.size() - 16));
  ExpectError(DecodeDepth(short_strip), ErrorCode::kInvalidArgument, "cannot read the strip");
}

TEST(TiffTest, RefusesDeclaredHugeImageBeforeReading) {
  std::string tiff = EncodeTiffFloat(TestDepth(4, 4));
  PatchTiffTag(tiff, TIFFTAG_IMAGEWIDTH, 100000);
  PatchTiffTag(tiff, TIFFTAG_IMAGELENGTH, 100000);
  ExpectError(DecodeDepth(tiff), ErrorCode::kTooLarge, "exceeds the limit");
  DepthDecodeOptions small;
  small.max_pixels = 15;
  ExpectError(DecodeDepth(EncodeTiffFloat(TestDepth(4, 4)), small), ErrorCode::kTooLarge,
              "limit of 15 pixels");
}

TEST(TiffTest, RejectsZeroSize) {
  std::string tiff = EncodeTiffFloat(TestDepth(4, 4));
  PatchTiffTag(tiff, TIFFTAG_IMAGEWIDTH, 0);
  const auto result = DecodeDepth(tiff);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, ErrorCode::kInvalidArgument);
}

TEST(TiffTest, RejectsGarbageAfterMagic) {
  ExpectError(DecodeDepth(std::string("II*\0garbage garbage garbage", 27)),
              ErrorCode::kInvalidArgument, "TIFF");
}

TEST(TiffTest, EncoderRefusesEmptyImage) {
  EXPECT_THROW(EncodeTiffFloat(cv::Mat1f()), std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::io
