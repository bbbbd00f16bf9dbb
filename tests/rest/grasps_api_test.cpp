// POST /v1/grasps end to end: real server, real socket, real depth files.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "tests/io/io_test_util.h"
#include "tests/rest/server_fixture.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;
using testing::FormPart;
using testing::MultipartRequest;
using testing::RawRequest;
using testing::ReadFileBytes;
using testing::RunningServer;
using testing::TestData;

class GraspsApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new RunningServer(); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static RunningServer* server_;
};
RunningServer* GraspsApiTest::server_ = nullptr;

json ExpectError(const testing::HttpReply& reply, int status, const std::string& field = "") {
  EXPECT_EQ(reply.status, status) << reply.body;
  EXPECT_EQ(reply.header("Content-Type").value_or(""), "application/json");
  const json body = json::parse(reply.body, nullptr, false);
  EXPECT_TRUE(body.contains("error")) << reply.body;
  if (!body.contains("error")) return body;
  EXPECT_TRUE(body["error"]["code"].is_string());
  EXPECT_FALSE(body["error"]["message"].get<std::string>().empty());
  if (!field.empty()) {
    EXPECT_EQ(body["error"].value("field", ""), field) << reply.body;
  }
  return body;
}

TEST_F(GraspsApiTest, PrimesenseFramesGiveGraspsOnTheObject) {
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE("single_depth_" + std::to_string(i));
    const auto reply = server_->Send(MultipartRequest(
        "/v1/grasps",
        {{"depth",
          ReadFileBytes(TestData("gqcnn/primesense/single_depth_" + std::to_string(i) + ".npy")),
          "d.npy"},
         {"intrinsics", ReadFileBytes(TestData("gqcnn/primesense/primesense.intr")), "p.intr"}}));
    ASSERT_EQ(reply.status, 200) << reply.body;
    const json body = json::parse(reply.body);
    EXPECT_EQ(body["camera"]["source"], "request");
    EXPECT_EQ(body["camera"]["fx"], 525.0);
    EXPECT_EQ(body["image"]["format"], "npy");
    ASSERT_FALSE(body["grasps"].empty());
    const json& best = body["grasps"][0];
    EXPECT_EQ(best["rank"], 1);
    const cv::Mat mask =
        cv::imread(TestData("gqcnn/primesense/single_segmask_" + std::to_string(i) + ".png"),
                   cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(mask.empty());
    const int u = static_cast<int>(std::lround(best["center_px"]["u"].get<double>()));
    const int v = static_cast<int>(std::lround(best["center_px"]["v"].get<double>()));
    EXPECT_GT(mask.at<uint8_t>(v, u), 0)
        << "best grasp centre (" << u << ", " << v << ") is off the object";
    // The pose lies on the centre pixel's ray: u = fx x / z + cx.
    const auto& p = best["pose"]["position_m"];
    const double z = p[2].get<double>();
    ASSERT_GT(z, 0.4);
    EXPECT_NEAR(525.0 * p[0].get<double>() / z + 319.5, best["center_px"]["u"].get<double>(), 0.5);
    EXPECT_NEAR(525.0 * p[1].get<double>() / z + 239.5, best["center_px"]["v"].get<double>(), 0.5);
    double norm = 0;
    for (const auto& q : best["pose"]["orientation_wxyz"])
      norm += q.get<double>() * q.get<double>();
    EXPECT_NEAR(norm, 1.0, 1e-9);
    // Ranked best first.
    for (std::size_t k = 1; k < body["grasps"].size(); ++k) {
      EXPECT_GE(body["grasps"][k - 1]["score"].get<double>(),
                body["grasps"][k]["score"].get<double>());
    }
  }
}

TEST_F(GraspsApiTest, PhoxiFrameWithMissingPixelsGivesGrasps) {
  const auto reply = server_->Send(MultipartRequest(
      "/v1/grasps", {{"depth", ReadFileBytes(TestData("gqcnn/phoxi/clutter_depth_0.npy")), "d.npy"},
                     {"intrinsics", ReadFileBytes(TestData("gqcnn/phoxi/phoxi.intr")), "p.intr"}}));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_NEAR(body["image"]["missing_fraction"].get<double>(), 0.31, 0.02);
  EXPECT_FALSE(body["grasps"].empty());
}

TEST_F(GraspsApiTest, RawBodyWithQueryIntrinsicsAndTopK) {
  const auto reply = server_->Send(
      RawRequest("POST", "/v1/grasps?fx=525&fy=525&cx=319.5&cy=239.5&top_k=2", "application/x-npy",
                 ReadFileBytes(TestData("gqcnn/primesense/single_depth_1.npy"))));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_EQ(body["camera"]["source"], "request");
  EXPECT_LE(body["grasps"].size(), 2u);
  EXPECT_FALSE(body["grasps"].empty());
}

