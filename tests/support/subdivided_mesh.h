#pragma once
/// Uniform subdivision of a triangle mesh (same geometry, more triangles) for tests and benchmarks
/// that need a mesh of a given size: each triangle is split into n x n sub-triangles on its
/// barycentric grid. Header-only, on mesh.h alone.

#include <array>
#include <map>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include "service/mesh/mesh.h"

namespace softgrasp::testing {

/// `mesh` with vertices of equal coordinates merged (a triangle soup, e.g. an OBJ file that
/// repeats each corner per face, becomes an indexed mesh), numbered in order of first use by the
/// faces; unused vertices are dropped.
inline mesh::TriangleMesh WeldVertices(const mesh::TriangleMesh& mesh) {
  mesh::TriangleMesh out;
  std::map<std::array<double, 3>, int> index;
  for (const auto& f : mesh.faces) {
    std::array<int, 3> face{};
    for (int k = 0; k < 3; ++k) {
      const auto& v = mesh.vertices.at(static_cast<std::size_t>(f[static_cast<std::size_t>(k)]));
      const auto [it, added] = index.try_emplace(v, static_cast<int>(out.vertices.size()));
      if (added) out.vertices.push_back(v);
      face[static_cast<std::size_t>(k)] = it->second;
    }
    out.faces.push_back(face);
  }
  return out;
}

/// Every triangle of WeldVertices(mesh) split into n x n triangles on its barycentric grid
/// (n^2 times the faces, same orientation). The grid points on a shared edge or corner are
/// computed from the edge's two end vertices alone, in a fixed order, and welded, so a closed
/// mesh stays closed and the surface is exactly the same point set up to rounding. n = 1 gives
/// the welded mesh. @throws std::invalid_argument for n < 1.
inline mesh::TriangleMesh SubdivideMesh(const mesh::TriangleMesh& mesh, int n) {
  if (n < 1) throw std::invalid_argument("SubdivideMesh: n must be >= 1");
  const mesh::TriangleMesh welded = WeldVertices(mesh);
  mesh::TriangleMesh out;
  out.vertices = welded.vertices;
  const auto lerp = [&](int a, int b, int weight_a) {  // (weight_a a + (n - weight_a) b) / n
    const auto& va = welded.vertices[static_cast<std::size_t>(a)];
    const auto& vb = welded.vertices[static_cast<std::size_t>(b)];
    std::array<double, 3> p{};
    for (std::size_t i = 0; i < 3; ++i) p[i] = (weight_a * va[i] + (n - weight_a) * vb[i]) / n;
    return p;
  };
  // Edge points by (smaller vertex, larger vertex, weight of the smaller one).
  std::map<std::tuple<int, int, int>, int> edge_points;
  const auto add = [&](const std::array<double, 3>& p) {
    out.vertices.push_back(p);
    return static_cast<int>(out.vertices.size()) - 1;
  };
  for (const auto& f : welded.faces) {
    // Grid point (i, j): barycentric weights (n - i - j, i, j) / n on the corners f[0], f[1], f[2].
    std::vector<int> grid(static_cast<std::size_t>((n + 1) * (n + 1)), -1);
    const auto at = [&](int i, int j) -> int& {
      return grid[static_cast<std::size_t>(i * (n + 1) + j)];
    };
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) {
        const std::array<int, 3> w{n - i - j, i, j};
        int zeros = 0;
        for (const int x : w) zeros += x == 0 ? 1 : 0;
        if (zeros == 2) {  // a corner
          for (std::size_t k = 0; k < 3; ++k) {
            if (w[k] == n) at(i, j) = f[k];
          }
        } else if (zeros == 1) {  // on the edge between the two corners of non-zero weight
          std::array<std::size_t, 2> ends{};
          std::size_t e = 0;
          for (std::size_t k = 0; k < 3; ++k) {
            if (w[k] != 0) ends[e++] = k;
          }
          int a = f[ends[0]], b = f[ends[1]];
          int weight_a = w[ends[0]];
          if (a > b) {
            std::swap(a, b);
            weight_a = n - weight_a;
          }
          const auto [it, added] = edge_points.try_emplace({a, b, weight_a}, -1);
          if (added) it->second = add(lerp(a, b, weight_a));
          at(i, j) = it->second;
        } else {  // interior
          std::array<double, 3> p{};
          for (std::size_t c = 0; c < 3; ++c) {
            double sum = 0.0;
            for (std::size_t k = 0; k < 3; ++k) {
              sum += w[k] * welded.vertices[static_cast<std::size_t>(f[k])][c];
            }
            p[c] = sum / n;
          }
          at(i, j) = add(p);
        }
      }
    }
    // Two triangles per grid cell (one at the far edge), counter-clockwise like the parent: the
    // parent's corners are (0,0), (1,0), (0,1) in (i, j).
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        out.faces.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
        if (i + j + 1 < n) out.faces.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
  }
  return out;
}

}  // namespace softgrasp::testing
