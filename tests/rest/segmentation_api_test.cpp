// POST /v1/segmentation and the instance options of POST /v1/grasps (instances, target, labels),
// end to end over real sockets with the PCL baseline, on analytic scenes (boxes standing apart on
// a table) whose box top centres are known in closed form. With a segmentation model file in
// models/ (or SOFTGRASP_TEST_SEGMENTATION_MODEL), the model's answers are checked too.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "service/models/segmentation_model.h"
#include "tests/rest/server_fixture.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;
using testing::FormPart;
using testing::HttpReply;
using testing::MultipartRequest;
using testing::RawRequest;
using testing::RunningServer;

// Three boxes well apart (further than any clustering tolerance), graspable across.
softgrasp::testing::SceneSpec ThreeBoxes() {
  softgrasp::testing::SceneSpec spec;
  spec.boxes = {
      {-0.12, -0.06, 0.030, 0.080, 0.040, 0.3, 1},
      {0.06, -0.08, 0.030, 0.060, 0.055, 1.2, 2},
      {0.02, 0.10, 0.035, 0.070, 0.030, 0.0, 3},
  };
  return spec;
}

struct Frame {
  softgrasp::testing::SceneSpec spec;
  softgrasp::testing::SyntheticScene scene;
  std::string npy;
};

Frame MakeFrame(const softgrasp::testing::SceneSpec& spec) {
  Frame f{spec, softgrasp::testing::RenderScene(spec), {}};
  f.npy = io::EncodeNpy(f.scene.depth.depth_m);
  return f;
}

const Frame& Boxes() {
  static const Frame frame = MakeFrame(ThreeBoxes());
  return frame;
}

std::vector<FormPart> Upload(const Frame& f, std::vector<FormPart> fields = {}) {
  const core::Camera& c = f.scene.camera;
  std::vector<FormPart> parts = {{"depth", f.npy, "d.npy"},
                                 {"fx", std::to_string(c.fx), ""},
                                 {"fy", std::to_string(c.fy), ""},
                                 {"cx", std::to_string(c.cx), ""},
                                 {"cy", std::to_string(c.cy), ""}};
  parts.insert(parts.end(), fields.begin(), fields.end());
  return parts;
}

cv::Mat DecodePng(const std::string& bytes) {
  return cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_UNCHANGED);
}

json ParseOk(const HttpReply& reply) {
  EXPECT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.header("Content-Type").value_or(""), "application/json");
  return json::parse(reply.body);
}

void ExpectError(const HttpReply& reply, int status, const std::string& field) {
  EXPECT_EQ(reply.status, status) << reply.body;
  const json body = json::parse(reply.body, nullptr, false);
  ASSERT_TRUE(body.contains("error")) << reply.body;
  EXPECT_FALSE(body["error"]["message"].get<std::string>().empty());
  EXPECT_EQ(body["error"].value("field", ""), field) << reply.body;
}

// The synthetic box id (SyntheticScene::object_id) that covers most of instance `id`.
int BoxOfInstance(const cv::Mat1w& labels, int id, const cv::Mat1i& object_id) {
  std::map<int, int> votes;
  for (int v = 0; v < labels.rows; ++v) {
    for (int u = 0; u < labels.cols; ++u) {
      if (labels(v, u) == id) ++votes[object_id(v, u)];
    }
  }
  int best = -2, best_votes = 0;
  for (const auto& [box, n] : votes) {
    if (n > best_votes) best = box, best_votes = n;
  }
  return best;
}

int BoxAt(const Frame& f, const json& grasp) {
  const int u = static_cast<int>(std::lround(grasp["center_px"]["u"].get<double>()));
  const int v = static_cast<int>(std::lround(grasp["center_px"]["v"].get<double>()));
  return f.scene.object_id(std::clamp(v, 0, f.scene.object_id.rows - 1),
                           std::clamp(u, 0, f.scene.object_id.cols - 1));
}

// The synthetic boxes whose surface lies above a grasp's contact height inside its closing
// region (|a| <= opening / 2, |b| <= finger width / 2 around the centre, pixel-centre rule).
std::set<int> ContactBoxes(const Frame& f, const json& g) {
  const double u0 = g["center_px"]["u"], v0 = g["center_px"]["v"], angle = g["angle_rad"];
  const double half_a = g["opening_px"].get<double>() / 2;
  const double half_b = g["finger_width_px"].get<double>() / 2;
  const double contact = g["contact_height_m"];
  std::set<int> ids;
  for (int v = 0; v < f.scene.object_id.rows; ++v) {
    for (int u = 0; u < f.scene.object_id.cols; ++u) {
      const double du = u - u0, dv = v - v0;
      const double a = du * std::cos(angle) + dv * std::sin(angle);
      const double b = -du * std::sin(angle) + dv * std::cos(angle);
      if (std::abs(a) <= half_a && std::abs(b) <= half_b && f.scene.height_m(v, u) > contact) {
        ids.insert(f.scene.object_id(v, u));
      }
    }
  }
  return ids;
}

class SegmentationApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new RunningServer(); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static HttpReply Segment(const std::vector<FormPart>& parts, const std::string& query = "") {
    return server_->Send(MultipartRequest("/v1/segmentation" + query, parts));
  }
  static cv::Mat1w Labels(const Frame& f) {
    const auto reply = Segment(Upload(f, {{"format", "labels", ""}}));
    EXPECT_EQ(reply.status, 200) << reply.body;
    const cv::Mat png = DecodePng(reply.body);
    EXPECT_EQ(png.type(), CV_16UC1);
    return png;
  }
  static RunningServer* server_;
};
RunningServer* SegmentationApiTest::server_ = nullptr;

TEST_F(SegmentationApiTest, PclFindsEveryBoxAtItsTopCentre) {
  const Frame& f = Boxes();
  const json body = ParseOk(Segment(Upload(f)));
  EXPECT_EQ(body["method"], "pcl");
  EXPECT_TRUE(body["segmentation_model"].is_null());
  EXPECT_EQ(body["image"]["width"], 640);
  EXPECT_EQ(body["image"]["height"], 480);
  for (const char* key : {"decode", "preprocess", "segment", "describe", "total"}) {
    EXPECT_TRUE(body["timing_ms"][key].is_number()) << key;
  }
  RecordProperty("pcl_segment_ms_640x480",
                 std::to_string(body["timing_ms"]["segment"].get<double>()));
  const json& instances = body["instances"];
  ASSERT_EQ(instances.size(), f.spec.boxes.size()) << body.dump(1);
  std::set<int> matched_boxes;
  for (std::size_t i = 0; i < instances.size(); ++i) {
    const json& inst = instances[i];
    EXPECT_EQ(inst["id"], static_cast<int>(i) + 1);
    EXPECT_GE(inst["score"].get<double>(), 0.0);
    EXPECT_LE(inst["score"].get<double>(), 1.0);
    EXPECT_GT(inst["area_px"].get<int>(), 300);
    EXPECT_TRUE(inst["mean_deformability"].is_null());  // PCL estimates none
    EXPECT_TRUE(inst["mean_stiffness"].is_null());      // no stiffness model
    const auto c = inst["centroid_m"].get<std::vector<double>>();
    const auto bbox = inst["bbox_px"].get<std::vector<int>>();
    const auto px = inst["centroid_px"].get<std::vector<double>>();
    ASSERT_EQ(c.size(), 3u);
    ASSERT_EQ(bbox.size(), 4u);
    EXPECT_GE(px[0], bbox[0]);
    EXPECT_LE(px[0], bbox[0] + bbox[2]);
    EXPECT_GE(px[1], bbox[1]);
    EXPECT_LE(px[1], bbox[1] + bbox[3]);
    // The nearest analytic box top centre, in the camera frame.
    double best = 1e9;
    const softgrasp::testing::Box* nearest = nullptr;
    for (const auto& box : f.spec.boxes) {
      const cv::Point3d top =
          softgrasp::testing::TableToCamera(f.spec, box.x_m, box.y_m, box.height_m);
      const double d = std::hypot(c[0] - top.x, c[1] - top.y, c[2] - top.z);
      if (d < best) best = d, nearest = &box;
    }
    ASSERT_NE(nearest, nullptr);
    EXPECT_LT(best, 0.01) << "instance " << inst["id"] << " centroid " << c[0] << " " << c[1] << " "
                          << c[2];
    EXPECT_NEAR(inst["top_height_m"].get<double>(), nearest->height_m, 0.004);
    matched_boxes.insert(nearest->id);
  }
  EXPECT_EQ(matched_boxes.size(), f.spec.boxes.size());  // one instance per box
}