TEST_F(GraspsApiTest, Png16InMillimetresGivesTheSameGraspsAsNpy) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  auto depth = io::DecodeDepth(npy);
  ASSERT_TRUE(depth.ok());
  cv::Mat1w mm;
  depth.value().depth_m.convertTo(mm, CV_16U, 1000.0);
  const auto reply_png =
      server_->Send(RawRequest("POST", "/v1/grasps", "image/png", io::EncodePng(mm)));
  const auto reply_npy = server_->Send(RawRequest("POST", "/v1/grasps", "application/x-npy", npy));
  ASSERT_EQ(reply_png.status, 200) << reply_png.body;
  ASSERT_EQ(reply_npy.status, 200) << reply_npy.body;
  EXPECT_EQ(json::parse(reply_png.body)["image"]["format"], "png16");
  // Millimetre rounding moves the fitted floor by ~1e-5 and with it the surface a slice cuts; on
  // this bar grasps one angle step apart nearly tie (scores within 10 %). So each answer's best
  // grasp is one of the other's near-best: at the same place, at most one angle step apart.
  const json png = json::parse(reply_png.body)["grasps"];
  const json npy_grasps = json::parse(reply_npy.body)["grasps"];
  ASSERT_FALSE(png.empty());
  ASSERT_FALSE(npy_grasps.empty());
  const auto best_is_among_near_best = [](const json& best, const json& others) {
    const double best_other = others[0]["score"].get<double>();
    for (const json& g : others) {
      if (g["score"].get<double>() < 0.9 * best_other) break;
      const double angle_step = std::numbers::pi / 16;  // FgeParams{}.num_angles = 16
      const double turn =
          std::fmod(std::abs(g["angle_rad"].get<double>() - best["angle_rad"].get<double>()),
                    std::numbers::pi);
      if (std::abs(g["center_px"]["u"].get<double>() - best["center_px"]["u"].get<double>()) <=
              3.0 &&
          std::abs(g["center_px"]["v"].get<double>() - best["center_px"]["v"].get<double>()) <=
              3.0 &&
          std::min(turn, std::numbers::pi - turn) <= angle_step + 1e-9) {
        return true;
      }
    }
    return false;
  };
  EXPECT_TRUE(best_is_among_near_best(png[0], npy_grasps)) << png.dump() << "\n"
                                                           << npy_grasps.dump();
  EXPECT_TRUE(best_is_among_near_best(npy_grasps[0], png)) << png.dump() << "\n"
                                                           << npy_grasps.dump();
}

// numpy.save of a depth computed in double precision: the same frame as float64 plans the same
// grasps (float -> double -> float is exact); the frame in millimetres is a 400 saying so.
TEST_F(GraspsApiTest, Float64NpyGivesTheSameGraspsAndMillimetresAreRefused) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  const auto depth = io::DecodeDepth(npy);
  ASSERT_TRUE(depth.ok());
  const cv::Mat1f& metres = depth.value().depth_m;
  const std::string shape =
      "(" + std::to_string(metres.rows) + ", " + std::to_string(metres.cols) + ")";
  std::vector<double> as_double(metres.begin(), metres.end());
  const std::string f8 =
      io::test::MakeNpy(io::test::NpyDict("<f8", shape), io::test::ElementBytes(as_double));
  const auto reply_f8 = server_->Send(RawRequest("POST", "/v1/grasps", "application/x-npy", f8));
  const auto reply_f4 = server_->Send(RawRequest("POST", "/v1/grasps", "application/x-npy", npy));
  ASSERT_EQ(reply_f8.status, 200) << reply_f8.body;
  ASSERT_EQ(reply_f4.status, 200) << reply_f4.body;
  EXPECT_EQ(json::parse(reply_f8.body)["grasps"], json::parse(reply_f4.body)["grasps"]);

  for (double& z : as_double) z *= 1000.0;
  const std::string mm =
      io::test::MakeNpy(io::test::NpyDict("<f8", shape), io::test::ElementBytes(as_double));
  const json body = ExpectError(
      server_->Send(RawRequest("POST", "/v1/grasps", "application/x-npy", mm)), 400, "depth");
  EXPECT_NE(body["error"]["message"].get<std::string>().find("divided by 1000"), std::string::npos)
      << body.dump();
}

