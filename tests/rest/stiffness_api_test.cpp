// POST /v1/stiffness and the stiffness strategy of POST /v1/grasps, end to end: a real server
// with the shipped pix2stiffness model, real sockets, a real depth frame. Expected maps come from
// calling the model directly on the same input, expected grasps from the planning engine the
// handler is meant to call (and the evaluation tools call).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "service/core/fge_stiffness.h"
#include "service/core/preprocess.h"
#include "service/engine/engine.h"
#include "service/engine/strategies/deformability.h"
#include "service/io/depth_codec.h"
#include "service/models/stiffness_model.h"
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

const std::string& DepthNpy() {
  static const std::string bytes = ReadFileBytes(TestData("gqcnn/primesense/single_depth_0.npy"));
  return bytes;
}
const std::string& Intrinsics() {
  static const std::string bytes = ReadFileBytes(TestData("gqcnn/primesense/primesense.intr"));
  return bytes;
}

std::vector<FormPart> Upload(std::vector<FormPart> fields = {}) {
  std::vector<FormPart> parts = {{"depth", DepthNpy(), "d.npy"},
                                 {"intrinsics", Intrinsics(), "p.intr"}};
  parts.insert(parts.end(), fields.begin(), fields.end());
  return parts;
}

// The same frame through the library: decode, intrinsics, preprocess, model.
struct Expected {
  core::DepthImage depth;
  core::Camera camera;
  core::Scene scene;
  cv::Mat1f map;
};
const Expected& Direct() {
  static const Expected e = [] {
    Expected x;
    x.depth = io::DecodeDepth(DepthNpy(), {}).value();
    x.camera = io::ParseIntrinsicsJson(Intrinsics()).value();
    x.scene = core::Preprocess(x.depth, x.camera).value();
    x.map = testing::ShippedStiffnessModel()->PredictScene(x.scene);
    return x;
  }();
  return e;
}

// The same frame planned by the engine with the shipped models.
engine::Plan EnginePlan(const std::string& strategy, bool mean_stiffness = false) {
  engine::PlanOptions options;
  options.strategy = strategy;
  options.mean_stiffness = mean_stiffness;
  auto plan = engine::PlanGrasps(
      Direct().depth, Direct().camera, options,
      {testing::ShippedStiffnessModel(), testing::ShippedSegmentationModel(), nullptr});
  EXPECT_TRUE(plan.ok()) << plan.error().message;
  return plan.ok() ? std::move(plan).value() : engine::Plan{};
}

class StiffnessApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    with_model_ = new RunningServer({}, nullptr, nullptr, testing::ShippedStiffnessModel());
    without_model_ = new RunningServer();
  }
  static void TearDownTestSuite() {
    delete with_model_;
    delete without_model_;
    with_model_ = without_model_ = nullptr;
  }
  static RunningServer* with_model_;
  static RunningServer* without_model_;
};
RunningServer* StiffnessApiTest::with_model_ = nullptr;
RunningServer* StiffnessApiTest::without_model_ = nullptr;

void ExpectError(const testing::HttpReply& reply, int status, const std::string& field) {
  EXPECT_EQ(reply.status, status) << reply.body;
  const json body = json::parse(reply.body, nullptr, false);
  ASSERT_TRUE(body.contains("error")) << reply.body;
  EXPECT_FALSE(body["error"]["message"].get<std::string>().empty());
  EXPECT_EQ(body["error"].value("field", ""), field) << reply.body;
}

cv::Mat DecodePng(const std::string& bytes) {
  return cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_UNCHANGED);
}

TEST_F(StiffnessApiTest, DefaultIsAnEightBitPngOfTheModelsMap) {
  const auto reply = with_model_->Send(MultipartRequest("/v1/stiffness", Upload()));
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.header("Content-Type").value_or(""), "image/png");
  EXPECT_EQ(reply.header("Server-Timing").value_or("").rfind("model;dur=", 0), 0u);
  const cv::Mat png = DecodePng(reply.body);
  ASSERT_EQ(png.type(), CV_8UC1);
  ASSERT_EQ(png.size(), Direct().depth.depth_m.size());
  cv::Mat expected;
  Direct().map.convertTo(expected, CV_8U, 255.0);
  EXPECT_LE(cv::norm(png, expected, cv::NORM_INF), 1.0);
  // The bar in the middle of the frame is hard, the floor is background.
  double max_level = 0;
  cv::minMaxLoc(png, nullptr, &max_level);
  EXPECT_GT(max_level, 200);
  EXPECT_EQ(png.at<uchar>(5, 320), 0);
}

