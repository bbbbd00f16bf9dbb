#pragma once
/// Closed, outward-oriented box meshes with known answers (volume, area, what a camera sees).

#include <Eigen/Core>

#include "service/mesh/mesh.h"

namespace softgrasp::testing {

/// The axis-aligned box [min_corner, max_corner]. Corner i takes max_corner in x when bit 0 of i is
/// set, in y for bit 1, in z for bit 2 (else min_corner). 12 triangles, counter-clockwise seen
/// from outside, two per side in the order -z, +z, -y, +y, -x, +x.
inline mesh::TriangleMesh BoxMesh(const Eigen::Vector3d& min_corner,
                                  const Eigen::Vector3d& max_corner) {
  mesh::TriangleMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.push_back({(i & 1) ? max_corner.x() : min_corner.x(),
                          (i & 2) ? max_corner.y() : min_corner.y(),
                          (i & 4) ? max_corner.z() : min_corner.z()});
  }
  m.faces = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 5}, {0, 5, 4},
             {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  return m;
}

/// The box [-half_m, half_m], centred on the origin (metres).
inline mesh::TriangleMesh CentredBoxMesh(const Eigen::Vector3d& half_m) {
  return BoxMesh(-half_m, half_m);
}

}  // namespace softgrasp::testing