// Clients that forget the Content-Type: Python's requests.post(url, data=file) sends none, curl
// --data-binary sends application/x-www-form-urlencoded. A body that starts like a depth file
// is read as one; other bodies of those types are still a 415 naming Content-Type.
TEST_F(GraspsApiTest, UntypedDepthBodiesAreReadByTheirMagicBytes) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  const auto typed = server_->Send(RawRequest("POST", "/v1/grasps", "application/x-npy", npy));
  ASSERT_EQ(typed.status, 200) << typed.body;
  for (const std::string type : {"", "application/x-www-form-urlencoded"}) {
    SCOPED_TRACE(type);
    const auto reply = server_->Send(RawRequest("POST", "/v1/grasps", type, npy));
    ASSERT_EQ(reply.status, 200) << reply.body;
    EXPECT_EQ(json::parse(reply.body)["grasps"], json::parse(typed.body)["grasps"]);
  }
  ExpectError(server_->Send(
                  RawRequest("POST", "/v1/grasps", "application/x-www-form-urlencoded", "top_k=3")),
              415, "Content-Type");
  ExpectError(server_->Send(RawRequest("POST", "/v1/grasps", "", "hello")), 415, "Content-Type");
}

TEST_F(GraspsApiTest, OverlayPngHasTheImageSize) {
  for (const std::string& how : {std::string("query"), std::string("accept")}) {
    const std::string target = how == "query" ? "/v1/grasps?format=png" : "/v1/grasps";
    const std::string headers = how == "accept" ? "Accept: image/png\r\n" : "";
    const auto reply = server_->Send(MultipartRequest(
        target,
        {{"depth", ReadFileBytes(TestData("gqcnn/primesense/single_depth_2.npy")), "d.npy"}},
        headers));
    ASSERT_EQ(reply.status, 200) << reply.body;
    EXPECT_EQ(reply.header("Content-Type").value_or(""), "image/png");
    EXPECT_GE(std::stoi(std::string(reply.header("X-Grasp-Count").value_or("0"))), 1);
    const cv::Mat image = cv::imdecode(cv::Mat(1, static_cast<int>(reply.body.size()), CV_8U,
                                               const_cast<char*>(reply.body.data())),
                                       cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(image.empty());
    EXPECT_EQ(image.cols, 640);
    EXPECT_EQ(image.rows, 480);
    EXPECT_EQ(image.channels(), 3);
  }
}

TEST_F(GraspsApiTest, TruncatedNpyIsA4xxWithAClearMessage) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  const auto header_cut =
      server_->Send(MultipartRequest("/v1/grasps", {{"depth", npy.substr(0, 40), "d.npy"}}));
  ExpectError(header_cut, 400, "depth");
  const auto data_cut =
      server_->Send(MultipartRequest("/v1/grasps", {{"depth", npy.substr(0, 5000), "d.npy"}}));
  ExpectError(data_cut, 400, "depth");
}

TEST_F(GraspsApiTest, EightBitPngIsUnsupported) {
  const cv::Mat1b eight(48, 64, uint8_t{100});
  const auto reply =
      server_->Send(MultipartRequest("/v1/grasps", {{"depth", io::EncodePng(eight), "d.png"}}));
  const json body = ExpectError(reply, 415, "depth");
  EXPECT_NE(body["error"]["message"].get<std::string>().find("16-bit"), std::string::npos);
}

TEST_F(GraspsApiTest, AllMissingDepthIsUnprocessable) {
  const cv::Mat1f zeros(48, 64, 0.0f);
  const auto reply =
      server_->Send(RawRequest("POST", "/v1/grasps", "application/x-npy", io::EncodeNpy(zeros)));
  ExpectError(reply, 422);
}

TEST_F(GraspsApiTest, MissingDepthPartNamesTheField) {
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", {{"top_k", "3", ""}})), 400, "depth");
}

TEST_F(GraspsApiTest, BadParametersNameTheirField) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  ExpectError(
      server_->Send(MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"}, {"top_k", "0", ""}})),
      400, "top_k");
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"},
                                                            {"fx", "abc", ""},
                                                            {"fy", "1", ""},
                                                            {"cx", "1", ""},
                                                            {"cy", "1", ""}})),
              400, "fx");
  ExpectError(
      server_->Send(MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"}, {"fx", "500", ""}})),
      400, "fx");
  ExpectError(server_->Send(
                  MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"}, {"colour", "red", ""}})),
              400, "colour");
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps", {{"depth", npy, "d.npy"}, {"strategy", "stiffness", ""}})),
              400, "strategy");
  ExpectError(
      server_->Send(MultipartRequest(
          "/v1/grasps", {{"depth", npy, "d.npy"}, {"intrinsics", "{\"_fx\": 1}", "p.intr"}})),
      400);
  ExpectError(server_->Send(RawRequest("POST", "/v1/grasps", "text/plain", "hello")), 415,
              "Content-Type");
}