TEST_F(SegmentationApiTest, LabelsPngRoundTripsTheJsonIds) {
  const Frame& f = Boxes();
  const json body = ParseOk(Segment(Upload(f)));
  const auto reply = Segment(Upload(f, {{"format", "labels", ""}}));
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.header("Content-Type").value_or(""), "image/png");
  EXPECT_EQ(reply.header("X-Instance-Count").value_or(""),
            std::to_string(body["instances"].size()));
  const cv::Mat png = DecodePng(reply.body);
  ASSERT_EQ(png.type(), CV_16UC1);
  ASSERT_EQ(png.cols, 640);
  ASSERT_EQ(png.rows, 480);
  const cv::Mat1w labels = png;
  double max_id = 0;
  cv::minMaxLoc(labels, nullptr, &max_id);
  EXPECT_EQ(static_cast<std::size_t>(max_id), body["instances"].size());
  for (const json& inst : body["instances"]) {
    const int id = inst["id"];
    EXPECT_EQ(cv::countNonZero(labels == id), inst["area_px"].get<int>()) << id;
    const auto bbox = inst["bbox_px"].get<std::vector<int>>();
    const cv::Rect tight = cv::boundingRect(cv::Mat1b(labels == id));
    EXPECT_EQ(tight, cv::Rect(bbox[0], bbox[1], bbox[2], bbox[3])) << id;
    // Every instance is one box, and a different one.
    EXPECT_GT(BoxOfInstance(labels, id, f.scene.object_id), 0);
  }
  // The table is background.
  EXPECT_EQ(labels(5, 5), 0);
}

TEST_F(SegmentationApiTest, OverlayIsAColourPngOfTheImageSize) {
  const auto reply = Segment(Upload(Boxes(), {{"format", "overlay", ""}}));
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.header("Content-Type").value_or(""), "image/png");
  const cv::Mat png = DecodePng(reply.body);
  ASSERT_EQ(png.type(), CV_8UC3);
  EXPECT_EQ(png.cols, 640);
  EXPECT_EQ(png.rows, 480);
  // Instances are coloured, the table grey.
  const cv::Vec3b table = png.at<cv::Vec3b>(5, 5);
  EXPECT_EQ(table[0], table[1]);
  EXPECT_EQ(table[1], table[2]);
  const cv::Point2d top = softgrasp::testing::ProjectTablePoint(Boxes().spec, 0.02, 0.10, 0.03);
  const cv::Vec3b box = png.at<cv::Vec3b>(cvRound(top.y) + 12, cvRound(top.x));
  EXPECT_FALSE(box[0] == box[1] && box[1] == box[2]);
}

TEST_F(SegmentationApiTest, EmptyTableGivesZeroInstances) {
  const Frame table = MakeFrame(softgrasp::testing::SceneSpec{});
  const json body = ParseOk(Segment(Upload(table)));
  EXPECT_EQ(body["instances"], json::array());
  const auto labels = Segment(Upload(table, {{"format", "labels", ""}}));
  ASSERT_EQ(labels.status, 200);
  EXPECT_EQ(cv::countNonZero(DecodePng(labels.body)), 0);
  EXPECT_EQ(Segment(Upload(table, {{"format", "overlay", ""}})).status, 200);
}

TEST_F(SegmentationApiTest, BadDepthGetsExactlyWhatGraspsGives) {
  cv::Mat1f zeros(48, 64, 0.0f);
  const std::string truncated = Boxes().npy.substr(0, 200);
  const std::vector<std::pair<std::string, std::string>> bodies = {
      {"application/x-npy", truncated},
      {"application/x-npy", io::EncodeNpy(zeros)},                // all missing: nothing to fit
      {"image/png", io::EncodePng(cv::Mat1b(10, 10, uchar{7}))},  // 8-bit PNG
      {"application/x-npy", "not npy"},
      {"text/plain", "hello"},
  };
  for (const auto& [type, bytes] : bodies) {
    const auto grasps = server_->Send(RawRequest("POST", "/v1/grasps", type, bytes));
    const auto segmentation = server_->Send(RawRequest("POST", "/v1/segmentation", type, bytes));
    EXPECT_GE(grasps.status, 400);
    EXPECT_LT(grasps.status, 500);
    EXPECT_EQ(segmentation.status, grasps.status) << segmentation.body;
    EXPECT_EQ(json::parse(segmentation.body), json::parse(grasps.body));
  }
  const auto no_depth = server_->Send(MultipartRequest("/v1/segmentation", {{"fx", "500", ""}}));
  ExpectError(no_depth, 400, "depth");
  // Unknown fields and values name the field, as /v1/grasps does.
  ExpectError(Segment(Upload(Boxes(), {{"method", "magic", ""}})), 400, "method");
  ExpectError(Segment(Upload(Boxes(), {{"format", "gif", ""}})), 400, "format");
  ExpectError(Segment(Upload(Boxes(), {{"top_k", "3", ""}})), 400, "top_k");
  ExpectError(Segment(Upload(Boxes(), {{"encoding", "png16", ""}})), 400, "encoding");
  ExpectError(Segment(Upload(Boxes(), {{"segmask", "x", "m.png"}})), 400, "segmask");
}

