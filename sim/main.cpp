// softgrasp-sim: the simulator's command line. Subcommands grow with the simulator issues;
// today: `fractals` (batches of fractal training meshes).
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "sim/fractal_batch.h"
#include "sim/progress.h"

namespace {

using softgrasp::core::Result;
namespace mesh = softgrasp::mesh;
namespace sim = softgrasp::sim;

constexpr const char* kUsage =
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

// Returns an error message, or "" when `params` is filled.
std::string ParseFractalsArgs(const std::vector<std::string>& args, sim::FractalBatchParams* params) {
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
      const auto dash = value.find('-');
      const bool ok = dash == std::string::npos
                          ? ParseInt(value, &lo) && (hi = lo, true)
                          : ParseInt(value.substr(0, dash), &lo) && ParseInt(value.substr(dash + 1), &hi);
      if (!ok) return "--maps must be N or MIN-MAX";
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
    std::cout << kUsage;
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "fractals") return RunFractals({args.begin() + 1, args.end()});
  std::cerr << "softgrasp-sim: unknown command '" << args[0] << "'\n" << kUsage;
  return 2;
}
