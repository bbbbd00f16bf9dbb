#pragma once
// Small closed meshes with known answers for the mesh tests (boxes: tests/support/box_mesh.h).

#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "service/mesh/mesh.h"

namespace softgrasp::mesh::testing {

/// Regular tetrahedron-like simplex (0,0,0), (1,0,0), (0,1,0), (0,0,1), outward.
inline TriangleMesh MakeTetrahedron() {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

/// Octahedron with vertices at +-1 on each axis (+x, -x, +y, -y, +z, -z), outward.
inline TriangleMesh MakeOctahedron() {
  TriangleMesh m;
  m.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.faces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
             {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return m;
}

/// Torus around z (radii R > r), n x m quads split in two, outward.
inline TriangleMesh MakeTorus(double big_r = 2.0, double small_r = 0.5, int n = 16, int m = 8) {
  TriangleMesh t;
  const double kPi = std::acos(-1.0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      const double u = 2 * kPi * i / n, v = 2 * kPi * j / m;
      t.vertices.push_back({(big_r + small_r * std::cos(v)) * std::cos(u),
                            (big_r + small_r * std::cos(v)) * std::sin(u), small_r * std::sin(v)});
    }
  }
  auto id = [&](int i, int j) { return ((i + n) % n) * m + (j + m) % m; };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      t.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  }
  return t;
}

/// Both meshes in one (indices of b shifted).
inline TriangleMesh Merge(TriangleMesh a, const TriangleMesh& b) {
  const int offset = static_cast<int>(a.vertices.size());
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto f : b.faces) a.faces.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
  return a;
}

}  // namespace softgrasp::mesh::testing
