// The whole mesh analysis on analytic and real meshes: a 4 cm cube (six poses of 1/6, every
// grasp in force closure, top-down grasps free exactly where the gripper's geometry says, a
// preview that sees the top face at its depth), determinism per seed, refusals; and the Dex-Net
// bar clamp, whose grasps across the bar and the handle rank above grasps on the jaw tips.
#include "service/mesh_grasps/mesh_grasp_analysis.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>
#include <vector>

#include "service/codec/mesh_grasps_json.h"
#include "service/mesh/mesh_io.h"
#include "tests/support/box_mesh.h"
#include "tests/support/test_data.h"

namespace softgrasp::mesh {
namespace {

MeshGraspAnalysis Analyse(const TriangleMesh& mesh, const MeshGraspOptions& options) {
  auto analysis = AnalyseMeshGrasps(mesh, options);
  EXPECT_TRUE(analysis.ok()) << analysis.error().message;
  return analysis.ok() ? std::move(analysis).value() : MeshGraspAnalysis{};
}

MeshGraspOptions SmallRun() {
  MeshGraspOptions options;
  options.num_grasps = 40;
  options.robust_samples = 5;
  options.seed = 3;
  return options;
}

double Quality(const AnalysedGrasp& g) { return g.robust_ferrari_canny.value_or(g.ferrari_canny); }

TEST(MeshGraspAnalysisTest, CubeRestsOnSixFacesAndItsTopDownGraspsClearWhereTheGeometrySays) {
  const TriangleMesh cube = testing::CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  MeshGraspOptions options = SmallRun();
  options.num_grasps = 200;
  options.robust_samples = 0;
  const MeshGraspAnalysis analysis = Analyse(cube, options);
  ASSERT_EQ(analysis.poses.size(), 6u);
  for (const StablePose& pose : analysis.poses) EXPECT_NEAR(pose.probability, 1.0 / 6, 1e-9);
  EXPECT_NEAR(analysis.center_of_mass_m.norm(), 0.0, 1e-12);
  ASSERT_GE(analysis.grasps.size(), 20u);
  int checked_free = 0;
  int checked_palm_hits = 0;
  for (std::size_t i = 0; i < analysis.grasps.size(); ++i) {
    const AnalysedGrasp& g = analysis.grasps[i];
    if (i > 0) {
      EXPECT_GE(Quality(analysis.grasps[i - 1]), Quality(g));
    }
    EXPECT_GT(g.ferrari_canny, 0.0);
    ASSERT_EQ(g.poses.size(), 6u);
    for (std::size_t p = 0; p < 6; ++p) {
      const StablePose& pose = analysis.poses[p];
      const Eigen::Vector3d down_o = -pose.table_from_object_rotation.row(2).transpose();
      // Aligned exactly when the axis is within 5 degrees of the table plane.
      const double tilt = std::asin(std::min(1.0, std::abs(g.grasp.axis.dot(down_o))));
      EXPECT_EQ(g.poses[p].aligned, tilt <= 5.0 * std::numbers::pi / 180.0 + 1e-12);
      // An axis within 8 degrees of a side normal and 2 of level: the open jaws (inner faces
      // 25 mm from the centre, 15 mm wide) clear the 40 mm cube. Fingertips reach 5 mm below
      // the centre and may sink 5 mm into the table; the palm starts 35 mm above the centre. So
      // centres 10-40 mm above the table are free (with 1.5 mm to spare for the tilts); centres
      // below 3 mm put the palm into the top at every approach offset (at most 10 degrees).
      const double height =
          (pose.table_from_object_rotation * g.grasp.center_m + pose.table_from_object_translation)
              .z();
      const double off_normal = std::acos(std::min(1.0, g.grasp.axis.cwiseAbs().maxCoeff()));
      if (tilt > 2.0 * std::numbers::pi / 180.0 || off_normal > 8.0 * std::numbers::pi / 180.0) {
        continue;
      }
      if (height >= 0.010 && height <= 0.040) {
        EXPECT_TRUE(g.poses[p].collision_free) << "grasp " << i << " pose " << p;
        EXPECT_TRUE(g.poses[p].approach_offset_rad.has_value());
        ++checked_free;
      } else if (height < 0.003) {
        EXPECT_FALSE(g.poses[p].collision_free) << "grasp " << i << " pose " << p;
        ++checked_palm_hits;
      }
    }
  }
  EXPECT_GT(checked_free, 10);
  EXPECT_GT(checked_palm_hits, 0);
}

TEST(MeshGraspAnalysisTest, SameSeedSameAnswerOtherSeedOtherGrasps) {
  const TriangleMesh cube = testing::CentredBoxMesh(Eigen::Vector3d(0.02, 0.015, 0.01));
  MeshGraspOptions options = SmallRun();
  const auto a = codec::ToJsonWithoutTiming(Analyse(cube, options));
  const auto b = codec::ToJsonWithoutTiming(Analyse(cube, options));
  EXPECT_EQ(a.dump(), b.dump());
  options.seed = 4;
  EXPECT_NE(a.dump(), codec::ToJsonWithoutTiming(Analyse(cube, options)).dump());
}

TEST(MeshGraspAnalysisTest, PreviewSeesTheTopFaceAtItsDepthAndDrawsGraspsOnTheCube) {
  const TriangleMesh cube = testing::CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  const MeshGraspAnalysis analysis = Analyse(cube, SmallRun());
  const GripperBoxes gripper;
  auto view = RenderPoseView(cube, analysis, 0, gripper, 200, 5);
  ASSERT_TRUE(view.ok()) << view.error().message;
  const PoseView& v = view.value();
  ASSERT_EQ(v.depth.width(), 200);
  // The top face is 40 mm above the table, the camera looks straight down.
  const double top_depth = v.table_from_camera.translation().z() - 0.04;
  EXPECT_NEAR(v.depth.depth_m(100, 100), top_depth, 1e-6);
  EXPECT_TRUE(std::isnan(v.depth.depth_m(0, 0)));
  ASSERT_FALSE(v.grasps.empty());
  EXPECT_LE(v.grasps.size(), 5u);
  for (const core::Grasp& g : v.grasps) {
    const int u = static_cast<int>(std::lround(g.center_u_px));
    const int row = static_cast<int>(std::lround(g.center_v_px));
    ASSERT_TRUE(u >= 0 && u < 200 && row >= 0 && row < 200);
    EXPECT_FALSE(std::isnan(v.depth.depth_m(row, u))) << "a grasp centre off the cube";
    // The fingers are drawn at the contacts: the cube's 40 mm (up to the friction cone's tilt).
    const double px_per_m = v.camera.fx / g.p_CG_m[2];
    EXPECT_GE(g.opening_px, 0.04 * px_per_m - 1e-9);
    EXPECT_LE(g.opening_px, 0.04 / std::cos(std::atan(0.5)) * px_per_m + 1e-9);
  }
  EXPECT_EQ(RenderPoseView(cube, analysis, 6, gripper).error().field, "pose");
  EXPECT_EQ(RenderPoseView(cube, analysis, 0, gripper, 8).error().field, "size_px");
}

TEST(MeshGraspAnalysisTest, RefusesBadOptionsAndMeshesWithoutVolume) {
  const TriangleMesh cube = testing::CentredBoxMesh(Eigen::Vector3d::Constant(0.02));
  MeshGraspOptions options;
  options.num_grasps = 0;
  EXPECT_EQ(AnalyseMeshGrasps(cube, options).error().field, "num_grasps");
  options = {};
  options.min_pose_probability = 1.0;
  EXPECT_EQ(AnalyseMeshGrasps(cube, options).error().field, "min_pose_probability");
  options = {};
  options.friction_coefficient = -0.1;
  EXPECT_EQ(AnalyseMeshGrasps(cube, options).error().field, "friction_coefficient");
  TriangleMesh inside_out = cube;
  for (auto& f : inside_out.faces) std::swap(f[1], f[2]);
  EXPECT_EQ(AnalyseMeshGrasps(inside_out, {}).error().code, core::ErrorCode::kUnprocessable);
}

// The Dex-Net bar clamp (tests/data/meshes): two long arms (the bar and the handle) joined by a
// ring at +x, their free ends (the jaw tips: the chamfered end of one arm, the block on the
// other) at x < -50 mm. Grasps across the arms' parallel sides are robust; grasps on the tips'
// chamfers and corners are not. Over three seeds, arm grasps rank above tip grasps: a higher
// median robust quality and a better (lower) mean rank.
TEST(MeshGraspAnalysisTest, BarClampGraspsOnTheBarAndHandleRankAboveTheJawTips) {
  std::ifstream in(testing::TestData("meshes/dexnet_bar_clamp.obj"), std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_FALSE(bytes.empty());
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    MeshFileJob job;
    job.analysis.robust_samples = 10;
    job.analysis.seed = seed;
    auto file = AnalyseMeshFile(bytes, job);
    ASSERT_TRUE(file.ok()) << file.error().message;
    const MeshGraspAnalysis& analysis = file.value().analysis;
    std::vector<double> arms, tips;
    double arm_rank = 0, tip_rank = 0;
    for (std::size_t rank = 0; rank < analysis.grasps.size(); ++rank) {
      const AnalysedGrasp& g = analysis.grasps[rank];
      const double x = g.grasp.center_m.x();
      if (x > -0.04 && x < 0.03) {
        arms.push_back(*g.robust_ferrari_canny);
        arm_rank += static_cast<double>(rank);
      } else if (x < -0.05) {
        tips.push_back(*g.robust_ferrari_canny);
        tip_rank += static_cast<double>(rank);
      }
    }
    ASSERT_GE(arms.size(), 10u);
    ASSERT_GE(tips.size(), 5u);
    const auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
      return v[v.size() / 2];
    };
    EXPECT_GT(median(arms), 1.5 * median(tips));
    EXPECT_LT(arm_rank / static_cast<double>(arms.size()),
              tip_rank / static_cast<double>(tips.size()));
  }
}

}  // namespace
}  // namespace softgrasp::mesh

