// NPY decoding and encoding: round trips, header variants, broken files, the GQ-CNN samples.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "tests/io/io_test_util.h"
#include "tests/support/test_data.h"

namespace softgrasp::io {
namespace {

using softgrasp::testing::TestData;

using core::ErrorCode;
using test::ElementBytes;
using test::ExpectError;
using test::FloatBytes;
using test::MakeNpy;
using test::NpyDict;
using test::ReadFile;
using ::testing::HasSubstr;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

const cv::Mat1f kSixValues = (cv::Mat1f(2, 3) << 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1.0f);

void ExpectSixValues(const core::Result<core::DepthImage>& result) {
  ASSERT_TRUE(result.ok()) << result.error().message;
  const cv::Mat1f& d = result.value().depth_m;
  ASSERT_EQ(d.rows, 2);
  ASSERT_EQ(d.cols, 3);
  EXPECT_EQ(cv::norm(d, kSixValues, cv::NORM_INF), 0.0);
}

TEST(NpyTest, RoundTripKeepsValuesAndMarksMissing) {
  cv::Mat1f image(7, 5);
  cv::randu(image, 0.2, 2.0);
  image(0, 0) = 0.0f;
  image(1, 2) = kNaN;
  image(3, 4) = -0.5f;
  image(6, 1) = std::numeric_limits<float>::infinity();
  const auto decoded = DecodeDepth(EncodeNpy(image));
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  const cv::Mat1f& d = decoded.value().depth_m;
  ASSERT_EQ(d.size(), image.size());
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      const float z = image(r, c);
      if (std::isfinite(z) && z > 0) {
        EXPECT_EQ(d(r, c), z);
      } else {
        EXPECT_TRUE(std::isnan(d(r, c))) << r << "," << c;
      }
    }
  }
}

TEST(NpyTest, EncoderWritesVersion1HeaderAlignedTo64Bytes) {
  const std::string npy = EncodeNpy(cv::Mat1f(3, 4, 1.0f));
  ASSERT_GE(npy.size(), 10u);
  EXPECT_EQ(npy.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t header_length =
      static_cast<unsigned char>(npy[8]) + 256u * static_cast<unsigned char>(npy[9]);
  EXPECT_EQ((10 + header_length) % 64, 0u);
  EXPECT_EQ(npy[10 + header_length - 1], '\n');
  EXPECT_THAT(npy.substr(10, header_length), HasSubstr("'descr': '<f4'"));
  EXPECT_THAT(npy.substr(10, header_length), HasSubstr("'shape': (3, 4)"));
  EXPECT_EQ(npy.size(), 10 + header_length + 3 * 4 * sizeof(float));
}

TEST(NpyTest, AcceptsShapeWithTrailingChannel) {
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict("<f4", "(2, 3, 1)"), FloatBytes(kSixValues))));
}

TEST(NpyTest, AcceptsBigEndian) {
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict(">f4", "(2, 3)"), FloatBytes(kSixValues, true))));
}

TEST(NpyTest, TransposesFortranOrder) {
  // Column-major storage of the 2x3 image: columns one after another.
  const cv::Mat1f column_major = kSixValues.t();
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict("<f4", "(2, 3)", true), FloatBytes(column_major))));
}

TEST(NpyTest, AcceptsVersions2And3) {
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict("<f4", "(2, 3)"), FloatBytes(kSixValues), 2)));
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict("<f4", "(2, 3)"), FloatBytes(kSixValues), 3)));
}

TEST(NpyTest, AcceptsOtherKeyOrderDoubleQuotesAndPython2Longs) {
  const std::string dict = "{\"shape\":(2L,3L),\"fortran_order\":False,\"descr\":\"<f4\"}   ";
  ExpectSixValues(DecodeDepth(MakeNpy(dict, FloatBytes(kSixValues))));
}

// numpy.save of a depth computed in double precision (numpy's default float).
TEST(NpyTest, AcceptsFloat64InMetresInEitherByteOrder) {
  const std::vector<double> values = {0.5, 0.6, 0.7, 0.8, 0.9, 1.0};
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict("<f8", "(2, 3)"), ElementBytes(values))));
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict(">f8", "(2, 3)"), ElementBytes(values, true))));
  ExpectSixValues(
      DecodeDepth(MakeNpy(NpyDict("<f8", "(2, 3, 1)"), ElementBytes(values))));  // (H, W, 1)
}

