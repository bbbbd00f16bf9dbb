// softgrasp-sim: the simulator's command line: `generate` (datasets of simulated scenes),
// `fractals` (batches of fractal training meshes) and `robot` (a simulated robot on the DDS bus).
// Parsing only; the work is in the libraries.
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "sim/dataset/dataset.h"
#include "sim/dataset/user_objects.h"
#include "sim/fractal_batch.h"
#include "sim/progress.h"
#include "sim/robot/robot_cli.h"

namespace {

using softgrasp::core::Result;
namespace mesh = softgrasp::mesh;
namespace io = softgrasp::io;
namespace sim = softgrasp::sim;

constexpr const char* kUsage =
    "usage: softgrasp-sim generate --scenes N --seed S --out DIR [--objects MIN-MAX]\n"
    "                              [--split train|val] [--support bin|table] [--noise on|off]\n"
    "                              [--fractals P] [--fractal-stiffness K] [--shard-size N]\n"
    "                              [--user-mesh PATH[:K|:STIFFNESS.json]]...\n"
    "                              [--camera-height M] [--intrinsics FILE.intr]\n"
    "  Simulated scenes (catalogue objects dropped with Bullet, rendered with Embree): 16-bit\n"
    "  depth (mm), 8-bit stiffness and deformability, 16-bit instance labels and one JSON\n"
    "  manifest per scene, in shards, plus index.json (docs/simulator.md). Defaults: objects\n"
    "  3-8 (at most 40; 15-30 makes dense bins whose piles reach the walls), split train,\n"
    "  support bin, noise on, fractals 0 (probability that an object is a\n"
    "  fractal mesh), fractal stiffness drawn per object unless K (0.1-1) is given. Each\n"
    "  --user-mesh (OBJ/PLY/STL in metres; constant stiffness K, default 0.5, or a JSON file\n"
    "  {\"vertex_stiffness\": [...]}) joins the draw beside the catalogue categories. The\n"
    "  camera looks straight down from M metres (default 0.55) with SR305-like intrinsics\n"
    "  (640x480) unless a GQ-CNN style .intr file gives others.\n"
    "\n"
    "usage: softgrasp-sim fractals --count N --seed S --out DIR [--alpha A] [--sigma S]\n"
    "                              [--points P] [--maps MIN-MAX] [--format F]\n"
    "  F: obj (default), ply, ply_ascii, ply_binary, stl, stl_ascii, stl_binary.\n"
    "  Writes fractal_<seed>.<ext> for seeds S..S+N-1 and index.json (docs/fractals.md).\n";

bool ParseDouble(const std::string& text, double* out) {
  char* end = nullptr;
  *out = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size();
}

bool ParseInt(const std::string& text, long long* out) {
  char* end = nullptr;
  *out = std::strtoll(text.c_str(), &end, 10);
  return !text.empty() && end == text.c_str() + text.size();
}

// "N" or "MIN-MAX".
bool ParseRange(const std::string& value, long long* lo, long long* hi) {
  const auto dash = value.find('-');
  if (dash == std::string::npos) return ParseInt(value, lo) && (*hi = *lo, true);
  return ParseInt(value.substr(0, dash), lo) && ParseInt(value.substr(dash + 1), hi);
}

// Returns an error message, or "" when `params` is filled.
std::string ParseGenerateArgs(const std::vector<std::string>& args, sim::DatasetParams* params) {
  bool have_out = false;
  bool have_scenes = false;
  params->spec.render.noise.enabled = true;
  for (std::size_t i = 0; i < args.size(); i += 2) {
    const std::string& flag = args[i];
    if (i + 1 >= args.size()) return flag + " needs a value";
    const std::string& value = args[i + 1];
    long long n = 0;
    long long m = 0;
    double x = 0;
    if (flag == "--scenes" && ParseInt(value, &n) && n >= 1 && n <= 10000000) {
      params->scenes = static_cast<int>(n);
      have_scenes = true;
    } else if (flag == "--seed" && ParseInt(value, &n) && n >= 0) {
      params->seed = static_cast<std::uint64_t>(n);
    } else if (flag == "--objects") {
      if (!ParseRange(value, &n, &m) || n < 1 || m > sim::kMaxObjectsPerScene || n > m)
        return "--objects must be N or MIN-MAX within 1-" +
               std::to_string(sim::kMaxObjectsPerScene);
      params->spec.min_objects = static_cast<int>(n);
      params->spec.max_objects = static_cast<int>(m);
    } else if (flag == "--split" && (value == "train" || value == "val")) {
      params->spec.split = value == "train" ? sim::ShapeSplit::kTrain : sim::ShapeSplit::kVal;
    } else if (flag == "--support" && (value == "bin" || value == "table")) {
      params->spec.support.kind =
          value == "bin" ? sim::Support::Kind::kBin : sim::Support::Kind::kTable;
    } else if (flag == "--noise" && (value == "on" || value == "off")) {
      params->spec.render.noise.enabled = value == "on";
    } else if (flag == "--fractals" && ParseDouble(value, &x) && x >= 0.0 && x <= 1.0) {
      params->spec.fractal_probability = x;
    } else if (flag == "--fractal-stiffness" && ParseDouble(value, &x) && x >= 0.1 && x <= 1.0) {
      params->spec.fractal_stiffness = static_cast<float>(x);
    } else if (flag == "--user-mesh") {
      auto user = sim::ParseUserObjectArg(value);
      if (!user.ok()) return "--user-mesh " + value + ": " + user.error().message;
      auto object = sim::LoadUserObject(user.value());
      if (!object.ok()) return "--user-mesh " + value + ": " + object.error().message;
      params->spec.user_objects.push_back(
          std::make_shared<const sim::SimObject>(std::move(object).value()));
    } else if (flag == "--camera-height" && ParseDouble(value, &x) && x > 0.05 && x <= 5.0) {
      params->spec.render.world_from_camera = sim::OverheadCameraPose(x);
    } else if (flag == "--intrinsics") {
      std::ifstream in(value);
      std::stringstream text;
      text << in.rdbuf();
      auto camera = io::ParseIntrinsicsJson(text.str());
      if (!in || !camera.ok()) {
        return "--intrinsics " + value + ": " +
               (in ? camera.error().message : "cannot read the file");
      }
      params->spec.render.camera = camera.value();
    } else if (flag == "--shard-size" && ParseInt(value, &n) && n >= 1 && n <= 100000) {
      params->shard_size = static_cast<int>(n);
    } else if (flag == "--out") {
      params->out_dir = value;
      have_out = true;
    } else {
      return "bad argument " + flag + " " + value;
    }
  }
  if (!have_scenes) return "--scenes is required";
  return have_out ? "" : "--out is required";
}

int RunGenerate(const std::vector<std::string>& args) {
  sim::DatasetParams params;
  if (const std::string problem = ParseGenerateArgs(args, &params); !problem.empty()) {
    std::cerr << "softgrasp-sim generate: " << problem << "\n" << kUsage;
    return 2;
  }
  sim::ProgressBar bar("scenes", params.scenes);
  auto index = sim::GenerateDataset(params, [&bar](int done) { bar.Update(done); });
  if (!index.ok()) {
    std::cerr << "softgrasp-sim generate: " << index.error().message << "\n";
    return 1;
  }
  std::cout << index.value().string() << "\n";
  return 0;
}

// Returns an error message, or "" when `params` is filled.
std::string ParseFractalsArgs(const std::vector<std::string>& args,
                              sim::FractalBatchParams* params) {
  bool have_out = false;
  for (std::size_t i = 0; i < args.size(); i += 2) {
    const std::string& flag = args[i];
    if (i + 1 >= args.size()) return flag + " needs a value";
    const std::string& value = args[i + 1];
    long long n = 0;
    double x = 0;
    if (flag == "--count" && ParseInt(value, &n) && n >= 1 && n <= 1000000) {
      params->count = static_cast<int>(n);
    } else if (flag == "--seed" && ParseInt(value, &n) && n >= 0) {
      params->seed = static_cast<std::uint64_t>(n);
    } else if (flag == "--alpha" && ParseDouble(value, &x)) {
      params->model.alpha = x;
    } else if (flag == "--sigma" && ParseDouble(value, &x)) {
      params->model.sigma = x;
    } else if (flag == "--points" && ParseInt(value, &n) && n > 0 && n <= 100000000) {
      params->model.num_points = static_cast<int>(n);
    } else if (flag == "--maps") {
      long long lo = 0, hi = 0;
      if (!ParseRange(value, &lo, &hi)) return "--maps must be N or MIN-MAX";
      params->model.min_maps = static_cast<int>(lo);
      params->model.max_maps = static_cast<int>(hi);
    } else if (flag == "--format" && mesh::MeshFormatFromName(value)) {
      params->format = *mesh::MeshFormatFromName(value);
    } else if (flag == "--out") {
      params->out_dir = value;
      have_out = true;
    } else {
      return "bad argument " + flag + " " + value;
    }
  }
  return have_out ? "" : "--out is required";
}

int RunFractals(const std::vector<std::string>& args) {
  sim::FractalBatchParams params;
  if (const std::string problem = ParseFractalsArgs(args, &params); !problem.empty()) {
    std::cerr << "softgrasp-sim fractals: " << problem << "\n" << kUsage;
    return 2;
  }
  sim::ProgressBar bar("fractals", params.count);
  auto index = sim::GenerateFractalBatch(params, [&bar](int done) { bar.Update(done); });
  if (!index.ok()) {
    std::cerr << "softgrasp-sim fractals: " << index.error().message << "\n";
    return 1;
  }
  std::cout << index.value().string() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    std::cout << kUsage << "\n" << sim::RobotUsage();
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "generate") return RunGenerate({args.begin() + 1, args.end()});
  if (args[0] == "fractals") return RunFractals({args.begin() + 1, args.end()});
  if (args[0] == "robot") return sim::RunRobotCommand({args.begin() + 1, args.end()});
  std::cerr << "softgrasp-sim: unknown command '" << args[0] << "'\n"
            << kUsage << "\n"
            << sim::RobotUsage();
  return 2;
}
