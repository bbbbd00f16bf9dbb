// POST /v1/meshes/grasps end to end (real server, real socket): the Dex-Net bar clamp as
// uploaded OBJ, a cube in millimetres as binary STL and rescaled, the PNG preview, repairs said,
// and every class of bad mesh and bad request answered with its 4xx and the field at fault.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "service/mesh/mesh_io.h"
#include "tests/rest/server_fixture.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::rest {
namespace {

using nlohmann::json;
using testing::RawRequest;
using testing::RunningServer;

class MeshesApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    config::ServiceConfig config;
    config.max_mesh_triangles = 1000;
    config.max_mesh_quality_evaluations = 3000;
    server_ = new RunningServer(config);
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static testing::HttpReply Post(const std::string& query, const std::string& body,
                                 const std::string& extra_headers = "",
                                 const std::string& type = "application/octet-stream") {
    return server_->Send(
        RawRequest("POST", "/v1/meshes/grasps" + query, type, body, extra_headers));
  }
  static json Error(const testing::HttpReply& reply) { return json::parse(reply.body)["error"]; }
  static RunningServer* server_;
};
RunningServer* MeshesApiTest::server_ = nullptr;

std::string CubeObj(double half, bool inside_out = false) {
  mesh::TriangleMesh m = softgrasp::testing::CentredBoxMesh(Eigen::Vector3d::Constant(half));
  if (inside_out) {
    for (auto& f : m.faces) std::swap(f[1], f[2]);
  }
  return mesh::WriteObj(m);
}

TEST_F(MeshesApiTest, BarClampAnswersPosesAndRankedGraspsWithPerPoseFlags) {
  const std::string clamp =
      testing::ReadFileBytes(testing::TestData("meshes/dexnet_bar_clamp.obj"));
  const auto reply = Post("?num_grasps=30&robust_samples=5&seed=2", clamp);
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_EQ(body["mesh"]["format"], "obj");
  EXPECT_EQ(body["mesh"]["scale_applied"], 1.0);
  const json& poses = body["stable_poses"];
  ASSERT_GE(poses.size(), 2u);
  for (std::size_t i = 1; i < poses.size(); ++i) {
    EXPECT_GE(poses[i - 1]["probability"].get<double>(), poses[i]["probability"].get<double>());
  }
  const json& grasps = body["grasps"];
  ASSERT_GT(grasps.size(), 10u);
  EXPECT_LE(grasps.size(), 30u);
  for (std::size_t i = 0; i < grasps.size(); ++i) {
    EXPECT_EQ(grasps[i]["rank"], i);
    EXPECT_EQ(grasps[i]["poses"].size(), poses.size());
    EXPECT_LE(grasps[i]["width_m"].get<double>(), 0.05);
    if (i > 0) {
      EXPECT_GE(grasps[i - 1]["robust_ferrari_canny"].get<double>(),
                grasps[i]["robust_ferrari_canny"].get<double>());
    }
  }
  for (const char* phase :
       {"decode", "prepare", "stable_poses", "sampling", "quality", "collisions", "total"}) {
    EXPECT_GE(body["timing_ms"][phase].get<double>(), 0.0) << phase;
  }
  // Same request, same answer (timings aside).
  json again = json::parse(Post("?num_grasps=30&robust_samples=5&seed=2", clamp).body);
  json first = body;
  first.erase("timing_ms");
  again.erase("timing_ms");
  EXPECT_EQ(first, again);
}

// A cracker box 72 mm at its thinnest, with the default 50 mm stroke: 200 with no grasp, and the
// answer says why and what stroke it needs; the default stroke's answer for a 40 mm cube has none.
TEST_F(MeshesApiTest, ABoxWiderThanTheStrokeSaysWhyThereIsNoGrasp) {
  const std::string box = mesh::WriteMesh(softgrasp::testing::CentredBoxMesh({0.036, 0.080, 0.105}),
                                          mesh::MeshFormat::kObj);
  const auto reply = Post("?num_grasps=20&robust_samples=0", box);
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  EXPECT_TRUE(body["grasps"].empty());
  ASSERT_TRUE(body["no_grasp"].is_object()) << body.dump();
  EXPECT_EQ(body["no_grasp"]["reason"], "wider_than_stroke");
  EXPECT_NEAR(body["no_grasp"]["narrowest_width_m"].get<double>(), 0.072, 1e-6);
  EXPECT_NEAR(body["no_grasp"]["needed_stroke_m"].get<double>(), 0.072, 1e-9);
  const auto wider = Post("?num_grasps=20&robust_samples=0&opening_stroke_mm=80", box);
  ASSERT_EQ(wider.status, 200) << wider.body;
  EXPECT_FALSE(json::parse(wider.body)["grasps"].empty());
  EXPECT_TRUE(json::parse(wider.body)["no_grasp"].is_null());
}