// numpy.save of a raw sensor frame: uint16 counts of png_unit_m (millimetres by default, as a
// 16-bit PNG's), 0 = missing.
TEST(NpyTest, AcceptsUint16CountsOfThePngUnit) {
  const std::vector<std::uint16_t> mm = {500, 600, 700, 800, 900, 1000};
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict("<u2", "(2, 3)"), ElementBytes(mm))));
  ExpectSixValues(DecodeDepth(MakeNpy(NpyDict(">u2", "(2, 3)"), ElementBytes(mm, true))));
  const std::vector<std::uint16_t> tenths = {5000, 6000, 7000, 8000, 9000, 0};
  const auto fine = DecodeDepth(MakeNpy(NpyDict("<u2", "(2, 3)"), ElementBytes(tenths)),
                                DepthDecodeOptions{.png_unit_m = 0.0001});
  ASSERT_TRUE(fine.ok()) << fine.error().message;
  EXPECT_FLOAT_EQ(fine.value().depth_m(1, 1), 0.9f);
  EXPECT_TRUE(std::isnan(fine.value().depth_m(1, 2))) << "0 is missing";
  const auto bad_unit = DecodeDepth(MakeNpy(NpyDict("<u2", "(2, 3)"), ElementBytes(mm)),
                                    DepthDecodeOptions{.png_unit_m = 0.0});
  ASSERT_FALSE(bad_unit.ok());
  EXPECT_EQ(bad_unit.error().field, "png_unit_m");
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f8", "(2, 3)"), std::string(47, '\0'))),
              ErrorCode::kInvalidArgument, "needs 48 bytes");
}

// Millimetres in a float file (or counts with a unit 1,000 times too large) would put the scene
// hundreds of metres away: a clear error instead of "no floor plane found".
TEST(NpyTest, RefusesMillimetresReadAsMetresSayingSo) {
  const std::vector<double> mm = {500, 600, 700, 800, 900, 1000};
  const auto result = DecodeDepth(MakeNpy(NpyDict("<f8", "(2, 3)"), ElementBytes(mm)));
  ExpectError(result, ErrorCode::kInvalidArgument, "median reading is 800 m");
  EXPECT_THAT(result.error().message, HasSubstr("divided by 1000"));
  const std::vector<std::uint16_t> counts = {500, 600, 700, 800, 900, 1000};
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<u2", "(2, 3)"), ElementBytes(counts)),
                          DepthDecodeOptions{.png_unit_m = 1.0}),
              ErrorCode::kInvalidArgument, "median reading is 800 m");
  // Far readings are fine while the median is plausible.
  const std::vector<double> some_far = {0.5, 0.6, 0.7, 0.8, 900, 1000};
  EXPECT_TRUE(DecodeDepth(MakeNpy(NpyDict("<f8", "(2, 3)"), ElementBytes(some_far))).ok());
}

TEST(NpyTest, RejectsOtherDtypesNamingThem) {
  const std::string data(6 * 8, '\0');
  for (const std::string dtype : {"|f4", "<f2", "<i4", "<i2", "|u1", "<u4", "<c8"}) {
    SCOPED_TRACE(dtype);
    const auto result = DecodeDepth(MakeNpy(NpyDict(dtype, "(2, 3)"), data));
    ExpectError(result, ErrorCode::kUnsupportedFormat, "'" + dtype + "'");
    EXPECT_THAT(result.error().message, HasSubstr("'<f4', '>f4', '<f8', '>f8'"));
    EXPECT_THAT(result.error().message, HasSubstr("'<u2', '>u2'"));
  }
}

TEST(NpyTest, RejectsStructuredDtype) {
  ExpectError(DecodeDepth(MakeNpy("{'descr': [('z', '<f4')], 'fortran_order': False, "
                                  "'shape': (2, 3), }",
                                  FloatBytes(kSixValues))),
              ErrorCode::kUnsupportedFormat, "structured");
}

TEST(NpyTest, RejectsTruncatedHeader) {
  const std::string npy = EncodeNpy(cv::Mat1f(4, 4, 1.0f));
  ExpectError(DecodeDepth(npy.substr(0, 40)), ErrorCode::kInvalidArgument, "truncated header");
  ExpectError(DecodeDepth(npy.substr(0, 9)), ErrorCode::kInvalidArgument, "truncated");
}