namespace softgrasp::mesh {
namespace {

// A cracker box, 72 x 160 x 210 mm: with the default 50 mm stroke no grasp, and the answer says
// it is wider than the stroke in every direction and needs 72 mm; with an 85 mm stroke it has
// grasps and no reason.
TEST(MeshGraspAnalysisNoGraspTest, ABoxWiderThanTheStrokeSaysWhatStrokeItNeeds) {
  const TriangleMesh box = testing::CentredBoxMesh({0.036, 0.080, 0.105});
  MeshGraspOptions options = SmallRun();
  const MeshGraspAnalysis narrow = Analyse(box, options);
  EXPECT_TRUE(narrow.grasps.empty());
  ASSERT_TRUE(narrow.no_grasp.has_value());
  EXPECT_EQ(narrow.no_grasp->reason, NoGraspReason::kWiderThanStroke);
  EXPECT_NEAR(narrow.no_grasp->narrowest_width_m, 0.072, 1e-6);
  ASSERT_TRUE(narrow.no_grasp->needed_stroke_m.has_value());
  EXPECT_NEAR(*narrow.no_grasp->needed_stroke_m, 0.072, 1e-9);
  EXPECT_NE(narrow.no_grasp->message.find("72.0 mm"), std::string::npos)
      << narrow.no_grasp->message;
  const nlohmann::json j = codec::ToJson(narrow);
  EXPECT_EQ(j["no_grasp"]["reason"], "wider_than_stroke");
  EXPECT_NEAR(j["no_grasp"]["needed_stroke_m"].get<double>(), 0.072, 1e-9);

  options.gripper.opening_m = 0.085;
  const MeshGraspAnalysis wide = Analyse(box, options);
  EXPECT_FALSE(wide.grasps.empty());
  EXPECT_FALSE(wide.no_grasp.has_value());
  EXPECT_TRUE(codec::ToJson(wide)["no_grasp"].is_null());
}

// A box turned by an arbitrary rotation is as narrow as before: the search is not tied to the
// axes.
TEST(MeshGraspAnalysisNoGraspTest, NarrowestWidthOfARotatedBoxIsItsThinnestSide) {
  TriangleMesh box = testing::CentredBoxMesh({0.036, 0.080, 0.105});
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()) *
                             Eigen::AngleAxisd(-1.1, Eigen::Vector3d(-2, 0.5, 1).normalized()))
                                .toRotationMatrix();
  for (auto& v : box.vertices) {
    const Eigen::Vector3d p = r * Eigen::Vector3d(v[0], v[1], v[2]);
    v = {p.x(), p.y(), p.z()};
  }
  EXPECT_NEAR(NarrowestWidthM(box), 0.072, 1e-6);
  // A regular tetrahedron of edge a is narrowest between opposite edges: a / sqrt(2).
  const double a = 0.04;
  TriangleMesh tetra;
  tetra.vertices = {{0, 0, 0},
                    {a, 0, 0},
                    {a / 2, a * std::sqrt(3.0) / 2, 0},
                    {a / 2, a * std::sqrt(3.0) / 6, a * std::sqrt(2.0 / 3.0)}};
  tetra.faces = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
  EXPECT_NEAR(NarrowestWidthM(tetra), a / std::sqrt(2.0), 1e-6);
}

