#pragma once
/// Internal to softgrasp::mesh: the small pieces the mesh checks (mesh_check.cpp) and the
/// preparation of uploads (mesh_prepare.cpp) both walk a mesh's topology with: union-find over
/// indices, half-edges sorted by their undirected edge, and that edge's key; and how the repair
/// and refusal lines of the preparation and the hole filling write a percentage.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <string>
#include <vector>

namespace softgrasp::mesh::internal {

/// Disjoint sets over 0..n-1 with path halving; a set's root is its smallest member.
class UnionFind {
 public:
  explicit UnionFind(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  std::size_t Find(std::size_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void Union(std::size_t a, std::size_t b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<std::size_t> parent_;
};

/// A face's directed edge from -> to.
struct HalfEdge {
  std::uint64_t key;  ///< undirected edge: min << 32 | max
  int from;
  int to;
  int face;
};

/// The undirected edge {a, b} as one number (indices are non-negative ints).
inline std::uint64_t EdgeKey(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b));
  const auto hi = static_cast<std::uint64_t>(std::max(a, b));
  return lo << 32 | hi;
}

/// A fraction as a percentage with three significant digits: 0.0118 -> "1.18%".
inline std::string Percent(double fraction) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g%%", 100.0 * fraction);
  return text;
}

}  // namespace softgrasp::mesh::internal