TEST_F(SegmentationApiTest, ModelMethodWithoutAModelIsUnavailable) {
  ExpectError(Segment(Upload(Boxes(), {{"method", "model", ""}})), 503, "method");
  ExpectError(Segment(Upload(Boxes(), {{"method", "fused", ""}})), 503, "method");
  // Deformability is the model's: a 400 for method=pcl, a 503 when no model could serve it.
  ExpectError(Segment(Upload(Boxes(), {{"method", "pcl", ""}, {"format", "deformability", ""}})),
              400, "format");
  ExpectError(Segment(Upload(Boxes(), {{"format", "deformability", ""}})), 503, "format");
  // The same rules on /v1/grasps.
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps",
                  Upload(Boxes(), {{"instances", "true", ""}, {"segmentation", "model", ""}}))),
              503, "segmentation");
  // Info says what serves.
  const json info = json::parse(server_->Send(RawRequest("GET", "/v1/info")).body);
  EXPECT_EQ(info["segmentation_methods"], json::array({"pcl"}));
  EXPECT_EQ(info["default_segmentation_method"], "pcl");
}

TEST_F(SegmentationApiTest, DefaultGraspsCarryNoInstancesAndDoNotSegment) {
  const json body = ParseOk(
      server_->Send(MultipartRequest("/v1/grasps", Upload(Boxes(), {{"strategy", "fge", ""}}))));
  ASSERT_FALSE(body["grasps"].empty());
  EXPECT_TRUE(body["segmentation"].is_null());
  EXPECT_FALSE(body["timing_ms"].contains("segmentation"));
  for (const json& g : body["grasps"]) {
    EXPECT_TRUE(g["instance_id"].is_null());
    EXPECT_TRUE(g["instance_deformability"].is_null());
  }
}

TEST_F(SegmentationApiTest, GraspsReportTheInstanceUnderTheirCentre) {
  const Frame& f = Boxes();
  const cv::Mat1w labels = Labels(f);
  const json body = ParseOk(server_->Send(
      MultipartRequest("/v1/grasps", Upload(f, {{"instances", "true", ""}, {"top_k", "10", ""}}))));
  EXPECT_EQ(body["segmentation"]["source"], "pcl");
  EXPECT_EQ(body["segmentation"]["instances"], 3);
  EXPECT_TRUE(body["timing_ms"]["segmentation"].is_number());
  ASSERT_FALSE(body["grasps"].empty());
  std::set<int> seen;
  for (const json& g : body["grasps"]) {
    const int id = g["instance_id"];
    const int u = static_cast<int>(std::lround(g["center_px"]["u"].get<double>()));
    const int v = static_cast<int>(std::lround(g["center_px"]["v"].get<double>()));
    EXPECT_EQ(id, labels(v, u));
    ASSERT_GT(id, 0) << g.dump();  // every grasp here is on a box
    EXPECT_EQ(BoxOfInstance(labels, id, f.scene.object_id), BoxAt(f, g));
    EXPECT_TRUE(g["instance_deformability"].is_null());  // PCL: no deformability
    seen.insert(id);
  }
  EXPECT_GE(seen.size(), 2u);
}

TEST_F(SegmentationApiTest, TargetRestrictsGraspsToThatBox) {
  const Frame& f = Boxes();
  const cv::Mat1w labels = Labels(f);
  for (int target = 1; target <= 3; ++target) {
    const int box = BoxOfInstance(labels, target, f.scene.object_id);
    const json body = ParseOk(server_->Send(MultipartRequest(
        "/v1/grasps", Upload(f, {{"target", std::to_string(target), ""}, {"top_k", "10", ""}}))));
    EXPECT_EQ(body["contact_region"]["target"], target);
    ASSERT_FALSE(body["grasps"].empty()) << "target " << target;
    for (const json& g : body["grasps"]) {
      EXPECT_EQ(g["instance_id"], target);
      EXPECT_EQ(BoxAt(f, g), box) << g.dump();
    }
  }
}

