#pragma once
/// User meshes joining the catalogue: an OBJ/PLY/STL file in metres with a constant stiffness
/// or a per-vertex stiffness file (JSON {"vertex_stiffness": [s0, s1, ...]}, one per vertex in
/// the mesh file's vertex order).

#include <filesystem>
#include <string>

#include "service/core/status.h"
#include "sim/scene/scene.h"

namespace softgrasp::sim {

struct UserObjectSpec {
  std::filesystem::path mesh_path;
  float stiffness = 0.5f;                ///< used when stiffness_path is empty; [0.1, 1]
  std::filesystem::path stiffness_path;  ///< optional per-vertex stiffness JSON
  double density_kg_m3 = 500.0;
};

/// Parses the command-line form PATH[:K | :STIFFNESS.json] (K a number in [0.1, 1]).
core::Result<UserObjectSpec> ParseUserObjectArg(const std::string& arg);

/// Reads, validates and builds the object (category "user", shape {"file", "stiffness"...}).
/// Vertices with exactly equal coordinates are welded first (triangle-soup exports), keeping
/// the first occurrence's stiffness.
/// Errors: kInvalidArgument naming "mesh_path"/"stiffness_path" when a file cannot be read,
/// the decoder's error for a broken mesh file, MakeMeshObject's errors for an unusable mesh.
core::Result<SimObject> LoadUserObject(const UserObjectSpec& spec);

}  // namespace softgrasp::sim
