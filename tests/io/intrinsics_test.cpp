// GQ-CNN .intr parsing: the shipped sample cameras and malformed documents.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "service/io/depth_codec.h"
#include "tests/support/test_data.h"

namespace softgrasp::io {
namespace {

using softgrasp::testing::TestData;

using core::ErrorCode;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << path;
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void ExpectFieldError(const std::string& json, const std::string& field) {
  const auto result = ParseIntrinsicsJson(json);
  ASSERT_FALSE(result.ok()) << json;
  EXPECT_EQ(result.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(result.error().field, field) << result.error().message;
  EXPECT_NE(result.error().message.find(field), std::string::npos) << result.error().message;
}

TEST(IntrinsicsTest, ParsesPrimesenseSample) {
  const auto camera = ParseIntrinsicsJson(ReadFile(TestData("gqcnn/primesense/primesense.intr")));
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  EXPECT_DOUBLE_EQ(camera.value().fx, 525.0);
  EXPECT_DOUBLE_EQ(camera.value().fy, 525.0);
  EXPECT_DOUBLE_EQ(camera.value().cx, 319.5);
  EXPECT_DOUBLE_EQ(camera.value().cy, 239.5);
  EXPECT_EQ(camera.value().width, 640);
  EXPECT_EQ(camera.value().height, 480);
}

TEST(IntrinsicsTest, ParsesPhoxiSample) {
  const auto camera = ParseIntrinsicsJson(ReadFile(TestData("gqcnn/phoxi/phoxi.intr")));
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  EXPECT_DOUBLE_EQ(camera.value().fx, 552.5);
  EXPECT_DOUBLE_EQ(camera.value().fy, 552.5);
  EXPECT_DOUBLE_EQ(camera.value().cx, 255.5);
  EXPECT_DOUBLE_EQ(camera.value().cy, 191.75);
  EXPECT_EQ(camera.value().width, 516);
  EXPECT_EQ(camera.value().height, 386);
}

TEST(IntrinsicsTest, AcceptsIntegersAndIgnoresExtraKeys) {
  const auto camera = ParseIntrinsicsJson(
      R"({"_fx": 600, "_fy": 610, "_cx": 320, "_cy": 240, "_width": 640.0, "_height": 480,
          "_frame": "camera", "_K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "_skew": 0.0})");
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  EXPECT_DOUBLE_EQ(camera.value().fy, 610.0);
  EXPECT_EQ(camera.value().width, 640);
}

constexpr const char* kRest = R"("_cx": 319.5, "_cy": 239.5, "_width": 640, "_height": 480})";

TEST(IntrinsicsTest, NamesTheKeyAtFault) {
  ExpectFieldError(std::string(R"({"_fy": 525, )") + kRest, "_fx");
  ExpectFieldError(std::string(R"({"_fx": 525, "_fy": -1, )") + kRest, "_fy");
  ExpectFieldError(std::string(R"({"_fx": 0, "_fy": 525, )") + kRest, "_fx");
  ExpectFieldError(std::string(R"({"_fx": "525", "_fy": 525, )") + kRest, "_fx");
  ExpectFieldError(std::string(R"({"_fx": true, "_fy": 525, )") + kRest, "_fx");
  ExpectFieldError(R"({"_fx": 525, "_fy": 525, "_cy": 239.5, "_width": 640, "_height": 480})",
                   "_cx");
  ExpectFieldError(R"({"_fx": 525, "_fy": 525, "_cx": 1, "_cy": null, "_width": 640,
                       "_height": 480})",
                   "_cy");
  ExpectFieldError(R"({"_fx": 525, "_fy": 525, "_cx": 1, "_cy": 1, "_width": 640.5,
                       "_height": 480})",
                   "_width");
  ExpectFieldError(R"({"_fx": 525, "_fy": 525, "_cx": 1, "_cy": 1, "_width": 640,
                       "_height": 0})",
                   "_height");
  ExpectFieldError(R"({"_fx": 525, "_fy": 525, "_cx": 1, "_cy": 1, "_width": 1e12,
                       "_height": 480})",
                   "_width");
}

TEST(IntrinsicsTest, RejectsNonObjects) {
  for (const std::string json : {"", "[1, 2]", "{\"_fx\": ", "525", "null", "\x93NUMPY"}) {
    const auto result = ParseIntrinsicsJson(json);
    ASSERT_FALSE(result.ok()) << json;
    EXPECT_EQ(result.error().code, ErrorCode::kInvalidArgument);
    EXPECT_EQ(result.error().field, "intrinsics");
  }
}

}  // namespace
}  // namespace softgrasp::io