TEST_F(SegmentationApiTest, TargetPxNamesTheObjectUnderThePixel) {
  const Frame& f = Boxes();
  const cv::Mat1w labels = Labels(f);
  for (int target = 1; target <= 3; ++target) {
    const cv::Moments m = cv::moments(labels == target, true);
    ASSERT_GT(m.m00, 0);
    const int u = static_cast<int>(m.m10 / m.m00), v = static_cast<int>(m.m01 / m.m00);
    ASSERT_EQ(labels(v, u), target);
    const json body = ParseOk(server_->Send(MultipartRequest(
        "/v1/grasps", Upload(f, {{"target_px", std::to_string(u) + "," + std::to_string(v), ""},
                                 {"top_k", "10", ""}}))));
    EXPECT_EQ(body["contact_region"]["target"], target);
    ASSERT_FALSE(body["grasps"].empty()) << "target " << target;
    for (const json& g : body["grasps"]) EXPECT_EQ(g["instance_id"], target);
  }
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"target_px", "5,5", ""}}))),
              422, "target_px");  // the table
  for (const char* bad : {"5", "5,", "1.5,3", "-1,3", "640,3", "3,480", "a,b"}) {
    ExpectError(server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"target_px", bad, ""}}))),
                400, "target_px");
  }
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps", Upload(f, {{"target_px", "5,5", ""}, {"target", "1", ""}}))),
              400, "target_px");
}

TEST_F(SegmentationApiTest, TargetOnUploadedLabelsUsesThemAsGiven) {
  const Frame& f = Boxes();
  const auto labels_png = Segment(Upload(f, {{"format", "labels", ""}})).body;
  const cv::Mat1w labels = DecodePng(labels_png);
  const int box = BoxOfInstance(labels, 2, f.scene.object_id);
  const json body = ParseOk(server_->Send(MultipartRequest(
      "/v1/grasps", Upload(f, {{"labels", labels_png, "labels.png"}, {"target", "2", ""}}))));
  EXPECT_EQ(body["segmentation"]["source"], "labels");
  EXPECT_FALSE(body["timing_ms"].contains("segmentation"));
  ASSERT_FALSE(body["grasps"].empty());
  for (const json& g : body["grasps"]) {
    EXPECT_EQ(g["instance_id"], 2);
    EXPECT_EQ(BoxAt(f, g), box);
  }
  // Only box 1 labelled by the client (its own ids, any value): grasps only there.
  cv::Mat1w one(labels.size(), std::uint16_t{0});
  one.setTo(7, labels == 1);
  const json only = ParseOk(server_->Send(MultipartRequest(
      "/v1/grasps", Upload(f, {{"labels", io::EncodePng(one), "l.png"}, {"target", "7", ""}}))));
  ASSERT_FALSE(only["grasps"].empty());
  for (const json& g : only["grasps"]) EXPECT_EQ(g["instance_id"], 7);
}

TEST_F(SegmentationApiTest, BadTargetsAndLabelsNameTheirField) {
  const Frame& f = Boxes();
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"target", "9", ""}}))), 422,
              "target");
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"target", "0", ""}}))), 400,
              "target");
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"target", "1.5", ""}}))),
              400, "target");
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"instances", "yes", ""}}))),
              400, "instances");
  const Frame table = MakeFrame(softgrasp::testing::SceneSpec{});
  ExpectError(server_->Send(MultipartRequest("/v1/grasps", Upload(table, {{"target", "1", ""}}))),
              422, "target");
  const std::string small = io::EncodePng(cv::Mat1w(10, 10, std::uint16_t{1}));
  ExpectError(
      server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"labels", small, "l.png"}}))), 422,
      "labels");
  ExpectError(server_->Send(MultipartRequest(
                  "/v1/grasps",
                  Upload(f, {{"labels", io::EncodePng(cv::Mat1b(480, 640, uchar{1})), "l.png"}}))),
              415, "labels");
  ExpectError(
      server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"labels", f.npy, "l.npy"}}))), 415,
      "labels");
}

// ---- configuration ----

TEST_F(SegmentationApiTest, DeformabilityStrategyNeedsTheSegmentationModel) {
  const Frame& f = Boxes();
  ExpectError(
      server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"strategy", "deformability", ""}}))),
      400, "strategy");
  ExpectError(
      server_->Send(MultipartRequest("/v1/grasps", Upload(f, {{"overlay", "deformability", ""}}))),
      400, "overlay");
  const json info = json::parse(server_->Send(RawRequest("GET", "/v1/info")).body);
  EXPECT_EQ(info["strategies"], json({"fge"}));
  EXPECT_EQ(info["default_strategy"], "fge");
  EXPECT_EQ(info["target_policies"], json({"highest", "least_deformable"}));
  EXPECT_EQ(info["defaults"]["deformability"]["num_slices"], 5);
}