TEST_F(StiffnessApiTest, SixteenBitPngAndNpyCarryTheSameMap) {
  const auto png16 =
      with_model_->Send(MultipartRequest("/v1/stiffness", Upload({{"format", "png16", ""}})));
  ASSERT_EQ(png16.status, 200) << png16.body;
  const cv::Mat levels = DecodePng(png16.body);
  ASSERT_EQ(levels.type(), CV_16UC1);
  cv::Mat1f from_png;
  levels.convertTo(from_png, CV_32F, 1.0 / 65535.0);
  EXPECT_LE(cv::norm(from_png, Direct().map, cv::NORM_INF), 1e-4);

  // Raw body with the intrinsics in the query string this time.
  const core::Camera& c = Direct().camera;
  const std::string target = "/v1/stiffness?format=npy&fx=" + std::to_string(c.fx) +
                             "&fy=" + std::to_string(c.fy) + "&cx=" + std::to_string(c.cx) +
                             "&cy=" + std::to_string(c.cy);
  const auto npy = with_model_->Send(RawRequest("POST", target, "application/x-npy", DepthNpy()));
  ASSERT_EQ(npy.status, 200) << npy.body;
  EXPECT_EQ(npy.header("Content-Type").value_or(""), "application/x-npy");
  const auto decoded = io::DecodeDepth(npy.body, {});
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  const cv::Mat1f& values = decoded.value().depth_m;
  ASSERT_EQ(values.size(), Direct().map.size());
  // Zeros (background) decode as missing (NaN) through the depth decoder.
  cv::Mat1f patched = values.clone();
  cv::patchNaNs(patched, 0.0);
  EXPECT_LE(cv::norm(patched, Direct().map, cv::NORM_INF), 1e-3);
}

TEST_F(StiffnessApiTest, ColourPictureIsBlackOnBackgroundAndWarmOnHardParts) {
  const auto reply =
      with_model_->Send(MultipartRequest("/v1/stiffness", Upload({{"format", "color", ""}})));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const cv::Mat picture = DecodePng(reply.body);
  ASSERT_EQ(picture.type(), CV_8UC3);
  ASSERT_EQ(picture.size(), Direct().map.size());
  cv::Point hardest;
  cv::minMaxLoc(Direct().map, nullptr, nullptr, nullptr, &hardest);
  const cv::Vec3b warm = picture.at<cv::Vec3b>(hardest);  // BGR
  EXPECT_GT(warm[2], warm[0]) << "hard should be red-ish";
  EXPECT_EQ(picture.at<cv::Vec3b>(5, 320), cv::Vec3b(0, 0, 0));
}

TEST_F(StiffnessApiTest, WithoutAModelTheMapIsUnavailable) {
  const auto reply = without_model_->Send(MultipartRequest("/v1/stiffness", Upload()));
  ExpectError(reply, 503, "model");
}

TEST_F(StiffnessApiTest, BadRequestsNameTheirField) {
  ExpectError(
      with_model_->Send(MultipartRequest("/v1/stiffness", Upload({{"format", "jpeg", ""}}))), 400,
      "format");
  ExpectError(with_model_->Send(MultipartRequest("/v1/stiffness", Upload({{"top_k", "3", ""}}))),
              400, "top_k");
  ExpectError(with_model_->Send(MultipartRequest(
                  "/v1/stiffness",
                  Upload({{"segmask", io::EncodePng(cv::Mat1b(48, 64, uchar{255})), "m.png"}}))),
              400, "segmask");
  ExpectError(with_model_->Send(MultipartRequest("/v1/stiffness", {{"format", "npy", ""}})), 400,
              "depth");
  ExpectError(with_model_->Send(RawRequest("POST", "/v1/stiffness", "text/plain", "x")), 415,
              "Content-Type");
  const auto truncated = with_model_->Send(
      RawRequest("POST", "/v1/stiffness", "application/x-npy", DepthNpy().substr(0, 100)));
  EXPECT_EQ(truncated.status / 100, 4) << truncated.body;
  const cv::Mat1f zeros(48, 64, 0.0f);
  const auto empty = with_model_->Send(
      RawRequest("POST", "/v1/stiffness", "application/x-npy", io::EncodeNpy(zeros)));
  EXPECT_EQ(empty.status, 422) << empty.body;
}

