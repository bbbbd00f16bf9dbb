#include "sim/gqcnn/primitives.h"

#include <cmath>
#include <numbers>
#include <random>
#include <utility>

namespace softgrasp::sim {
namespace {

constexpr int kSegments = 32;
constexpr int kQuarterRings = 8;

/// Uniform in [lo, hi) from the top 53 bits (same bytes on every platform).
double Draw(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

mesh::TriangleMesh Box(double x, double y, double z) {
  mesh::TriangleMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.push_back(
        {(i & 1 ? 0.5 : -0.5) * x, (i & 2 ? 0.5 : -0.5) * y, (i & 4 ? 0.5 : -0.5) * z});
  }
  // Two counter-clockwise triangles (seen from outside) per face.
  m.faces = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
             {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

/// Revolves a profile of (r, z) points about z: it starts and ends on the axis (r = 0, the
/// poles), has r > 0 in between and runs bottom to top with the solid on its left.
mesh::TriangleMesh Revolve(const std::vector<std::pair<double, double>>& profile) {
  mesh::TriangleMesh m;
  const int rings = static_cast<int>(profile.size()) - 2;
  m.vertices.push_back({0.0, 0.0, profile.front().second});
  for (int k = 0; k < rings; ++k) {
    const auto [r, z] = profile[static_cast<std::size_t>(k) + 1];
    for (int j = 0; j < kSegments; ++j) {
      const double a = 2.0 * std::numbers::pi * j / kSegments;
      m.vertices.push_back({r * std::cos(a), r * std::sin(a), z});
    }
  }
  const int top = static_cast<int>(m.vertices.size());
  m.vertices.push_back({0.0, 0.0, profile.back().second});
  const auto ring = [](int k, int j) { return 1 + k * kSegments + (j % kSegments); };
  for (int j = 0; j < kSegments; ++j) m.faces.push_back({0, ring(0, j + 1), ring(0, j)});
  for (int k = 0; k + 1 < rings; ++k) {
    for (int j = 0; j < kSegments; ++j) {
      m.faces.push_back({ring(k, j), ring(k, j + 1), ring(k + 1, j + 1)});
      m.faces.push_back({ring(k, j), ring(k + 1, j + 1), ring(k + 1, j)});
    }
  }
  for (int j = 0; j < kSegments; ++j) {
    m.faces.push_back({top, ring(rings - 1, j), ring(rings - 1, j + 1)});
  }
  return m;
}

/// Half circle of radius r about (0, z0) from angle a0 to a1 (0 = straight down), as profile
/// points without the poles.
void Arc(double r, double z0, double a0, double a1, int steps,
         std::vector<std::pair<double, double>>* profile) {
  for (int i = 0; i <= steps; ++i) {
    const double a = a0 + (a1 - a0) * i / steps;
    const double pr = r * std::sin(a);
    if (pr <= 1e-12) continue;  // the poles are added by the caller
    profile->emplace_back(pr, z0 - r * std::cos(a));
  }
}

void CentreBoundingBox(mesh::TriangleMesh* m) {
  std::array<double, 3> lo{1e9, 1e9, 1e9};
  std::array<double, 3> hi{-1e9, -1e9, -1e9};
  for (const auto& v : m->vertices) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], v[a]);
      hi[a] = std::max(hi[a], v[a]);
    }
  }
  for (auto& v : m->vertices) {
    for (int a = 0; a < 3; ++a) v[a] -= 0.5 * (lo[a] + hi[a]);
  }
}

}  // namespace

const std::vector<std::string>& PrimitiveKinds() {
  static const std::vector<std::string> kinds = {"box",     "cylinder", "ellipsoid",
                                                 "capsule", "cone",     "frustum"};
  return kinds;
}

Primitive MakeRandomPrimitive(std::uint64_t seed) {
  std::mt19937_64 rng(seed ^ 0x5052494D49544956ull);  // "PRIMITIV"
  const auto& kinds = PrimitiveKinds();
  Primitive p;
  p.kind = kinds[static_cast<std::size_t>(rng() % kinds.size())];
  const double half_pi = 0.5 * std::numbers::pi;
  if (p.kind == "box") {
    p.dimensions_m = {Draw(rng, 0.02, 0.12), Draw(rng, 0.02, 0.12), Draw(rng, 0.02, 0.12)};
    p.mesh = Box(p.dimensions_m[0], p.dimensions_m[1], p.dimensions_m[2]);
  } else if (p.kind == "cylinder") {
    const double r = Draw(rng, 0.01, 0.06);
    const double h = Draw(rng, 0.02, 0.12);
    p.dimensions_m = {r, h};
    p.mesh = Revolve({{0.0, 0.0}, {r, 0.0}, {r, h}, {0.0, h}});
  } else if (p.kind == "ellipsoid") {
    const double a = Draw(rng, 0.01, 0.06);
    const double b = Draw(rng, 0.01, 0.06);
    const double c = Draw(rng, 0.01, 0.06);
    p.dimensions_m = {a, b, c};
    std::vector<std::pair<double, double>> profile{{0.0, -1.0}};
    Arc(1.0, 0.0, 0.0, std::numbers::pi, 2 * kQuarterRings, &profile);
    profile.emplace_back(0.0, 1.0);
    p.mesh = Revolve(profile);
    for (auto& v : p.mesh.vertices) {
      v[0] *= a;
      v[1] *= b;
      v[2] *= c;
    }
  } else if (p.kind == "capsule") {
    const double r = Draw(rng, 0.01, 0.06);
    const double l = Draw(rng, 0.005, 0.10);
    p.dimensions_m = {r, l};
    std::vector<std::pair<double, double>> profile{{0.0, -r}};
    Arc(r, 0.0, 0.0, half_pi, kQuarterRings, &profile);
    Arc(r, l, half_pi, std::numbers::pi, kQuarterRings, &profile);
    profile.emplace_back(0.0, l + r);
    p.mesh = Revolve(profile);
  } else if (p.kind == "cone") {
    const double r = Draw(rng, 0.01, 0.06);
    const double h = Draw(rng, 0.02, 0.12);
    p.dimensions_m = {r, h};
    p.mesh = Revolve({{0.0, 0.0}, {r, 0.0}, {0.0, h}});
  } else {  // frustum
    const double r0 = Draw(rng, 0.01, 0.06);
    const double r1 = Draw(rng, 0.005, r0);
    const double h = Draw(rng, 0.02, 0.12);
    p.dimensions_m = {r0, r1, h};
    p.mesh = Revolve({{0.0, 0.0}, {r0, 0.0}, {r1, h}, {0.0, h}});
  }
  CentreBoundingBox(&p.mesh);
  return p;
}

}  // namespace softgrasp::sim