TEST_F(MeshesApiTest, MillimetreStlIsConvertedAndRescaledToTheGripper) {
  const std::string stl =
      mesh::WriteStl(softgrasp::testing::BoxMesh({0, 0, 0}, {20, 40, 80}), mesh::Encoding::kBinary);
  const auto mm = Post("?unit=mm&num_grasps=10&robust_samples=0", stl);
  ASSERT_EQ(mm.status, 200) << mm.body;
  const json body = json::parse(mm.body);
  EXPECT_EQ(body["mesh"]["format"], "stl_binary");
  EXPECT_DOUBLE_EQ(body["mesh"]["scale_applied"].get<double>(), 0.001);
  EXPECT_NEAR(body["mesh"]["volume_m3"].get<double>(), 0.02 * 0.04 * 0.08, 1e-12);
  EXPECT_TRUE(body["grasps"][0]["robust_ferrari_canny"].is_null());
  // Dex-Net's rescale: the smallest principal extent becomes 40 mm.
  const auto rescaled =
      Post("?unit=mm&rescale_min_extent_mm=40&num_grasps=10&robust_samples=0", stl);
  ASSERT_EQ(rescaled.status, 200) << rescaled.body;
  const json r = json::parse(rescaled.body);
  EXPECT_NEAR(r["mesh"]["scale_applied"].get<double>(), 0.002, 1e-12);
  EXPECT_NEAR(r["mesh"]["extents_m"][0].get<double>(), 0.04, 1e-9);
}

TEST_F(MeshesApiTest, PngPreviewDrawsTheUsableGraspsOfThePose) {
  const auto reply =
      Post("?num_grasps=40&robust_samples=0&size_px=200", CubeObj(0.02), "Accept: image/png\r\n");
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.header("Content-Type").value_or(""), "image/png");
  const cv::Mat image = cv::imdecode(
      cv::Mat(1, static_cast<int>(reply.body.size()), CV_8U, const_cast<char*>(reply.body.data())),
      cv::IMREAD_UNCHANGED);
  ASSERT_EQ(image.cols, 200);
  ASSERT_EQ(image.rows, 200);
  EXPECT_GT(std::stoi(std::string(reply.header("X-Grasp-Count").value_or("0"))), 0);
  const auto bad_pose = Post("?num_grasps=5&robust_samples=0&format=png&pose=6", CubeObj(0.02));
  EXPECT_EQ(bad_pose.status, 400);
  EXPECT_EQ(Error(bad_pose)["field"], "pose");
}

TEST_F(MeshesApiTest, RepairsAreDoneAndSaid) {
  const auto reply = Post("?num_grasps=5&robust_samples=0", CubeObj(0.02, /*inside_out=*/true));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  ASSERT_FALSE(body["mesh"]["repairs"].empty());
  EXPECT_EQ(body["stable_poses"].size(), 6u);
}

TEST_F(MeshesApiTest, AScanMissingItsBottomIsClosedAndSaysSo) {
  // A cube without its bottom side, as a scanner looking down at an object on a table sees it.
  mesh::TriangleMesh open = softgrasp::testing::CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  open.faces.erase(open.faces.begin() + 2, open.faces.begin() + 4);
  const auto reply = Post("?num_grasps=5&robust_samples=0", mesh::WriteObj(open));
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json body = json::parse(reply.body);
  std::string repairs;
  for (const auto& line : body["mesh"]["repairs"]) repairs += line.get<std::string>() + "\n";
  EXPECT_NE(repairs.find("filled 1 hole (4 boundary edges) with 2 new faces, adding 20% to the "
                         "surface area"),
            std::string::npos)
      << repairs;
  EXPECT_EQ(body["stable_poses"].size(), 6u);
}

