// Region-of-interest masks (GQ-CNN's segmask): every PNG flavour a client may send, and broken
// or hostile files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <png.h>

#include <cstdint>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "tests/io/io_test_util.h"

namespace softgrasp::io {
namespace {

using core::ErrorCode;
using test::EncodeWithOpenCv;
using test::PatchPngSize;

constexpr std::int64_t kMaxPixels = 1 << 20;

// A 40 x 30 mask with a filled rectangle and one isolated pixel at (3, 2).
cv::Mat1b Expected() {
  cv::Mat1b m(30, 40, uchar{0});
  m(cv::Rect(10, 5, 20, 15)).setTo(255);
  m(2, 3) = 255;
  return m;
}

void ExpectMask(const core::Result<cv::Mat1b>& result, const cv::Mat1b& expected) {
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_EQ(result.value().size(), expected.size());
  EXPECT_EQ(cv::countNonZero(result.value() != expected), 0);
}

void ExpectMaskError(const core::Result<cv::Mat1b>& result, ErrorCode code,
                     const std::string& substring) {
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, code) << result.error().message;
  EXPECT_THAT(result.error().message, ::testing::HasSubstr(substring));
  EXPECT_EQ(result.error().field, "segmask");
}

TEST(DecodeMask, EightBitGreyWithAnyNonZeroValueAllowed) {
  cv::Mat1b grey = Expected() / 255;  // values 0 and 1: "non-zero" is not "255"
  ExpectMask(DecodeMask(EncodeWithOpenCv(".png", grey), kMaxPixels), Expected());
}

TEST(DecodeMask, SixteenBitGrey) {
  cv::Mat1w counts;
  cv::Mat1b(Expected() / 255).convertTo(counts, CV_16U);  // 1 of 65535: a low byte only
  ExpectMask(DecodeMask(EncodeWithOpenCv(".png", counts), kMaxPixels), Expected());
}

TEST(DecodeMask, OneBitGrey) {
  const std::vector<int> bilevel = {cv::IMWRITE_PNG_BILEVEL, 1};
  std::vector<uchar> buffer;
  ASSERT_TRUE(cv::imencode(".png", Expected(), buffer, bilevel));
  const std::string png(buffer.begin(), buffer.end());
  ASSERT_EQ(static_cast<int>(png[24]), 1) << "not a 1-bit PNG";
  ExpectMask(DecodeMask(png, kMaxPixels), Expected());
}

TEST(DecodeMask, ColourAnyChannelCountsAndAlphaIsIgnored) {
  cv::Mat3b colour(Expected().size(), cv::Vec3b(0, 0, 0));
  colour.setTo(cv::Vec3b(0, 0, 7), Expected());  // red only, faint
  ExpectMask(DecodeMask(EncodeWithOpenCv(".png", colour), kMaxPixels), Expected());

  cv::Mat4b rgba(Expected().size(), cv::Vec4b(0, 0, 0, 255));  // opaque black: not allowed
  rgba.setTo(cv::Vec4b(0, 9, 0, 0), Expected());               // transparent green: allowed
  ExpectMask(DecodeMask(EncodeWithOpenCv(".png", rgba), kMaxPixels), Expected());
}

// Writes `rows` (already in the PNG's sample layout) with libpng: for the flavours OpenCV does
// not write (palette, Adam7 interlacing).
std::string WritePng(int width, int height, int bit_depth, int color_type, bool interlaced,
                     const std::vector<std::vector<png_byte>>& rows,
                     const std::vector<png_color>& palette = {}) {
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t n) {
        static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<char*>(data), n);
      },
      nullptr);
  png_set_IHDR(png, info, width, height, bit_depth, color_type,
               interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  if (!palette.empty()) png_set_PLTE(png, info, palette.data(), static_cast<int>(palette.size()));
  png_write_info(png, info);
  std::vector<png_bytep> pointers;
  for (const auto& row : rows) pointers.push_back(const_cast<png_bytep>(row.data()));
  png_write_image(png, pointers.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

TEST(DecodeMask, InterlacedGreyDecodesTheSame) {
  const cv::Mat1b expected = Expected();
  std::vector<std::vector<png_byte>> rows;
  for (int v = 0; v < expected.rows; ++v) {
    rows.emplace_back(expected.ptr<uchar>(v), expected.ptr<uchar>(v) + expected.cols);
  }
  const std::string png =
      WritePng(expected.cols, expected.rows, 8, PNG_COLOR_TYPE_GRAY, true, rows);
  ASSERT_EQ(static_cast<int>(png[28]), 1) << "not interlaced";
  ExpectMask(DecodeMask(png, kMaxPixels), expected);
}

TEST(DecodeMask, PaletteIndicesCountByTheirColour) {
  // Index 0 is black (not allowed), index 1 white, index 2 black again: a palette entry's
  // colour decides, not its index.
  const std::vector<png_color> palette = {{0, 0, 0}, {255, 255, 255}, {0, 0, 0}};
  const cv::Mat1b expected = Expected();
  std::vector<std::vector<png_byte>> rows;
  for (int v = 0; v < expected.rows; ++v) {
    std::vector<png_byte> row;
    for (int u = 0; u < expected.cols; ++u) row.push_back(expected(v, u) ? 1 : (u % 2 ? 2 : 0));
    rows.push_back(row);
  }
  ExpectMask(DecodeMask(WritePng(expected.cols, expected.rows, 8, PNG_COLOR_TYPE_PALETTE, false,
                                 rows, palette),
                        kMaxPixels),
             expected);
}

TEST(DecodeMask, NotAPngIsUnsupported) {
  ExpectMaskError(DecodeMask("", kMaxPixels), ErrorCode::kUnsupportedFormat, "PNG");
  ExpectMaskError(DecodeMask("P5\n2 2\n255\n\1\2\3\4", kMaxPixels), ErrorCode::kUnsupportedFormat,
                  "PNG");
  ExpectMaskError(DecodeMask(std::string("\x93NUMPY", 6), kMaxPixels),
                  ErrorCode::kUnsupportedFormat, "PNG");
}

TEST(DecodeMask, TruncatedAndCorruptFilesAreInvalid) {
  const std::string png = EncodeWithOpenCv(".png", Expected());
  ExpectMaskError(DecodeMask(png.substr(0, 20), kMaxPixels), ErrorCode::kInvalidArgument,
                  "truncated");
  ExpectMaskError(DecodeMask(png.substr(0, png.size() - 30), kMaxPixels),
                  ErrorCode::kInvalidArgument, "PNG");
  std::string flipped = png;
  flipped[flipped.size() / 2] = static_cast<char>(flipped[flipped.size() / 2] ^ 0x55);
  ExpectMaskError(DecodeMask(flipped, kMaxPixels), ErrorCode::kInvalidArgument, "PNG");
  std::string bad_depth = png;
  bad_depth[24] = 3;  // bit depth 3 does not exist
  ExpectMaskError(DecodeMask(bad_depth, kMaxPixels), ErrorCode::kInvalidArgument, "bit depth");
}

TEST(DecodeMask, OversizedImagesAreRefusedBeforeDecoding) {
  std::string png = EncodeWithOpenCv(".png", Expected());
  ExpectMaskError(DecodeMask(png, 100), ErrorCode::kTooLarge, "");
  PatchPngSize(png, 100000, 100000);  // the IHDR claims 10^10 pixels; the data is 40 x 30
  ExpectMaskError(DecodeMask(png, kMaxPixels), ErrorCode::kTooLarge, "");
  PatchPngSize(png, 0, 30);
  ExpectMaskError(DecodeMask(png, kMaxPixels), ErrorCode::kInvalidArgument, "");
}

}  // namespace
}  // namespace softgrasp::io
