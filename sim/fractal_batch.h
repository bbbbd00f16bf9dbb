#pragma once
/// Batches of fractal meshes on disk: `softgrasp-sim fractals`.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "service/core/status.h"
#include "service/mesh/fractal.h"
#include "service/mesh/mesh_io.h"
#include "sim/tasks/array_tasks.h"

namespace softgrasp::sim {

struct FractalBatchParams {
  int count = 10;
  std::uint64_t seed = 0;     ///< model i uses seed + i
  mesh::FractalParams model;  ///< everything but the seed
  mesh::MeshFormat format = mesh::MeshFormat::kObj;
  std::filesystem::path out_dir;
  /// Task K of N writes only its part of the models and a partial index (array_tasks.h).
  ArrayTask task;
};

/// Writes `count` meshes (task K of N: its part of them) as fractal_<seed>.<ext> and an
/// index.json (a partial index for N > 1) listing each file with its seed and statistics. Calls
/// `progress(done)` after each model. Same params, same bytes, whatever the split into tasks.
/// Errors: kInvalidArgument (bad params, unwritable folder), kUnprocessable (a model could not
/// be made within max_attempts).
core::Result<std::filesystem::path> GenerateFractalBatch(
    const FractalBatchParams& params, const std::function<void(int done)>& progress = {});

}  // namespace softgrasp::sim
