// GET / and /assets/{file} over a real socket: the page, its caching, refusal of traversal, the
// web root setting; and draw=none, the plain depth picture the page draws its grasps on.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "service/config/config.h"
#include "service/http/static_files.h"
#include "service/io/depth_codec.h"
#include "service/io/overlay.h"
#include "tests/rest/server_fixture.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::rest {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::RawRequest;

constexpr const char* kIndex =
    "<!doctype html><title>softgrasp</title><script src=/assets/app-ABCD1234.js></script>";
constexpr const char* kScript = "document.title = 'x';";
constexpr const char* kSecret = "TOP-SECRET-CONTENT";

void WriteFile(const fs::path& path, const std::string& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

class WebRoutesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    sandbox_ = temp_.path();
    WriteFile(sandbox_ / "web" / "index.html", kIndex);
    WriteFile(sandbox_ / "web" / "assets" / "app-ABCD1234.js", kScript);
    WriteFile(sandbox_ / "secret.txt", kSecret);
    config::ServiceConfig config;
    config.web_root = (sandbox_ / "web").string();
    server_ = std::make_unique<testing::RunningServer>(config);
  }
  void TearDown() override { server_.reset(); }
  testing::HttpReply Get(const std::string& target, const std::string& headers = "") {
    return server_->Send(RawRequest("GET", target, "", "", headers));
  }

  softgrasp::testing::TempDir temp_{"web"};
  fs::path sandbox_;
  std::unique_ptr<testing::RunningServer> server_;
};

void ExpectJsonError(const testing::HttpReply& reply, int status, const std::string& code) {
  EXPECT_EQ(reply.status, status);
  EXPECT_EQ(reply.header("Content-Type").value_or(""), "application/json");
  EXPECT_EQ(json::parse(reply.body)["error"]["code"], code) << reply.body;
}

TEST_F(WebRoutesTest, RootServesIndexHtmlToRevalidate) {
  const auto page = Get("/");
  ASSERT_EQ(page.status, 200);
  EXPECT_EQ(page.body, kIndex);
  EXPECT_EQ(page.header("Content-Type").value_or(""), "text/html; charset=utf-8");
  EXPECT_EQ(page.header("Cache-Control").value_or(""), "no-cache");
  EXPECT_EQ(page.header("ETag").value_or(""), http::EntityTagFor(kIndex));
  EXPECT_NE(page.header("Content-Security-Policy").value_or("").find("default-src 'self'"),
            std::string::npos);

  const std::string etag(page.header("ETag").value());
  const auto cached = Get("/", "If-None-Match: " + etag + "\r\n");
  EXPECT_EQ(cached.status, 304);
  EXPECT_TRUE(cached.body.empty());
  EXPECT_FALSE(cached.header("Content-Length").has_value());
  EXPECT_EQ(cached.header("ETag").value_or(""), etag);
}

TEST_F(WebRoutesTest, HeadGivesHeadersWithoutBody) {
  const auto head = server_->Send(RawRequest("HEAD", "/"));
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.header("Content-Length").value_or(""), std::to_string(std::string(kIndex).size()));
  EXPECT_EQ(head.header("Content-Type").value_or(""), "text/html; charset=utf-8");
  EXPECT_TRUE(head.body.empty());
}

TEST_F(WebRoutesTest, AssetsAreImmutableWithTheirType) {
  const auto script = Get("/assets/app-ABCD1234.js");
  ASSERT_EQ(script.status, 200);
  EXPECT_EQ(script.body, kScript);
  EXPECT_EQ(script.header("Content-Type").value_or(""), "text/javascript; charset=utf-8");
  EXPECT_EQ(script.header("Cache-Control").value_or(""), "public, max-age=31536000, immutable");
}

TEST_F(WebRoutesTest, NothingOutsideTheAssetsIsServed) {
  for (const char* target :
       {"/assets", "/assets/", "/assets/%2e%2e", "/assets/%2e%2e%2fsecret.txt",
        "/assets/..%2F..%2Fsecret.txt", "/assets/%2Ftmp%2Fsecret.txt", "/index.html",
        "/assets/missing.js", "/secret.txt", "/assets/app-ABCD1234.js%00"}) {
    SCOPED_TRACE(target);
    const auto reply = Get(target);
    EXPECT_EQ(reply.status, reply.status == 400 ? 400 : 404);  // the parser may refuse first
    if (reply.status == 404) ExpectJsonError(reply, 404, "not_found");
    EXPECT_EQ(reply.body.find(kSecret), std::string::npos);
  }
  ExpectJsonError(server_->Send(RawRequest("POST", "/", "text/plain", "x")), 405,
                  "method_not_allowed");
}

