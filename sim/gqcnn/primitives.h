#pragma once
/// Procedural primitive solids with random dimensions (docs/gqcnn-dataset.md): the "primitive"
/// source of the GQ-CNN dataset, a baseline against fractal and catalogue meshes (thesis
/// Table 4.1). Every mesh is closed, 2-manifold, one piece, outward-oriented, without zero-area
/// faces (mesh::CheckMesh passes), in metres with its bounding box centred on the origin, and
/// deterministic in the seed.

#include <cstdint>
#include <string>
#include <vector>

#include "service/mesh/mesh.h"

namespace softgrasp::sim {

/// The primitive kinds, in a fixed order: box, cylinder, ellipsoid, capsule, cone, frustum.
const std::vector<std::string>& PrimitiveKinds();

struct Primitive {
  std::string kind;  ///< one of PrimitiveKinds()
  /// The drawn dimensions, metres: box (x, y, z sides); cylinder, cone (radius, height);
  /// ellipsoid (three semi-axes); capsule (radius, straight length); frustum (bottom radius,
  /// top radius, height).
  std::vector<double> dimensions_m;
  mesh::TriangleMesh mesh;
};

/// A primitive of a kind drawn uniformly from PrimitiveKinds() with dimensions drawn uniformly
/// in [2, 12] cm per side (radii [1, 6] cm), from `seed` alone. Curved surfaces use 32 segments
/// around and 8 rings per quarter circle.
Primitive MakeRandomPrimitive(std::uint64_t seed);

}  // namespace softgrasp::sim