TEST(SegmentationModelConfigTest, FileEnvironmentAndFlagSetTheModel) {
  auto from_file = config::ApplyConfigJson({}, R"({"models": {"segmentation": "/a.pt"}})");
  ASSERT_TRUE(from_file.ok()) << from_file.error().message;
  EXPECT_EQ(from_file.value().segmentation_model, "/a.pt");
  EXPECT_EQ(config::ApplyConfigJson({}, R"({"models": {"segmentation": 3}})").error().field,
            "models.segmentation");
  ::setenv("SOFTGRASP_SEGMENTATION_MODEL", "none", 1);
  EXPECT_EQ(config::ParseCommandLine({}).value().config.segmentation_model, "none");
  EXPECT_EQ(
      config::ParseCommandLine({"--segmentation-model", "/f.pt"}).value().config.segmentation_model,
      "/f.pt");
  ::unsetenv("SOFTGRASP_SEGMENTATION_MODEL");
  EXPECT_EQ(config::ParseCommandLine({}).value().config.segmentation_model,
            "");  // main picks the default
  EXPECT_FALSE(config::ParseCommandLine({"--segmentation-model"}).ok());
  EXPECT_EQ(
      json::parse(config::ConfigToJson(
          config::ParseCommandLine({"--segmentation-model", "/m"}).value().config))["models"]
                                                                                   ["segmentation"],
      "/m");
}

TEST(SegmentationModelConfigTest, DefaultIsTheShippedModelNextToTheExecutableElseNone) {
  namespace fs = std::filesystem;
  const softgrasp::testing::TempDir temp("segmentation-models");
  const fs::path& prefix = temp.path();
  const auto touch = [](const fs::path& file) {
    fs::create_directories(file.parent_path());
    std::ofstream(file) << "x";
  };
  EXPECT_EQ(config::DefaultSegmentationModel((prefix / "service" / "softgrasp-server").string()),
            "none");
  touch(prefix / "models" / "pix2stiffness.pt");  // the other model does not count
  EXPECT_EQ(config::DefaultSegmentationModel((prefix / "service" / "softgrasp-server").string()),
            "none");
  touch(prefix / "share" / "softgrasp" / "models" / "segmentation.pt");
  EXPECT_EQ(config::DefaultSegmentationModel((prefix / "bin" / "softgrasp-server").string()),
            (prefix / "share" / "softgrasp" / "models" / "segmentation.pt").string());
  touch(prefix / "models" / "segmentation.pt");
  EXPECT_EQ(config::DefaultSegmentationModel((prefix / "service" / "softgrasp-server").string()),
            (prefix / "models" / "segmentation.pt").string());
}

// ---- with a segmentation model, when one exists (never a made-up one) ----

std::string ModelPath() {
  if (const char* path = std::getenv("SOFTGRASP_TEST_SEGMENTATION_MODEL")) return path;
  return std::string(SOFTGRASP_SOURCE_DIR) + "/models/segmentation.pt";
}

// The model at ModelPath(), loaded once; null when there is no file (the tests then skip).
std::shared_ptr<const models::SegmentationModel> Model() {
  static const std::shared_ptr<const models::SegmentationModel> model =
      []() -> std::shared_ptr<const models::SegmentationModel> {
    if (!std::filesystem::exists(ModelPath())) return nullptr;
    auto loaded = models::SegmentationModel::Load(ModelPath());
    if (!loaded.ok()) throw std::runtime_error(loaded.error().message);
    return std::make_shared<const models::SegmentationModel>(std::move(loaded).value());
  }();
  return model;
}