TEST(WebRootTest, MissingPageIs404SayingHowToBuildIt) {
  config::ServiceConfig config;
  config.web_root = "/nonexistent/softgrasp-web";
  testing::RunningServer server(config);
  const auto reply = server.Send(RawRequest("GET", "/"));
  ExpectJsonError(reply, 404, "not_found");
  EXPECT_NE(reply.body.find("scripts/build.sh"), std::string::npos);
  EXPECT_EQ(server.Send(RawRequest("GET", "/healthz")).status, 200);  // the API still works
}

TEST(WebRootTest, ConfigFileEnvironmentAndFlag) {
  auto from_json = config::ApplyConfigJson({}, R"({"web": {"root": "/srv/web"}})");
  ASSERT_TRUE(from_json.ok());
  EXPECT_EQ(from_json.value().web_root, "/srv/web");
  EXPECT_EQ(config::ApplyConfigJson({}, R"({"web": {"root": 3}})").error().field, "web.root");
  EXPECT_EQ(config::ApplyConfigJson({}, R"({"web": {"rot": "x"}})").error().field, "web.rot");

  ::setenv("SOFTGRASP_WEB_ROOT", "/env/web", 1);
  EXPECT_EQ(config::ParseCommandLine({}).value().config.web_root, "/env/web");
  EXPECT_EQ(config::ParseCommandLine({"--web-root", "/flag/web"}).value().config.web_root,
            "/flag/web");
  ::unsetenv("SOFTGRASP_WEB_ROOT");
  EXPECT_FALSE(config::ParseCommandLine({"--web-root"}).ok());
  EXPECT_EQ(json::parse(config::ConfigToJson(
                config::ParseCommandLine({"--web-root", "/w"}).value().config))["web"]["root"],
            "/w");
}

TEST(WebRootTest, DefaultIsNextToTheExecutable) {
  const softgrasp::testing::TempDir temp("layout");
  const fs::path& prefix = temp.path();
  // Nothing built: the build-tree folder, so the start-up warning names where it should be.
  EXPECT_EQ(config::DefaultWebRoot((prefix / "service" / "softgrasp-server").string()),
            (prefix / "web").string());
  WriteFile(prefix / "share" / "softgrasp" / "web" / "index.html", "x");
  EXPECT_EQ(config::DefaultWebRoot((prefix / "bin" / "softgrasp-server").string()),
            (prefix / "share" / "softgrasp" / "web").string());
  WriteFile(prefix / "web" / "index.html", "x");
  EXPECT_EQ(config::DefaultWebRoot((prefix / "service" / "softgrasp-server").string()),
            (prefix / "web").string());
}

// The page draws grasps itself over the plain depth picture (draw=none); the overlay with
// draw=grasps (the default) differs from it exactly where grasps are drawn.
TEST(GraspPictureTest, DrawNoneIsTheColourMappedDepthAlone) {
  testing::RunningServer server;
  const std::string npy =
      testing::ReadFileBytes(testing::TestData("gqcnn/primesense/single_depth_0.npy"));
  const auto plain = server.Send(testing::MultipartRequest(
      "/v1/grasps?format=png", {{"depth", npy, "d.npy"}, {"draw", "none", ""}}));
  const auto drawn = server.Send(testing::MultipartRequest(
      "/v1/grasps?format=png", {{"depth", npy, "d.npy"}, {"draw", "grasps", ""}}));
  ASSERT_EQ(plain.status, 200) << plain.body;
  ASSERT_EQ(drawn.status, 200) << drawn.body;
  EXPECT_EQ(plain.header("X-Grasp-Count").value_or(""), "0");
  EXPECT_NE(drawn.header("X-Grasp-Count").value_or("0"), "0");

  auto depth = io::DecodeDepth(npy, {});
  ASSERT_TRUE(depth.ok());
  EXPECT_EQ(plain.body, io::EncodePng(io::ColorizeDepth(depth.value())));
  const cv::Mat a = cv::imdecode(
      cv::Mat(1, static_cast<int>(plain.body.size()), CV_8U, const_cast<char*>(plain.body.data())),
      cv::IMREAD_COLOR);
  const cv::Mat b = cv::imdecode(
      cv::Mat(1, static_cast<int>(drawn.body.size()), CV_8U, const_cast<char*>(drawn.body.data())),
      cv::IMREAD_COLOR);
  ASSERT_EQ(a.size(), b.size());
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  cv::Mat gray;
  cv::cvtColor(diff, gray, cv::COLOR_BGR2GRAY);
  const int changed = cv::countNonZero(gray);
  EXPECT_GT(changed, 100);                  // the grasps are drawn ...
  EXPECT_LT(changed, a.rows * a.cols / 4);  // ... over an otherwise identical picture

  const auto bad = server.Send(testing::MultipartRequest(
      "/v1/grasps?format=png", {{"depth", npy, "d.npy"}, {"draw", "some", ""}}));
  ExpectJsonError(bad, 400, "invalid_argument");
  EXPECT_EQ(json::parse(bad.body)["error"]["field"], "draw");
}

}  // namespace
}  // namespace softgrasp::rest
