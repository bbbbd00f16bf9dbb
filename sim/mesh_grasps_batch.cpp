#include "sim/mesh_grasps_batch.h"

#include <map>
#include <nlohmann/json.hpp>
#include <utility>

#include "service/cli/files.h"
#include "service/codec/mesh_grasps_json.h"
#include "service/io/depth_codec.h"
#include "service/io/overlay.h"

namespace softgrasp::sim {
namespace {

using nlohmann::json;

// Output stems: the file's stem, "-2", "-3", ... appended when it repeats.
std::vector<std::string> UniqueStems(const std::vector<std::filesystem::path>& meshes) {
  std::map<std::string, int> seen;
  std::vector<std::string> stems;
  for (const auto& path : meshes) {
    const std::string stem = path.stem().string().empty() ? "mesh" : path.stem().string();
    const int n = ++seen[stem];
    stems.push_back(n == 1 ? stem : stem + "-" + std::to_string(n));
  }
  return stems;
}

}  // namespace

core::Result<MeshGraspBatchResult> AnalyseMeshBatch(const MeshGraspBatchParams& params,
                                                    const std::function<void(int done)>& progress) {
  if (params.meshes.empty()) {
    return core::MakeError(core::ErrorCode::kInvalidArgument, "no mesh files given", "meshes");
  }
  std::error_code ec;
  std::filesystem::create_directories(params.out_dir, ec);
  if (ec) {
    return core::MakeError(core::ErrorCode::kInvalidArgument,
                           "cannot create " + params.out_dir.string() + ": " + ec.message(), "out");
  }
  MeshGraspBatchResult result;
  json index = {{"meshes", json::array()}};
  const std::vector<std::string> stems = UniqueStems(params.meshes);
  for (std::size_t i = 0; i < params.meshes.size(); ++i) {
    const std::filesystem::path& path = params.meshes[i];
    json entry = {{"input", path.string()}};
    auto bytes = cli::ReadFile(path);
    core::Result<mesh::MeshFileAnalysis> analysed =
        bytes.ok() ? mesh::AnalyseMeshFile(bytes.value(), params.job)
                   : core::Result<mesh::MeshFileAnalysis>(bytes.error());
    if (!analysed.ok()) {
      entry["error"] = analysed.error().message;
      result.failures.push_back(path.string() + ": " + analysed.error().message);
    } else {
      const std::string json_name = stems[i] + ".json";
      if (auto error = cli::WriteFile(params.out_dir / json_name,
                                      codec::ToJson(analysed.value()).dump(1) + "\n")) {
        return *error;
      }
      entry["output"] = json_name;
      entry["stable_poses"] = analysed.value().analysis.poses.size();
      entry["grasps"] = analysed.value().analysis.grasps.size();
      if (params.png) {
        auto view =
            mesh::RenderPoseView(analysed.value().prepared.mesh, analysed.value().analysis, 0,
                                 params.job.analysis.gripper, 480, params.preview_grasps);
        if (!view.ok()) return view.error();
        const std::string png_name = stems[i] + ".png";
        if (auto error = cli::WriteFile(
                params.out_dir / png_name,
                io::EncodePng(io::RenderGraspOverlay(view.value().depth, view.value().grasps)))) {
          return *error;
        }
        entry["preview"] = png_name;
      }
      ++result.analysed;
    }
    index["meshes"].push_back(std::move(entry));
    if (progress) progress(static_cast<int>(i) + 1);
  }
  result.index = params.out_dir / "index.json";
  if (auto error = cli::WriteFile(result.index, index.dump(1) + "\n")) return *error;
  return result;
}

}  // namespace softgrasp::sim