TEST(SegmentationApiModelTest, ModelAnswersWithDeformability) {
  if (!Model()) GTEST_SKIP() << "no segmentation model at " << ModelPath();
  RunningServer server({}, nullptr, nullptr, nullptr, Model());
  const Frame& f = Boxes();
  const json info = json::parse(server.Send(RawRequest("GET", "/v1/info")).body);
  EXPECT_EQ(info["default_segmentation_method"], "model");
  const auto reply = server.Send(MultipartRequest("/v1/segmentation", Upload(f)));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_EQ(body["method"], "model");
  for (const json& inst : body["instances"]) {
    ASSERT_TRUE(inst["mean_deformability"].is_number());
    EXPECT_GE(inst["mean_deformability"].get<double>(), 0.0);
    EXPECT_LE(inst["mean_deformability"].get<double>(), 1.0);
  }
  for (const char* encoding : {"png8", "png16", "npy", "color"}) {
    const auto map = server.Send(
        MultipartRequest("/v1/segmentation",
                         Upload(f, {{"format", "deformability", ""}, {"encoding", encoding, ""}})));
    EXPECT_EQ(map.status, 200) << encoding << map.body;
  }
  const cv::Mat png8 = DecodePng(
      server
          .Send(MultipartRequest("/v1/segmentation", Upload(f, {{"format", "deformability", ""}})))
          .body);
  ASSERT_EQ(png8.type(), CV_8UC1);
  EXPECT_EQ(png8.size(), cv::Size(640, 480));
  // The PCL baseline still serves on request.
  EXPECT_EQ(
      server.Send(MultipartRequest("/v1/segmentation", Upload(f, {{"method", "pcl", ""}}))).status,
      200);
  // Fused: the model's instances plus what only the geometry found; one instance per box (the
  // model is confident on these), with the model's deformability.
  EXPECT_EQ(info["segmentation_methods"], json({"model", "pcl", "fused"}));
  const json fused = ParseOk(
      server.Send(MultipartRequest("/v1/segmentation", Upload(f, {{"method", "fused", ""}}))));
  EXPECT_EQ(fused["method"], "fused");
  EXPECT_EQ(fused["segmentation_model"], "segmentation");
  const cv::Mat1w fused_labels = DecodePng(
      server
          .Send(MultipartRequest("/v1/segmentation",
                                 Upload(f, {{"method", "fused", ""}, {"format", "labels", ""}})))
          .body);
  std::multiset<int> fused_boxes;
  for (const json& inst : fused["instances"]) {
    EXPECT_TRUE(inst["mean_deformability"].is_number());
    if (inst["score"].get<double>() < 0.25) continue;
    fused_boxes.insert(BoxOfInstance(fused_labels, inst["id"], f.scene.object_id));
  }
  EXPECT_EQ(fused_boxes, (std::multiset<int>{1, 2, 3}));
  EXPECT_EQ(
      server
          .Send(MultipartRequest("/v1/segmentation", Upload(f, {{"method", "fused", ""},
                                                                {"format", "deformability", ""}})))
          .status,
      200);
  const json grasps = json::parse(
      server
          .Send(MultipartRequest("/v1/grasps",
                                 Upload(f, {{"instances", "true", ""}, {"strategy", "fge", ""}})))
          .body);
  EXPECT_EQ(grasps["segmentation"]["source"], "model");
  for (const json& g : grasps["grasps"]) {
    if (g["instance_id"].get<int>() > 0) {
      EXPECT_TRUE(g["instance_deformability"].is_number());
    }
  }
}

// strategy=deformability with the shipped model: the target is one box, every grasp is on it
// and says so; labels given by the client are used as they are (every id confident); bad
// fields name themselves.
TEST(SegmentationApiModelTest, DeformabilityStrategyGraspsOneTarget) {
  if (!Model()) GTEST_SKIP() << "no segmentation model at " << ModelPath();
  RunningServer server({}, nullptr, nullptr, nullptr, Model());
  const Frame& f = Boxes();
  const json info = json::parse(server.Send(RawRequest("GET", "/v1/info")).body);
  EXPECT_EQ(info["default_strategy"], "deformability");
  EXPECT_EQ(info["strategies"], json({"fge", "deformability"}));
  EXPECT_EQ(info["overlays"], json({"depth", "deformability"}));

  // Labels from the PCL baseline (exact on these boxes), target 2 by request.
  const auto labels_png = server.Send(MultipartRequest(
      "/v1/segmentation", Upload(f, {{"method", "pcl", ""}, {"format", "labels", ""}})));
  ASSERT_EQ(labels_png.status, 200);
  const cv::Mat1w labels = DecodePng(labels_png.body);
  for (const std::string policy : {"highest", "least_deformable"}) {
    const json body = ParseOk(
        server.Send(MultipartRequest("/v1/grasps", Upload(f, {{"labels", labels_png.body, "l.png"},
                                                              {"target_policy", policy, ""},
                                                              {"top_k", "3", ""}}))));
    EXPECT_EQ(body["strategy"], "deformability");
    EXPECT_EQ(body["target"]["policy"], policy);
    ASSERT_TRUE(body["target"]["id"].is_number()) << body.dump();
    const int target = body["target"]["id"];
    if (policy == "highest") {
      // Box 2 (55 mm) is the tallest.
      EXPECT_EQ(BoxOfInstance(labels, target, f.scene.object_id), 2);
    }
    ASSERT_FALSE(body["grasps"].empty());
    for (const json& g : body["grasps"]) {
      EXPECT_EQ(g["instance_id"], target);
      // The fingers close on the target alone (the model may rank a box's stiffer end first,
      // so the centre itself can lie just off the box).
      EXPECT_EQ(ContactBoxes(f, g), std::set<int>{BoxOfInstance(labels, target, f.scene.object_id)})
          << g.dump();
      const json& d = g["deformability"];
      EXPECT_EQ(d["target_policy"], policy);
      EXPECT_EQ(d["target_by"], "policy");
      EXPECT_GE(d["mean_deformability"].get<double>(), 0.0);
      EXPECT_LE(d["mean_deformability"].get<double>(), 1.0);
      EXPECT_TRUE(d["pressed_instances"].is_array());
      EXPECT_GT(d["opening_fraction"].get<double>(), 0.0);
      EXPECT_NEAR(g["opening_m"].get<double>(), 0.05 * d["opening_fraction"].get<double>(), 1e-9);
    }
  }
  // An explicit target wins; the model segments when no labels are given.
  const int box3 =
      labels(static_cast<int>(
                 std::lround(softgrasp::testing::ProjectTablePoint(f.spec, 0.02, 0.10, 0.03).y)),
             static_cast<int>(
                 std::lround(softgrasp::testing::ProjectTablePoint(f.spec, 0.02, 0.10, 0.03).x)));
  ASSERT_GT(box3, 0);
  const json chosen = ParseOk(server.Send(MultipartRequest(
      "/v1/grasps",
      Upload(f, {{"labels", labels_png.body, "l.png"}, {"target", std::to_string(box3), ""}}))));
  EXPECT_EQ(chosen["target"]["id"], box3);
  for (const json& g : chosen["grasps"]) {
    EXPECT_EQ(ContactBoxes(f, g), std::set<int>{3}) << g.dump();
    EXPECT_EQ(g["deformability"]["target_by"], "request");
  }
  const json segmented = ParseOk(server.Send(MultipartRequest("/v1/grasps", Upload(f))));
  EXPECT_EQ(segmented["segmentation"]["source"], "model");
  EXPECT_GT(segmented["timing_ms"]["segmentation"].get<double>(), 0.0);
  // The picture: the deformability map with the target outlined, the grasps over it.
  const auto png = server.Send(MultipartRequest(
      "/v1/grasps", Upload(f, {{"format", "png", ""}, {"overlay", "deformability", ""}})));
  ASSERT_EQ(png.status, 200);
  EXPECT_EQ(DecodePng(png.body).size(), cv::Size(640, 480));

  for (const auto& [field, value] :
       std::vector<std::pair<std::string, std::string>>{{"target_policy", "tallest"},
                                                        {"opening_fractions", "1,0.5"},
                                                        {"opening_fractions", "0,1"},
                                                        {"opening_fractions", "a"},
                                                        {"slice_step_mm", "45"},
                                                        {"num_slices", "0"},
                                                        {"min_score", "2"}}) {
    ExpectError(server.Send(MultipartRequest("/v1/grasps", Upload(f, {{field, value, ""}}))), 400,
                field);
  }
}