TEST_F(StiffnessApiTest, StiffnessIsTheDefaultStrategyAndMatchesThePlanner) {
  const auto reply = with_model_->Send(MultipartRequest("/v1/grasps", Upload()));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_EQ(body["strategy"], "stiffness");
  EXPECT_EQ(body["stiffness_model"], "pix2stiffness");
  EXPECT_TRUE(body["timing_ms"]["stiffness"].is_number());
  const engine::Plan plan = EnginePlan("stiffness");
  // The engine ran the model on the same scene: the map /v1/stiffness answers.
  EXPECT_LE(cv::norm(plan.stiffness, Direct().map, cv::NORM_INF), 1e-6);
  const auto& expected = plan.grasps;
  ASSERT_FALSE(expected.empty());
  ASSERT_EQ(body["grasps"].size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE(i);
    const json& g = body["grasps"][i];
    EXPECT_DOUBLE_EQ(g["center_px"]["u"].get<double>(), expected[i].grasp.center_u_px);
    EXPECT_DOUBLE_EQ(g["center_px"]["v"].get<double>(), expected[i].grasp.center_v_px);
    EXPECT_DOUBLE_EQ(g["angle_rad"].get<double>(), expected[i].grasp.angle_rad);
    EXPECT_NEAR(g["mean_stiffness"].get<double>(), expected[i].grasp.mean_stiffness, 1e-9);
  }
  // Best first: the top grasp is on the hard bar.
  EXPECT_GT(body["grasps"][0]["mean_stiffness"].get<double>(), 0.8);
}

TEST_F(StiffnessApiTest, ClassicStrategyRunsTheModelOnlyWhenMeanStiffnessIsAskedFor) {
  const auto plain =
      with_model_->Send(MultipartRequest("/v1/grasps", Upload({{"strategy", "fge", ""}})));
  ASSERT_EQ(plain.status, 200) << plain.body;
  const json plain_body = json::parse(plain.body);
  EXPECT_FALSE(plain_body["timing_ms"].contains("stiffness")) << "the model ran for nothing";
  ASSERT_FALSE(plain_body["grasps"].empty());
  for (const json& g : plain_body["grasps"]) EXPECT_TRUE(g["mean_stiffness"].is_null());

  const auto reply = with_model_->Send(MultipartRequest(
      "/v1/grasps", Upload({{"strategy", "fge", ""}, {"mean_stiffness", "true", ""}})));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_EQ(body["strategy"], "fge");
  EXPECT_TRUE(body["timing_ms"]["stiffness"].is_number());
  ASSERT_EQ(body["grasps"].size(), plain_body["grasps"].size());
  const engine::Plan plan = EnginePlan("fge", /*mean_stiffness=*/true);
  ASSERT_EQ(body["grasps"].size(), plan.grasps.size());
  for (std::size_t i = 0; i < plan.grasps.size(); ++i) {
    const core::Grasp& expected = plan.grasps[i].grasp;
    // The mean over the grasp's contact surface, recomputed here from the model's map.
    const double mean = core::ContactMeanStiffness(Direct().scene, Direct().map, expected);
    EXPECT_DOUBLE_EQ(body["grasps"][i]["score"].get<double>(), expected.score);
    ASSERT_TRUE(std::isfinite(mean));
    EXPECT_NEAR(body["grasps"][i]["mean_stiffness"].get<double>(), mean, 1e-9);
  }
}

TEST_F(StiffnessApiTest, WithoutAModelGraspsUseFgeAndReportNoStiffness) {
  const auto reply = without_model_->Send(MultipartRequest("/v1/grasps", Upload()));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_EQ(body["strategy"], "fge");
  EXPECT_TRUE(body["stiffness_model"].is_null());
  ASSERT_FALSE(body["grasps"].empty());
  EXPECT_TRUE(body["grasps"][0]["mean_stiffness"].is_null());
  ExpectError(
      without_model_->Send(MultipartRequest("/v1/grasps", Upload({{"strategy", "stiffness", ""}}))),
      400, "strategy");
  ExpectError(without_model_->Send(MultipartRequest(
                  "/v1/grasps", Upload({{"format", "png", ""}, {"overlay", "stiffness", ""}}))),
              400, "overlay");
  ExpectError(with_model_->Send(MultipartRequest("/v1/grasps", Upload({{"strategy", "best", ""}}))),
              400, "strategy");
  ExpectError(without_model_->Send(
                  MultipartRequest("/v1/grasps", Upload({{"mean_stiffness", "true", ""}}))),
              400, "mean_stiffness");
  ExpectError(
      with_model_->Send(MultipartRequest("/v1/grasps", Upload({{"mean_stiffness", "yes", ""}}))),
      400, "mean_stiffness");
}