TEST_F(MeshesApiTest, EveryBadMeshClassGetsItsStatusAndAMessage) {
  // Not a mesh: 415.
  const auto text = Post("", "hello, this is not a mesh\n");
  EXPECT_EQ(text.status, 415) << text.body;
  // NaN coordinate: 400.
  const auto nan = Post("",
                        "v 0 0 0\nv 1 0 0\nv 0 nan 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\n"
                        "f 2 4 3\n");
  EXPECT_EQ(nan.status, 400) << nan.body;
  // Not closed: one side of a cube, a sheet whose "hole" is too large to fill, 422.
  mesh::TriangleMesh open = softgrasp::testing::CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  open.faces.resize(2);
  const auto not_closed = Post("", mesh::WriteObj(open));
  EXPECT_EQ(not_closed.status, 422) << not_closed.body;
  EXPECT_NE(Error(not_closed)["message"].get<std::string>().find("closed"), std::string::npos)
      << not_closed.body;
  EXPECT_NE(Error(not_closed)["message"].get<std::string>().find("not filled"), std::string::npos)
      << not_closed.body;
  // Non-manifold: two cubes sharing an edge, 422.
  mesh::TriangleMesh two = softgrasp::testing::BoxMesh({0, 0, 0}, {0.02, 0.02, 0.02});
  const mesh::TriangleMesh second =
      softgrasp::testing::BoxMesh({0.02, 0.02, 0}, {0.04, 0.04, 0.02});
  for (const auto& v : second.vertices) two.vertices.push_back(v);
  for (const auto& f : second.faces) two.faces.push_back({f[0] + 8, f[1] + 8, f[2] + 8});
  const auto non_manifold = Post("", mesh::WriteObj(two));
  EXPECT_EQ(non_manifold.status, 422) << non_manifold.body;
  // Degenerate: a flat square with both sides (no volume), 422.
  const auto flat = Post("",
                         "v 0 0 0\nv 0.05 0 0\nv 0.05 0.05 0\nv 0 0.05 0\n"
                         "f 1 2 3\nf 1 3 4\nf 1 3 2\nf 1 4 3\n");
  EXPECT_EQ(flat.status, 422) << flat.body;
  // Too many triangles (this server takes 1,000): 413.
  std::string big = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i <= 1000; ++i) big += "f 1 2 3\n";
  const auto too_big = Post("", big);
  EXPECT_EQ(too_big.status, 413) << too_big.body.substr(0, 200);
  for (const auto* reply : {&text, &nan, &not_closed, &non_manifold, &flat, &too_big}) {
    EXPECT_FALSE(Error(*reply)["message"].get<std::string>().empty());
  }
}

TEST_F(MeshesApiTest, BadRequestsNameTheField) {
  const std::string cube = CubeObj(0.02);
  const auto unknown = Post("?grasps=3", cube);
  EXPECT_EQ(unknown.status, 400);
  EXPECT_EQ(Error(unknown)["field"], "grasps");
  const auto unit = Post("?unit=cm", cube);
  EXPECT_EQ(unit.status, 400);
  EXPECT_EQ(Error(unit)["field"], "unit");
  const auto range = Post("?num_grasps=0", cube);
  EXPECT_EQ(range.status, 400);
  EXPECT_EQ(Error(range)["field"], "num_grasps");
  const auto fraction = Post("?robust_samples=2.5", cube);
  EXPECT_EQ(fraction.status, 400);
  // More work than this server allows (3,000 evaluations): 400 naming robust_samples.
  const auto too_much = Post("?num_grasps=200&robust_samples=20", cube);
  EXPECT_EQ(too_much.status, 400);
  EXPECT_EQ(Error(too_much)["field"], "robust_samples");
  const auto as_json = Post("", R"({"mesh": "cube"})", "", "application/json");
  EXPECT_EQ(as_json.status, 415);
  const auto empty = Post("", "");
  EXPECT_EQ(empty.status, 400);
  EXPECT_EQ(Error(empty)["field"], "mesh");
  // The multipart form works like the raw body.
  const auto form = server_->Send(testing::MultipartRequest(
      "/v1/meshes/grasps",
      {{"mesh", cube, "cube.obj"}, {"num_grasps", "5", ""}, {"robust_samples", "0", ""}}));
  ASSERT_EQ(form.status, 200) << form.body;
  EXPECT_EQ(json::parse(form.body)["stable_poses"].size(), 6u);
}

}  // namespace
}  // namespace softgrasp::rest
