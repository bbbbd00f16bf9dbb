#pragma once
/// The object catalogue: procedural daily items whose surfaces carry stiffness fields derived
/// from how each item is built (docs/sim-catalogue.md), plus user and fractal meshes.
/// Every object is deterministic in (category, split, seed).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "service/core/status.h"
#include "service/mesh/mesh.h"
#include "sim/scene/scene.h"

namespace softgrasp::sim {

/// Which shape-parameter ranges to draw from. Validation shapes come from sub-ranges disjoint
/// from the training ones (documented per category), so they are never seen in training.
enum class ShapeSplit { kTrain, kVal };

/// "train" / "val".
const char* ShapeSplitName(ShapeSplit split);

/// The procedural categories, in a fixed order: bottle, box, can, cup, sponge, block, brush.
const std::vector<std::string>& CatalogueCategories();

/// Builds one object of `category` with shape parameters drawn from `split`'s ranges using
/// `seed`. The result's mesh is closed, 2-manifold, connected and outward (mesh::CheckMesh ok),
/// in metres with its origin at the centre of mass; `shape` lists the drawn parameters and
/// the split. Errors: kInvalidArgument (field "category") for an unknown category.
core::Result<SimObject> MakeCatalogueObject(std::string_view category, ShapeSplit split,
                                            std::uint64_t seed);

/// Turns a user or fractal mesh (metres, any origin) into a catalogue object: recentred on its
/// centre of mass (uniform density), mass = volume * density. `vertex_stiffness` empty means
/// `constant_stiffness` everywhere; otherwise one score per vertex (each quantised).
/// Errors (kInvalidArgument, with the field at fault): "mesh" when it is not closed, manifold,
/// outward with positive volume; "vertex_stiffness" for a wrong length or non-finite score;
/// "stiffness" outside [0.1, 1]; "density_kg_m3" not in (0, 20000].
core::Result<SimObject> MakeMeshObject(mesh::TriangleMesh mesh_m,
                                       std::vector<float> vertex_stiffness,
                                       float constant_stiffness, double density_kg_m3,
                                       std::string category = "user",
                                       nlohmann::json shape = nlohmann::json::object());

}  // namespace softgrasp::sim