TEST_F(StiffnessApiTest, OverlayCanShowTheStiffnessMapUnderTheGrasps) {
  const auto map_only = with_model_->Send(MultipartRequest(
      "/v1/grasps",
      Upload({{"format", "png", ""}, {"overlay", "stiffness", ""}, {"draw", "none", ""}})));
  ASSERT_EQ(map_only.status, 200) << map_only.body;
  const auto colour =
      with_model_->Send(MultipartRequest("/v1/stiffness", Upload({{"format", "color", ""}})));
  ASSERT_EQ(colour.status, 200);
  const cv::Mat background = DecodePng(map_only.body);
  EXPECT_EQ(cv::norm(background, DecodePng(colour.body), cv::NORM_INF), 0.0);

  const auto drawn = with_model_->Send(MultipartRequest(
      "/v1/grasps", Upload({{"format", "png", ""}, {"overlay", "stiffness", ""}})));
  ASSERT_EQ(drawn.status, 200);
  EXPECT_NE(drawn.header("X-Grasp-Count").value_or("0"), "0");
  const cv::Mat with_grasps = DecodePng(drawn.body);
  ASSERT_EQ(with_grasps.size(), background.size());
  // The best grasp's centre is drawn in green over the map.
  const json grasps = json::parse(with_model_->Send(MultipartRequest("/v1/grasps", Upload())).body);
  const cv::Point centre(
      static_cast<int>(std::lround(grasps["grasps"][0]["center_px"]["u"].get<double>())),
      static_cast<int>(std::lround(grasps["grasps"][0]["center_px"]["v"].get<double>())));
  EXPECT_EQ(with_grasps.at<cv::Vec3b>(centre), cv::Vec3b(0, 255, 0));
  EXPECT_GT(cv::norm(with_grasps, background, cv::NORM_L1), 0.0);
}

TEST_F(StiffnessApiTest, InfoListsTheModelAndBothStrategies) {
  const json with = json::parse(with_model_->Send(RawRequest("GET", "/v1/info")).body);
  ASSERT_EQ(with["models"].size(), 1u);
  EXPECT_EQ(with["models"][0]["name"], "pix2stiffness");
  EXPECT_EQ(with["models"][0]["input_size"], testing::ShippedStiffnessModel()->input_size());
  EXPECT_EQ(with["strategies"], json({"fge", "stiffness"}));
  EXPECT_EQ(with["default_strategy"], "stiffness");
  const json without = json::parse(without_model_->Send(RawRequest("GET", "/v1/info")).body);
  EXPECT_TRUE(without["models"].empty());
  EXPECT_EQ(without["strategies"], json({"fge"}));
  EXPECT_EQ(without["default_strategy"], "fge");
}

TEST(StiffnessModelConfigTest, ConfigFileEnvironmentAndFlag) {
  auto from_json = config::ApplyConfigJson({}, R"({"models": {"stiffness": "/srv/m.pt"}})");
  ASSERT_TRUE(from_json.ok());
  EXPECT_EQ(from_json.value().stiffness_model, "/srv/m.pt");
  EXPECT_EQ(config::ApplyConfigJson({}, R"({"models": {"stiffness": 1}})").error().field,
            "models.stiffness");
  ::setenv("SOFTGRASP_STIFFNESS_MODEL", "none", 1);
  EXPECT_EQ(config::ParseCommandLine({}).value().config.stiffness_model, "none");
  EXPECT_EQ(config::ParseCommandLine({"--stiffness-model", "/f.pt"}).value().config.stiffness_model,
            "/f.pt");
  ::unsetenv("SOFTGRASP_STIFFNESS_MODEL");
  EXPECT_FALSE(config::ParseCommandLine({"--stiffness-model"}).ok());
  EXPECT_EQ(json::parse(config::ConfigToJson(
                config::ParseCommandLine({"--stiffness-model", "/m"}).value().config))["models"]
                                                                                      ["stiffness"],
            "/m");
}

