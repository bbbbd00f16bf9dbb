// Intrinsics parsing: GQ-CNN .intr (the shipped sample cameras), ROS CameraInfo, Open3D and
// librealsense layouts, and malformed documents.
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

// The Primesense camera of ../shared/data as the robot software around us writes intrinsics.
TEST(IntrinsicsTest, ReadsRosOpen3dAndRealsenseLayoutsAsTheIntrFile) {
  const auto intr = ParseIntrinsicsJson(ReadFile(TestData("gqcnn/primesense/primesense.intr")));
  ASSERT_TRUE(intr.ok());
  const std::string layouts[] = {
      // ROS 1 sensor_msgs/CameraInfo (rosbridge / rostopic echo as JSON), K row-major
      R"({"header": {"frame_id": "camera"}, "height": 480, "width": 640,
          "distortion_model": "plumb_bob", "D": [0, 0, 0, 0, 0],
          "K": [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0],
          "P": [525.0, 0.0, 319.5, 0.0, 0.0, 525.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0]})",
      // ROS 2 field names
      R"({"height": 480, "width": 640, "d": [], "k": [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]})",
      // the matrix as three rows
      R"({"height": 480, "width": 640, "K": [[525, 0, 319.5], [0, 525, 239.5], [0, 0, 1]]})",
      // Open3D's write_pinhole_camera_intrinsic: column-major
      R"({"width": 640, "height": 480,
          "intrinsic_matrix": [525.0, 0.0, 0.0, 0.0, 525.0, 0.0, 319.5, 239.5, 1.0]})",
      // librealsense rs2_intrinsics
      R"({"width": 640, "height": 480, "ppx": 319.5, "ppy": 239.5, "fx": 525.0, "fy": 525.0,
          "model": "Brown Conrady", "coeffs": [0, 0, 0, 0, 0]})",
  };
  for (const std::string& json : layouts) {
    SCOPED_TRACE(json);
    const auto camera = ParseIntrinsicsJson(json);
    ASSERT_TRUE(camera.ok()) << camera.error().message;
    EXPECT_DOUBLE_EQ(camera.value().fx, intr.value().fx);
    EXPECT_DOUBLE_EQ(camera.value().fy, intr.value().fy);
    EXPECT_DOUBLE_EQ(camera.value().cx, intr.value().cx);
    EXPECT_DOUBLE_EQ(camera.value().cy, intr.value().cy);
    EXPECT_EQ(camera.value().width, intr.value().width);
    EXPECT_EQ(camera.value().height, intr.value().height);
  }
  // fx != fy and cx != cy tell the two orders apart.
  const auto ros = ParseIntrinsicsJson(
      R"({"width": 640, "height": 480, "K": [600, 0, 330, 0, 610, 250, 0, 0, 1]})");
  const auto open3d = ParseIntrinsicsJson(
      R"({"width": 640, "height": 480, "intrinsic_matrix": [600, 0, 0, 0, 610, 0, 330, 250, 1]})");
  ASSERT_TRUE(ros.ok() && open3d.ok());
  for (const core::Camera& c : {ros.value(), open3d.value()}) {
    EXPECT_DOUBLE_EQ(c.fx, 600);
    EXPECT_DOUBLE_EQ(c.fy, 610);
    EXPECT_DOUBLE_EQ(c.cx, 330);
    EXPECT_DOUBLE_EQ(c.cy, 250);
  }
}