// GQ-CNN's segmask on the real clutter frame: the heap's mask without a disc around the best
// unmasked grasp. No grasp may close there any more, and every grasp closes on the mask: its
// centre lies within half an opening of a mask pixel (a grasp around a ring may centre in its
// hole).
TEST_F(GraspsApiTest, SegmaskRestrictsGraspsToTheMaskedRegion) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/phoxi/clutter_depth_0.npy"));
  const std::string intr = ReadFileBytes(TestData("gqcnn/phoxi/phoxi.intr"));
  const auto unmasked = server_->Send(
      MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"}, {"intrinsics", intr, "p.intr"}}));
  ASSERT_EQ(unmasked.status, 200) << unmasked.body;
  const json best = json::parse(unmasked.body)["grasps"].at(0);
  const cv::Point2d taken(best["center_px"]["u"].get<double>(),
                          best["center_px"]["v"].get<double>());

  cv::Mat1b mask = cv::imread(TestData("gqcnn/phoxi/clutter_segmask_0.png"), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(mask.empty());
  constexpr int kHoleRadiusPx = 60;
  cv::circle(mask, cv::Point(static_cast<int>(taken.x), static_cast<int>(taken.y)), kHoleRadiusPx,
             cv::Scalar(0), cv::FILLED);
  cv::Mat1f distance_to_mask;
  cv::distanceTransform(mask == 0, distance_to_mask, cv::DIST_L2, 5);

  const auto reply =
      server_->Send(MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"},
                                                    {"intrinsics", intr, "p.intr"},
                                                    {"segmask", io::EncodePng(mask), "mask.png"},
                                                    {"top_k", "10", ""}}));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_EQ(body["contact_region"]["segmask"], true);
  ASSERT_FALSE(body["grasps"].empty());
  for (const json& g : body["grasps"]) {
    const cv::Point2d c(g["center_px"]["u"].get<double>(), g["center_px"]["v"].get<double>());
    const double half_opening_px = g["opening_px"].get<double>() / 2;
    EXPECT_GT(cv::norm(c - taken), kHoleRadiusPx - half_opening_px)
        << "grasp at (" << c.x << ", " << c.y << ") closes inside the removed disc";
    EXPECT_LE(
        distance_to_mask(static_cast<int>(std::lround(c.y)), static_cast<int>(std::lround(c.x))),
        half_opening_px)
        << "grasp at (" << c.x << ", " << c.y << ") is off the mask";
  }
}

TEST_F(GraspsApiTest, MinDepthKeepsGraspsOffNearSurfaces) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  const auto all = server_->Send(MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"}}));
  ASSERT_EQ(all.status, 200);
  const json best = json::parse(all.body)["grasps"][0];
  // Just beyond the best grasp's surface: that surface (and everything nearer) is off limits.
  const double z = best["pose"]["position_m"][2].get<double>();
  const auto limited = server_->Send(MultipartRequest(
      "/v1/grasps", {{"depth", npy, "d.npy"}, {"min_depth_m", std::to_string(z + 0.05), ""}}));
  ASSERT_EQ(limited.status, 200) << limited.body;
  const json body = json::parse(limited.body);
  EXPECT_DOUBLE_EQ(body["contact_region"]["min_depth_m"].get<double>(),
                   std::stod(std::to_string(z + 0.05)));
  for (const json& g : body["grasps"]) {
    EXPECT_GE(g["pose"]["position_m"][2].get<double>() + 0.02, z + 0.05)
        << "a grasp closes on a surface nearer than min_depth_m";
  }
  // Beyond the floor nothing is allowed: no grasps, not an error.
  const auto none = server_->Send(
      MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"}, {"min_depth_m", "5", ""}}));
  ASSERT_EQ(none.status, 200) << none.body;
  EXPECT_TRUE(json::parse(none.body)["grasps"].empty());
}

TEST_F(GraspsApiTest, BadSegmasksAndMinDepthsNameTheirField) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  const cv::Mat1b small(48, 64, uint8_t{255});
  ExpectError(
      server_->Send(MultipartRequest(
          "/v1/grasps", {{"depth", npy, "d.npy"}, {"segmask", io::EncodePng(small), "m.png"}})),
      422, "segmask");
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps", {{"depth", npy, "d.npy"}, {"segmask", "GIF89a", "m.gif"}})),
              415, "segmask");
  const std::string mask = io::EncodePng(cv::Mat1b(480, 640, uint8_t{255}));
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps", {{"depth", npy, "d.npy"},
                                 {"segmask", mask.substr(0, mask.size() / 2), "m.png"}})),
              400, "segmask");
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps", {{"depth", npy, "d.npy"}, {"min_depth_m", "-0.1", ""}})),
              400, "min_depth_m");
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps", {{"depth", npy, "d.npy"}, {"min_depth_m", "near", ""}})),
              400, "min_depth_m");
}