TEST(StiffnessModelConfigTest, DefaultIsTheShippedModelNextToTheExecutable) {
  namespace fs = std::filesystem;
  char pattern[] = "/tmp/softgrasp-models-XXXXXX";
  ASSERT_NE(::mkdtemp(pattern), nullptr);
  const fs::path prefix = pattern;
  const auto touch = [](const fs::path& file) {
    fs::create_directories(file.parent_path());
    std::ofstream(file) << "x";
  };
  EXPECT_EQ(config::DefaultStiffnessModel((prefix / "service" / "softgrasp-server").string()),
            "none");
  touch(prefix / "share" / "softgrasp" / "models" / "pix2stiffness.pt");
  EXPECT_EQ(config::DefaultStiffnessModel((prefix / "bin" / "softgrasp-server").string()),
            (prefix / "share" / "softgrasp" / "models" / "pix2stiffness.pt").string());
  touch(prefix / "models" / "pix2stiffness.pt");
  EXPECT_EQ(config::DefaultStiffnessModel((prefix / "service" / "softgrasp-server").string()),
            (prefix / "models" / "pix2stiffness.pt").string());
  fs::remove_all(prefix);
}

// Every registered strategy: POST /v1/grasps answers exactly what the engine plans on the same
// frame (the handler decodes, calls the engine and encodes; the evaluation tools call the same
// engine, tests/models/train_cli_test.cpp).
TEST(GraspsHandlerTest, EveryStrategyAnswersWhatTheEnginePlans) {
  const engine::Models models{testing::ShippedStiffnessModel(), testing::ShippedSegmentationModel(),
                              testing::ShippedGqcnnModel()};
  const RunningServer server({}, nullptr, nullptr, models.stiffness, models.segmentation,
                             models.gqcnn);
  for (const engine::Strategy* strategy : engine::Strategies()) {
    const engine::StrategyInfo& info = strategy->info();
    SCOPED_TRACE(info.name);
    ASSERT_TRUE(engine::Serves(models, *strategy)) << "is the model for it shipped?";
    const auto reply = server.Send(MultipartRequest(
        "/v1/grasps", Upload({{"strategy", info.name, ""}, {"instances", "true", ""}})));
    ASSERT_EQ(reply.status, 200) << reply.body;
    const json body = json::parse(reply.body);
    EXPECT_EQ(body["strategy"], info.name);
    engine::PlanOptions options;
    options.strategy = info.name;
    options.report_instances = true;
    auto plan = engine::PlanGrasps(Direct().depth, Direct().camera, options, models);
    ASSERT_TRUE(plan.ok()) << plan.error().message;
    const auto& expected = plan.value().grasps;
    ASSERT_FALSE(expected.empty());
    ASSERT_EQ(body["grasps"].size(), expected.size());
    EXPECT_EQ(body["floor"]["d_m"].get<double>(), plan.value().scene.floor.d);
    for (std::size_t i = 0; i < expected.size(); ++i) {
      SCOPED_TRACE(i);
      const json& g = body["grasps"][i];
      const core::Grasp& e = expected[i].grasp;
      EXPECT_EQ(g["center_px"]["u"].get<double>(), e.center_u_px);
      EXPECT_EQ(g["center_px"]["v"].get<double>(), e.center_v_px);
      EXPECT_EQ(g["angle_rad"].get<double>(), e.angle_rad);
      EXPECT_EQ(g["score"].get<double>(), e.score);
      EXPECT_EQ(g["opening_m"].get<double>(), e.opening_m);
      ASSERT_TRUE(expected[i].instance_id.has_value());
      EXPECT_EQ(g["instance_id"].get<int>(), *expected[i].instance_id);
      // Each strategy's details under its key, null under the others' keys.
      for (const engine::Strategy* other : engine::Strategies()) {
        const std::string key = other->grasp_details_key();
        if (key.empty()) continue;
        EXPECT_EQ(g[key].is_null(), other != strategy || expected[i].details == nullptr) << key;
      }
    }
    EXPECT_EQ(body.contains("target"), engine::TargetChoiceOf(plan.value()) != nullptr);
  }
}

}  // namespace
}  // namespace softgrasp::rest
