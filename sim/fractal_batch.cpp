#include "sim/fractal_batch.h"

#include <nlohmann/json.hpp>
#include <system_error>

#include "service/cli/files.h"

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

json Entry(const std::string& file, std::uint64_t seed, const mesh::FractalModel& m) {
  return {{"file", file},
          {"seed", seed},
          {"vertices", m.mesh.vertices.size()},
          {"faces", m.mesh.faces.size()},
          {"volume_m3", m.volume_m3},
          {"bbox_min_m", m.bbox_min_m},
          {"bbox_max_m", m.bbox_max_m},
          {"maps", m.ifs.maps.size()},
          {"alpha_requested", m.alpha_requested},
          {"alpha_used", m.alpha_used},
          {"pieces_dropped", m.pieces_dropped},
          {"attempts", m.attempts}};
}

}  // namespace

core::Result<std::filesystem::path> GenerateFractalBatch(
    const FractalBatchParams& params, const std::function<void(int done)>& progress) {
  if (params.count < 1)
    return MakeError(ErrorCode::kInvalidArgument, "--count must be >= 1", "count");
  if (auto invalid = mesh::ValidateFractalParams(params.model)) return *invalid;
  std::error_code ec;
  std::filesystem::create_directories(params.out_dir, ec);
  if (ec) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "cannot create " + params.out_dir.string() + ": " + ec.message(), "out");
  }
  if (const std::string bad = CheckArrayTask(params.task, params.count); !bad.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, bad, "task");
  }
  const ItemRange items = TaskItems(params.task, params.count);
  json models = json::array();
  for (int i = items.first; i < items.end; ++i) {
    mesh::FractalParams p = params.model;
    p.seed = params.seed + static_cast<std::uint64_t>(i);
    auto model = mesh::GenerateFractal(p);
    if (!model.ok()) return model.error();
    const std::string file =
        "fractal_" + std::to_string(p.seed) + "." + mesh::MeshFileExtension(params.format);
    if (auto error = cli::WriteFile(params.out_dir / file,
                                    mesh::WriteMesh(model.value().mesh, params.format))) {
      return MakeError(ErrorCode::kInvalidArgument, error->message, "out");
    }
    models.push_back(Entry(file, p.seed, model.value()));
    if (progress) progress(i + 1 - items.first);
  }
  const json index = {{"generator", "softgrasp 3D-IFS + alpha shape"},
                      {"format", mesh::MeshFormatName(params.format)},
                      {"seed", params.seed},
                      {"count", params.count},
                      {"points", params.model.num_points},
                      {"sigma", params.model.sigma},
                      {"alpha", params.model.alpha},
                      {"maps", {params.model.min_maps, params.model.max_maps}},
                      {"gripper_opening_m", params.model.gripper_opening_m},
                      {"fit_fraction", params.model.fit_fraction},
                      {"models", models}};
  return WriteTaskIndex(params.out_dir, index, params.task, items, "models");
}

}  // namespace softgrasp::sim
