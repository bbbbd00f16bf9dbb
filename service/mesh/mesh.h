#pragma once
/// The triangle-mesh value type shared by the fractal generator, the mesh checks and the codecs.

#include <array>
#include <vector>

namespace softgrasp::mesh {

/// An indexed triangle mesh. Faces list vertex indices counter-clockwise as seen from outside,
/// so the right-hand normal points outward. Units are whatever the producer says (the fractal
/// generator gives metres).
struct TriangleMesh {
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::array<int, 3>> faces;

  friend bool operator==(const TriangleMesh&, const TriangleMesh&) = default;
};

}  // namespace softgrasp::mesh