// What is not sampled is classified by what the grasps show: none in force closure, or none
// usable (aligned and free) in any pose.
TEST(MeshGraspAnalysisNoGraspTest, GraspsWithoutClosureOrWithoutAFreePoseSayWhy) {
  const TriangleMesh cube = testing::CentredBoxMesh({0.02, 0.02, 0.02});
  MeshGraspAnalysis analysis = Analyse(cube, SmallRun());
  ASSERT_FALSE(analysis.grasps.empty());
  EXPECT_FALSE(WhyNoGrasp(cube, analysis, SmallRun()).has_value());
  MeshGraspAnalysis blocked = analysis;
  for (AnalysedGrasp& g : blocked.grasps) {
    for (GraspInPose& p : g.poses) p.collision_free = false;
  }
  auto why = WhyNoGrasp(cube, blocked, SmallRun());
  ASSERT_TRUE(why.has_value());
  EXPECT_EQ(why->reason, NoGraspReason::kCollidesInEveryPose);
  EXPECT_FALSE(why->needed_stroke_m.has_value());
  MeshGraspAnalysis slipping = analysis;
  for (AnalysedGrasp& g : slipping.grasps) g.ferrari_canny = 0.0;
  why = WhyNoGrasp(cube, slipping, SmallRun());
  ASSERT_TRUE(why.has_value());
  EXPECT_EQ(why->reason, NoGraspReason::kNoForceClosure);
  MeshGraspAnalysis none = analysis;
  none.grasps.clear();
  why = WhyNoGrasp(cube, none, SmallRun());
  ASSERT_TRUE(why.has_value());
  EXPECT_EQ(why->reason, NoGraspReason::kNoAntipodalPair);  // 40 mm fits the 50 mm stroke
  EXPECT_NEAR(why->narrowest_width_m, 0.04, 1e-6);
}

}  // namespace
}  // namespace softgrasp::mesh