TEST_F(GraspsApiTest, IntrinsicsOfAnotherImageSizeAreRefused) {
  const auto reply = server_->Send(MultipartRequest(
      "/v1/grasps",
      {{"depth", ReadFileBytes(TestData("gqcnn/phoxi/clutter_depth_0.npy")), "d.npy"},
       {"intrinsics", ReadFileBytes(TestData("gqcnn/primesense/primesense.intr")), "p.intr"}}));
  ExpectError(reply, 422, "intrinsics");
}

// A ROS node sends its CameraInfo as JSON (a form field, no file name): the same camera and the
// same grasps as the .intr file, also as a binned rectified camera; a column-major matrix in "K"
// is refused naming it.
TEST_F(GraspsApiTest, RosCameraInfoIsReadAsTheIntrFile) {
  const std::string npy = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  const auto intr = server_->Send(MultipartRequest(
      "/v1/grasps",
      {{"depth", npy, "d.npy"},
       {"intrinsics", ReadFileBytes(TestData("gqcnn/primesense/primesense.intr")), "p.intr"}}));
  const auto ros = server_->Send(MultipartRequest(
      "/v1/grasps", {{"depth", npy, "d.npy"},
                     {"intrinsics",
                      R"({"header": {"frame_id": "wrist_camera"}, "height": 480, "width": 640,
            "distortion_model": "plumb_bob", "D": [0.0, 0.0, 0.0, 0.0, 0.0],
            "K": [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]})",
                      ""}}));
  ASSERT_EQ(intr.status, 200) << intr.body;
  ASSERT_EQ(ros.status, 200) << ros.body;
  EXPECT_EQ(json::parse(ros.body)["camera"], json::parse(intr.body)["camera"]);
  EXPECT_EQ(json::parse(ros.body)["camera"]["source"], "request");
  EXPECT_EQ(json::parse(ros.body)["grasps"], json::parse(intr.body)["grasps"]);
  // The same camera as a 1280 x 960 sensor's rectified CameraInfo with 2 x 2 binning: P (not
  // the raw image's K) halved.
  const auto binned = server_->Send(
      MultipartRequest("/v1/grasps", {{"depth", npy, "d.npy"},
                                      {"intrinsics",
                                       R"({"height": 960, "width": 1280, "D": [0.05, -0.1, 0, 0, 0],
            "K": [1062.0, 0.0, 645.0, 0.0, 1060.0, 470.0, 0.0, 0.0, 1.0],
            "P": [1050.0, 0.0, 639.0, 0.0, 0.0, 1050.0, 479.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            "binning_x": 2, "binning_y": 2})",
                                       ""}}));
  ASSERT_EQ(binned.status, 200) << binned.body;
  EXPECT_EQ(json::parse(binned.body)["camera"], json::parse(intr.body)["camera"]);
  EXPECT_EQ(json::parse(binned.body)["grasps"], json::parse(intr.body)["grasps"]);
  ExpectError(
      server_->Send(MultipartRequest(
          "/v1/grasps",
          {{"depth", npy, "d.npy"},
           {"intrinsics",
            R"({"height": 480, "width": 640, "K": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})",
            ""}})),
      400, "K");
}

TEST(GraspsApiLimitsTest, ImagesOverThePixelLimitAreRefusedBeforeDecoding) {
  config::ServiceConfig config;
  config.max_image_pixels = 640 * 480 - 1;
  RunningServer server(config);
  const auto reply = server.Send(MultipartRequest(
      "/v1/grasps",
      {{"depth", ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy")), "d.npy"}}));
  ExpectError(reply, 413, "depth");
}

TEST(GraspsApiLimitsTest, BodiesOverTheByteLimitGet413) {
  config::ServiceConfig config;
  config.server.limits.max_body_bytes = 1000;
  RunningServer server(config);
  const auto reply =
      server.Send(RawRequest("POST", "/v1/grasps", "application/x-npy", std::string(5000, 'x')));
  EXPECT_EQ(reply.status, 413);
}

}  // namespace
}  // namespace softgrasp::rest
