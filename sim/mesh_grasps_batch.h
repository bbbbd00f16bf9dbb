#pragma once
/// Mesh grasp analyses of files on disk: `softgrasp-sim mesh-grasps` (docs/mesh-grasps.md).

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "service/core/status.h"
#include "service/mesh_grasps/mesh_grasp_analysis.h"

namespace softgrasp::sim {

struct MeshGraspBatchParams {
  std::vector<std::filesystem::path> meshes;  ///< OBJ, PLY or STL files
  std::filesystem::path out_dir;
  mesh::MeshFileJob job;  ///< the same for every file
  bool png = false;       ///< also a preview of each mesh's most probable pose
  int preview_grasps = 10;
};

struct MeshGraspBatchResult {
  std::filesystem::path index;  ///< out_dir/index.json
  int analysed = 0;
  /// "PATH: message" per file that could not be read or analysed (the others are written).
  std::vector<std::string> failures;
};

/// For each mesh, writes <stem>.json (codec::ToJson of its MeshFileAnalysis; "-2", "-3", ...
/// appended to repeated stems) and with `png` <stem>.png; then index.json listing each input
/// with its output or its error. Calls `progress(done)` after each mesh. A file that cannot be
/// read or analysed is a failure in the result, not an error: the others still run. Errors:
/// kInvalidArgument for no meshes or options out of range, and the folder's write errors.
core::Result<MeshGraspBatchResult> AnalyseMeshBatch(
    const MeshGraspBatchParams& params, const std::function<void(int done)>& progress = {});

}  // namespace softgrasp::sim
