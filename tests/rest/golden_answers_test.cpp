// The service's answers on the real frames and mesh kept with the tests, compared with golden
// copies (tests/data/golden/answers.json): every strategy's grasps on the Primesense and PhoXi
// frames, both segmenters, a mesh analysis and /v1/info's defaults. A change to how requests are
// parsed, planned or written that moves any of them shows up here as the path of the first value
// that differs. Timings and build facts are left out; numbers compare to 1e-6 relative (1e-9
// absolute), so that another CPU's BLAS kernels do not count as a change while a grasp moved by a
// pixel does.
//
// To write the golden copies anew after a change that is meant to move answers:
//   SOFTGRASP_WRITE_GOLDEN=1 build/tests/rest/rest_golden_answers_test
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

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

const std::string kGoldenPath = TestData("golden/answers.json");

// Drops what changes from run to run or build to build.
void StripVolatile(json& value) {
  if (value.is_object()) {
    for (const char* key :
         {"timing_ms", "milliseconds", "sample_ms", "evaluate_ms", "build", "version"}) {
      value.erase(key);
    }
    for (auto& [key, child] : value.items()) StripVolatile(child);
  } else if (value.is_array()) {
    for (json& child : value) StripVolatile(child);
  }
}

// The first difference between `expected` and `actual` ("" when none), as a JSON path.
std::string FirstDifference(const json& expected, const json& actual, const std::string& path) {
  if (expected.is_number() && actual.is_number()) {
    const double e = expected.get<double>(), a = actual.get<double>();
    if (std::abs(e - a) <= 1e-9 + 1e-6 * std::max(std::abs(e), std::abs(a))) return "";
    return path + ": expected " + expected.dump() + ", got " + actual.dump();
  }
  if (expected.type() != actual.type()) {
    return path + ": expected " + expected.dump() + ", got " + actual.dump();
  }
  if (expected.is_object()) {
    for (const auto& [key, child] : expected.items()) {
      if (!actual.contains(key)) return path + "." + key + ": missing";
      const std::string d = FirstDifference(child, actual.at(key), path + "." + key);
      if (!d.empty()) return d;
    }
    for (const auto& [key, child] : actual.items()) {
      if (!expected.contains(key)) return path + "." + key + ": not in the golden copy";
    }
    return "";
  }
  if (expected.is_array()) {
    if (expected.size() != actual.size()) {
      return path + ": " + std::to_string(expected.size()) + " elements expected, got " +
             std::to_string(actual.size());
    }
    for (std::size_t i = 0; i < expected.size(); ++i) {
      const std::string d =
          FirstDifference(expected[i], actual[i], path + "[" + std::to_string(i) + "]");
      if (!d.empty()) return d;
    }
    return "";
  }
  return expected == actual ? ""
                            : path + ": expected " + expected.dump() + ", got " + actual.dump();
}

struct Frame {
  std::string name;
  std::string depth;
  std::string intrinsics;
  std::vector<FormPart> extra;  // e.g. min_depth_m for the wrist camera's fingers
};

std::vector<Frame> Frames() {
  std::vector<Frame> frames;
  for (int i = 0; i < 3; ++i) {
    frames.push_back({"primesense_" + std::to_string(i),
                      "gqcnn/primesense/single_depth_" + std::to_string(i) + ".npy",
                      "gqcnn/primesense/primesense.intr",
                      {{"min_depth_m", "0.6", ""}}});
  }
  frames.push_back(
      {"phoxi_clutter", "gqcnn/phoxi/clutter_depth_0.npy", "gqcnn/phoxi/phoxi.intr", {}});
  return frames;
}

std::vector<FormPart> Upload(const Frame& frame) {
  std::vector<FormPart> parts = {
      {"depth", ReadFileBytes(TestData(frame.depth)), "d.npy"},
      {"intrinsics", ReadFileBytes(TestData(frame.intrinsics)), "c.intr"}};
  parts.insert(parts.end(), frame.extra.begin(), frame.extra.end());
  return parts;
}

// Every case's stripped answer, by name.
json CurrentAnswers() {
  const RunningServer server({}, nullptr, nullptr, testing::ShippedStiffnessModel(),
                             testing::ShippedSegmentationModel(), testing::ShippedGqcnnModel());
  json answers = json::object();
  const auto record = [&answers](const std::string& name, const testing::HttpReply& reply) {
    json body = json::parse(reply.body, nullptr, false);
    if (body.is_discarded()) body = "non-JSON body";
    StripVolatile(body);
    answers[name] = {{"status", reply.status}, {"body", body}};
  };
  for (const Frame& frame : Frames()) {
    for (const char* strategy : {"fge", "stiffness", "gqcnn", "deformability"}) {
      std::vector<FormPart> parts = Upload(frame);
      parts.push_back({"strategy", strategy, ""});
      record("grasps/" + std::string(strategy) + "/" + frame.name,
             server.Send(MultipartRequest("/v1/grasps", parts)));
    }
    for (const char* method : {"model", "pcl"}) {
      std::vector<FormPart> parts = Upload(frame);
      parts.erase(parts.begin() + 2, parts.end());  // segmentation takes no min_depth_m
      parts.push_back({"method", method, ""});
      record("segmentation/" + std::string(method) + "/" + frame.name,
             server.Send(MultipartRequest("/v1/segmentation", parts)));
    }
  }
  // The PhoXi frame with its segmask, the fge grasps reporting instances and mean stiffness.
  {
    const Frame phoxi = Frames().back();
    std::vector<FormPart> parts = Upload(phoxi);
    parts.push_back(
        {"segmask", ReadFileBytes(TestData("gqcnn/phoxi/clutter_segmask_0.png")), "m.png"});
    parts.push_back({"strategy", "fge", ""});
    parts.push_back({"instances", "true", ""});
    parts.push_back({"mean_stiffness", "true", ""});
    record("grasps/fge/phoxi_clutter_segmask", server.Send(MultipartRequest("/v1/grasps", parts)));
  }
  record("meshes/dexnet_bar_clamp",
         server.Send(RawRequest("POST", "/v1/meshes/grasps?num_grasps=20&robust_samples=5&seed=2",
                                "application/octet-stream",
                                ReadFileBytes(TestData("meshes/dexnet_bar_clamp.obj")))));
  record("info", server.Send(RawRequest("GET", "/v1/info")));
  return answers;
}

TEST(GoldenAnswersTest, AnswersOnTheRealFramesAndMeshAreUnchanged) {
  const json current = CurrentAnswers();
  if (std::getenv("SOFTGRASP_WRITE_GOLDEN") != nullptr) {
    std::ofstream(kGoldenPath) << current.dump(1) << "\n";
    GTEST_SKIP() << "wrote " << kGoldenPath;
  }
  std::ifstream in(kGoldenPath);
  ASSERT_TRUE(in) << "no golden copy at " << kGoldenPath;
  const json golden = json::parse(in);
  for (const auto& [name, expected] : golden.items()) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(current.contains(name)) << "case no longer answered";
    EXPECT_EQ(FirstDifference(expected, current.at(name), "$"), "");
  }
  EXPECT_EQ(golden.size(), current.size()) << "cases were added: write the golden copy anew";
}

}  // namespace
}  // namespace softgrasp::rest