// ROS's image_geometry reads a CameraInfo's camera from P (the rectified image's), falls back on
// K when P is all zeros, and applies the region of interest, then binning.
TEST(IntrinsicsTest, ReadsRosCameraInfoAsImageGeometryDoes) {
  auto parse = [](const std::string& json) {
    auto c = ParseIntrinsicsJson(json);
    EXPECT_TRUE(c.ok()) << json << ": " << (c.ok() ? "" : c.error().message);
    return c.ok() ? c.value() : core::Camera{};
  };
  const std::string k = R"("K": [600, 0, 330, 0, 610, 250, 0, 0, 1])";
  const std::string p = R"("P": [590, 0, 320, -59, 0, 595, 245, 0, 0, 0, 1, 0])";
  // P wins over K, its last column (a stereo baseline) is not used; ROS 2's lower-case too.
  core::Camera c = parse(R"({"width": 1280, "height": 720, )" + k + ", " + p + "}");
  EXPECT_DOUBLE_EQ(c.fx, 590);
  EXPECT_DOUBLE_EQ(c.fy, 595);
  EXPECT_DOUBLE_EQ(c.cx, 320);
  EXPECT_DOUBLE_EQ(c.cy, 245);
  c = parse(R"({"width": 1280, "height": 720, "k": [600, 0, 330, 0, 610, 250, 0, 0, 1],
                "p": [[590, 0, 320, 0], [0, 595, 245, 0], [0, 0, 1, 0]]})");
  EXPECT_DOUBLE_EQ(c.fx, 590);
  // An uncalibrated camera's P is all zeros: K.
  c = parse(R"({"width": 1280, "height": 720, )" + k + R"(, "P": [0,0,0,0,0,0,0,0,0,0,0,0]})");
  EXPECT_DOUBLE_EQ(c.fx, 600);
  EXPECT_DOUBLE_EQ(c.cx, 330);
  // P alone.
  c = parse(R"({"width": 1280, "height": 720, )" + p + "}");
  EXPECT_DOUBLE_EQ(c.cx, 320);
  // Region of interest: the principal point moves by its offset, the image is its size; all
  // zeros is the whole image.
  c = parse(R"({"width": 1280, "height": 720, )" + k +
            R"(, "roi": {"x_offset": 100, "y_offset": 50, "width": 640, "height": 480,
                         "do_rectify": false}})");
  EXPECT_DOUBLE_EQ(c.cx, 230);
  EXPECT_DOUBLE_EQ(c.cy, 200);
  EXPECT_DOUBLE_EQ(c.fx, 600);
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  c = parse(R"({"width": 1280, "height": 720, )" + k +
            R"(, "roi": {"x_offset": 0, "y_offset": 0, "width": 0, "height": 0},
                "binning_x": 0, "binning_y": 0})");
  EXPECT_EQ(c.width, 1280);
  EXPECT_DOUBLE_EQ(c.cx, 330);
  // Binning 2 x 4 after the region of interest: fx, cx and the width halve, fy, cy and the
  // height quarter.
  c = parse(R"({"width": 1280, "height": 720, )" + k +
            R"(, "roi": {"x_offset": 100, "y_offset": 50, "width": 640, "height": 480},
                "binning_x": 2, "binning_y": 4})");
  EXPECT_DOUBLE_EQ(c.fx, 300);
  EXPECT_DOUBLE_EQ(c.cx, 115);
  EXPECT_DOUBLE_EQ(c.fy, 152.5);
  EXPECT_DOUBLE_EQ(c.cy, 50);
  EXPECT_EQ(c.width, 320);
  EXPECT_EQ(c.height, 120);

  // Broken ones name their key.
  const std::string size = R"({"width": 1280, "height": 720, )";
  ExpectFieldError(size + k + R"(, "P": [590, 0, 320, 0, 0, 595, 245, 0, 0, 0, 1]})", "P");
  ExpectFieldError(size + k + R"(, "P": [590, 0, 320, 0, 0, 595, 245, 0, 0, 0, 1, 5]})", "P");
  ExpectFieldError(size + R"("P": [0,0,0,0,0,0,0,0,0,0,0,0]})", "P");
  ExpectFieldError(size + k + R"(, "roi": {"x_offset": 700, "y_offset": 0, "width": 640,
                                           "height": 480}})",
                   "roi");
  ExpectFieldError(size + k + R"(, "roi": {"x_offset": 10, "y_offset": 0, "width": 0,
                                           "height": 0}})",
                   "roi");
  ExpectFieldError(size + k + R"(, "roi": [0, 0, 640, 480]})", "roi");
  ExpectFieldError(size + k + R"(, "roi": {"x_offset": -1, "width": 640, "height": 480}})",
                   "roi.x_offset");
  ExpectFieldError(size + k + R"(, "binning_x": 1.5})", "binning_x");
  ExpectFieldError(size + k + R"(, "binning_y": "2"})", "binning_y");
  ExpectFieldError(size + k + R"(, "binning_x": 4096})", "binning_x");
}

TEST(IntrinsicsTest, NamesTheKeyAtFaultInEveryLayout) {
  // A matrix in the other order would put the principal point in the wrong place: refused.
  ExpectFieldError(R"({"width": 640, "height": 480, "K": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})",
                   "K");
  ExpectFieldError(
      R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]})",
      "intrinsic_matrix");
  ExpectFieldError(R"({"width": 640, "height": 480, "K": [525, 0, 319.5, 0, 525, 239.5, 0, 0]})",
                   "K");
  ExpectFieldError(R"({"width": 640, "height": 480, "k": "525 0 319.5 0 525 239.5 0 0 1"})", "k");
  ExpectFieldError(R"({"width": 640, "height": 480, "K": [0, 0, 319.5, 0, 525, 239.5, 0, 0, 1]})",
                   "K");
  ExpectFieldError(R"({"height": 480, "K": [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]})", "width");
  ExpectFieldError(R"({"width": 640, "height": 480, "ppx": 319.5, "ppy": 239.5, "fx": 525})", "fy");
  const auto unknown = ParseIntrinsicsJson(R"({"focal": 525, "width": 640, "height": 480})");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().field, "intrinsics");
  EXPECT_NE(unknown.error().message.find("ROS CameraInfo"), std::string::npos)
      << unknown.error().message;
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
