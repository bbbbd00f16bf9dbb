// POST /v1/fractals end to end: real server, real socket.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "service/mesh/mesh_check.h"
#include "service/mesh/mesh_io.h"
#include "tests/rest/server_fixture.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;
using testing::RawRequest;
using testing::RunningServer;

class FractalsApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    config::ServiceConfig config;
    config.max_fractal_points = 20000;
    server_ = new RunningServer(config);
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static testing::HttpReply Post(const std::string& body) {
    return server_->Send(RawRequest("POST", "/v1/fractals", "application/json", body));
  }
  static RunningServer* server_;
};
RunningServer* FractalsApiTest::server_ = nullptr;

TEST_F(FractalsApiTest, StatisticsDescribeAClosedScaledMesh) {
  const auto reply = Post(R"({"seed": 7, "alpha": 0.3, "points": 10000, "format": "json"})");
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json stats = json::parse(reply.body);
  EXPECT_GT(stats["vertices"].get<int>(), 3);
  EXPECT_GT(stats["faces"].get<int>(), 3);
  EXPECT_GT(stats["volume_m3"].get<double>(), 0.0);
  EXPECT_GE(stats["attempts"].get<int>(), 1);
  EXPECT_GE(stats["alpha_used"].get<double>(), 0.3);
  EXPECT_EQ(stats["seed"], 7);
  // Near-duplicate chaos-game points are merged on a grid of min(0.05 alpha, 0.05) first.
  EXPECT_DOUBLE_EQ(stats["merge_cell"].get<double>(), 0.05 * 0.3);
  EXPECT_GT(stats["points_triangulated"].get<int>(), 3);
  EXPECT_LE(stats["points_triangulated"].get<int>(), stats["points"].get<int>());
  // Smallest bounding-box side = 80 % of the 50 mm opening.
  const auto& size = stats["bbox"]["size_m"];
  const double smallest =
      std::min({size[0].get<double>(), size[1].get<double>(), size[2].get<double>()});
  EXPECT_NEAR(smallest, 0.04, 1e-6);
}

TEST_F(FractalsApiTest, SameSeedSameBytesAndAClosedMeshInEveryFormat) {
  for (const std::string format : {"obj", "ply_ascii", "ply_binary", "stl_ascii", "stl_binary"}) {
    SCOPED_TRACE(format);
    const std::string body = R"({"seed": 11, "points": 4000, "format": ")" + format + "\"}";
    const auto a = Post(body);
    const auto b = Post(body);
    ASSERT_EQ(a.status, 200) << a.body;
    EXPECT_EQ(a.body, b.body);
    const std::string disposition(a.header("Content-Disposition").value_or(""));
    EXPECT_NE(disposition.find("attachment; filename=\"fractal-seed11-alpha0.3."),
              std::string::npos)
        << disposition;
    auto mesh = mesh::ReadMesh(a.body);
    ASSERT_TRUE(mesh.ok()) << mesh.error().message;
    const mesh::MeshReport report = mesh::CheckMesh(mesh.value());
    EXPECT_TRUE(report.ok()) << ::testing::PrintToString(report.problems);
  }
  EXPECT_NE(Post(R"({"seed": 11, "points": 4000})").body,
            Post(R"({"seed": 12, "points": 4000})").body);
}

TEST_F(FractalsApiTest, BadParametersNameTheirField) {
  const auto field_of = [](const testing::HttpReply& r) {
    EXPECT_EQ(r.status, 400) << r.body;
    return json::parse(r.body)["error"].value("field", "");
  };
  EXPECT_EQ(field_of(Post(R"({"sigma": 0.5})")), "sigma");
  EXPECT_EQ(field_of(Post(R"({"alpha": 0})")), "alpha");
  EXPECT_EQ(field_of(Post(R"({"alpha": -1})")), "alpha");
  EXPECT_EQ(field_of(Post(R"({"points": 20001})")), "points");
  EXPECT_EQ(field_of(Post(R"({"maps": [5, 2]})")), "maps");
  EXPECT_EQ(field_of(Post(R"({"seed": -1})")), "seed");
  EXPECT_EQ(field_of(Post(R"({"format": "gltf"})")), "format");
  EXPECT_EQ(field_of(Post(R"({"colour": "red"})")), "colour");
  EXPECT_EQ(field_of(Post(R"({"scale": {"opening_mm": -5}})")), "scale.opening_mm");
  EXPECT_EQ(field_of(Post("{not json")), "body");
  const auto wrong_type = server_->Send(RawRequest("POST", "/v1/fractals", "text/plain", "seed=1"));
  EXPECT_EQ(wrong_type.status, 415);
}

}  // namespace
}  // namespace softgrasp::rest