TEST(NpyTest, RejectsTruncatedData) {
  const std::string npy = EncodeNpy(cv::Mat1f(4, 4, 1.0f));
  ExpectError(DecodeDepth(npy.substr(0, npy.size() - 1)), ErrorCode::kInvalidArgument,
              "NPY data is truncated");
}

TEST(NpyTest, RejectsZeroSize) {
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f4", "(0, 640)"), "")), ErrorCode::kInvalidArgument,
              "empty");
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f4", "(4, 4, 0)"), "")), ErrorCode::kInvalidArgument,
              "(4, 4, 0)");
}

TEST(NpyTest, RejectsNonImageShapes) {
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f4", "(2, 3, 3)"), FloatBytes(kSixValues))),
              ErrorCode::kUnsupportedFormat, "(H, W) or (H, W, 1)");
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f4", "(6,)"), FloatBytes(kSixValues))),
              ErrorCode::kUnsupportedFormat, "(6,)");
}

TEST(NpyTest, RefusesDeclaredHugeImageBeforeReadingData) {
  // 100000 x 100000 floats would be 40 GB; the file holds none of it.
  const std::string npy = MakeNpy(NpyDict("<f4", "(100000, 100000)"), "");
  ExpectError(DecodeDepth(npy), ErrorCode::kTooLarge, "exceeds the limit");
  DepthDecodeOptions small;
  small.max_pixels = 5;
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f4", "(2, 3)"), FloatBytes(kSixValues)), small),
              ErrorCode::kTooLarge, "limit of 5 pixels");
}

TEST(NpyTest, RefusesShapeWhoseProductOverflows) {
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f4", "(4294967296, 4294967296)"), "")),
              ErrorCode::kTooLarge, "exceeds");
  ExpectError(DecodeDepth(MakeNpy(NpyDict("<f4", "(99999999999999999999999999, 2)"), "")),
              ErrorCode::kTooLarge, "exceeds");
}

TEST(NpyTest, RejectsMalformedHeaders) {
  const std::string data = FloatBytes(kSixValues);
  for (const std::string dict :
       {"", "{", "{'descr': '<f4', 'shape': (2, 3)}", "{'descr': '<f4' 'fortran_order': False}",
        "{'descr': '<f4', 'fortran_order': Maybe, 'shape': (2, 3)}",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (2, x)}",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), 'extra': 1}",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3)} trailing",
        "{'descr: '<f4', 'fortran_order': False, 'shape': (2, 3)}"}) {
    SCOPED_TRACE(dict);
    ExpectError(DecodeDepth(MakeNpy(dict, data)), ErrorCode::kInvalidArgument, "NPY header");
  }
}

TEST(NpyTest, RejectsUnknownVersion) {
  std::string npy = EncodeNpy(cv::Mat1f(2, 2, 1.0f));
  npy[6] = 4;
  ExpectError(DecodeDepth(npy), ErrorCode::kUnsupportedFormat, "version 4.0");
}

TEST(NpyTest, DecodesPrimesenseSample) {
  const auto result = DecodeDepth(ReadFile(TestData("gqcnn/primesense/single_depth_0.npy")));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const cv::Mat1f& d = result.value().depth_m;
  EXPECT_EQ(d.rows, 480);
  EXPECT_EQ(d.cols, 640);
  float low = 100, high = 0;
  for (const float z : d) {
    if (std::isnan(z)) continue;
    low = std::min(low, z);
    high = std::max(high, z);
  }
  EXPECT_NEAR(low, 0.54, 0.02);
  EXPECT_NEAR(high, 0.82, 0.02);
}

TEST(NpyTest, DecodesPhoxiSampleWithMissingPixels) {
  const auto result = DecodeDepth(ReadFile(TestData("gqcnn/phoxi/clutter_depth_0.npy")));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const cv::Mat1f& d = result.value().depth_m;
  EXPECT_EQ(d.rows, 386);
  EXPECT_EQ(d.cols, 516);
  // (cv::compare does not treat NaN != NaN reliably: count by hand.)
  const auto nan_count = std::count_if(d.begin(), d.end(), [](float z) { return std::isnan(z); });
  const double nan_fraction = static_cast<double>(nan_count) / static_cast<double>(d.total());
  EXPECT_NEAR(nan_fraction, 0.31, 0.02);
}

}  // namespace
}  // namespace softgrasp::io