// The default strategy with the shipped models on every real frame in tests/data: always
// grasps (on one target, or from the whole-scene fallback when no confident object gives one),
// each with its deformability record; the whole request within the 250 ms budget is a benchmark
// (grasps_api_bench), not asserted here.
TEST(SegmentationApiModelTest, DeformabilityAnswersGraspsOnEveryRealFrame) {
  if (!Model()) GTEST_SKIP() << "no segmentation model at " << ModelPath();
  RunningServer server({}, nullptr, nullptr, nullptr, Model());
  for (const auto& [frame, intr] : std::vector<std::pair<std::string, std::string>>{
           {"gqcnn/primesense/single_depth_0.npy", "gqcnn/primesense/primesense.intr"},
           {"gqcnn/primesense/single_depth_1.npy", "gqcnn/primesense/primesense.intr"},
           {"gqcnn/primesense/single_depth_2.npy", "gqcnn/primesense/primesense.intr"},
           {"gqcnn/phoxi/clutter_depth_0.npy", "gqcnn/phoxi/phoxi.intr"}}) {
    SCOPED_TRACE(frame);
    const json body = ParseOk(server.Send(MultipartRequest(
        "/v1/grasps",
        {{"depth", testing::ReadFileBytes(testing::TestData(frame)), "d.npy"},
         {"intrinsics", testing::ReadFileBytes(testing::TestData(intr)), "c.intr"}})));
    EXPECT_EQ(body["strategy"], "deformability");
    ASSERT_FALSE(body["grasps"].empty()) << body.dump();
    const bool fallback = body["target"]["fallback"];
    EXPECT_EQ(body["target"]["id"].is_null(), fallback);
    for (const json& g : body["grasps"]) {
      EXPECT_EQ(g["deformability"]["target_by"], fallback ? "fallback" : "policy");
      if (!fallback) {
        EXPECT_EQ(g["instance_id"], body["target"]["id"]);
      }
      const double d = g["deformability"]["mean_deformability"];
      EXPECT_GE(d, 0.0);
      EXPECT_LE(d, 1.0);
    }
  }
}

}  // namespace
}  // namespace softgrasp::rest
