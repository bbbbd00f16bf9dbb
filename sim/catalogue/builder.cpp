// Mesh-building helpers of the catalogue: seeded draws, solids of revolution, unions of cells.
#include "sim/catalogue/builder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "sim/scene/scene.h"

namespace softgrasp::sim::catalogue_internal {

std::pair<double, double> HeldOutBand(double lo, double hi, int band) {
  const double width = (hi - lo) / kHeldOutBands;
  return {lo + band * width, band + 1 == kHeldOutBands ? hi : lo + (band + 1) * width};
}

ShapeSampler::ShapeSampler(std::uint64_t rng_seed, ShapeSplit split)
    : rng_(rng_seed), split_(split) {
  shape_["split"] = ShapeSplitName(split);
}

double ShapeSampler::Unit() {
  // The top 53 bits of one draw, exactly representable: [0, 1) on every platform.
  return static_cast<double>(rng_() >> 11) * 0x1.0p-53;
}

double ShapeSampler::Uniform(const char* name, double lo, double hi) {
  const double value = lo + (hi - lo) * Unit();
  shape_[name] = value;
  return value;
}

double ShapeSampler::HeldOut(const char* name, double lo, double hi) {
  // Train: bands 0, 2, 4; val: bands 1, 3. One draw picks the band, one the place in it.
  static constexpr std::array<int, 3> kTrainBands = {0, 2, 4};
  static constexpr std::array<int, 2> kValBands = {1, 3};
  const double pick = Unit();
  const int band = split_ == ShapeSplit::kTrain
                       ? kTrainBands[static_cast<std::size_t>(pick * kTrainBands.size())]
                       : kValBands[static_cast<std::size_t>(pick * kValBands.size())];
  const auto [band_lo, band_hi] = HeldOutBand(lo, hi, band);
  const double value = band_lo + (band_hi - band_lo) * Unit();
  shape_[name] = value;
  return value;
}

void ShapeSampler::Record(const char* name, double value) { shape_[name] = value; }

double Ramp(double a, double b, double t) { return a + (b - a) * std::clamp(t, 0.0, 1.0); }

std::vector<double> Subdivide(std::vector<double> breakpoints, double max_step_m) {
  if (!(max_step_m > 0.0)) throw std::logic_error("Subdivide: max_step_m must be positive");
  std::sort(breakpoints.begin(), breakpoints.end());
  breakpoints.erase(std::unique(breakpoints.begin(), breakpoints.end()), breakpoints.end());
  std::vector<double> out;
  for (std::size_t i = 0; i + 1 < breakpoints.size(); ++i) {
    const double a = breakpoints[i], b = breakpoints[i + 1];
    const int pieces = std::max(1, static_cast<int>(std::ceil((b - a) / max_step_m - 1e-9)));
    for (int k = 0; k < pieces; ++k) out.push_back(a + (b - a) * k / pieces);
  }
  if (!breakpoints.empty()) out.push_back(breakpoints.back());
  return out;
}

namespace {

// Sign of the turn a -> b -> c in the (r, z) plane.
int Orientation(const ProfilePoint& a, const ProfilePoint& b, const ProfilePoint& c) {
  const double cross = (b.r_m - a.r_m) * (c.z_m - a.z_m) - (b.z_m - a.z_m) * (c.r_m - a.r_m);
  return (cross > 0.0) - (cross < 0.0);
}

bool OnSegment(const ProfilePoint& a, const ProfilePoint& b, const ProfilePoint& p) {
  return std::min(a.r_m, b.r_m) <= p.r_m && p.r_m <= std::max(a.r_m, b.r_m) &&
         std::min(a.z_m, b.z_m) <= p.z_m && p.z_m <= std::max(a.z_m, b.z_m);
}

// Closed segments [a, b] and [c, d] share a point.
bool SegmentsTouch(const ProfilePoint& a, const ProfilePoint& b, const ProfilePoint& c,
                   const ProfilePoint& d) {
  // Boxes first: segments on one straight wall are collinear, and rounding would otherwise make
  // far-apart pieces of the same line look crossed.
  if (std::max(a.r_m, b.r_m) < std::min(c.r_m, d.r_m) ||
      std::max(c.r_m, d.r_m) < std::min(a.r_m, b.r_m) ||
      std::max(a.z_m, b.z_m) < std::min(c.z_m, d.z_m) ||
      std::max(c.z_m, d.z_m) < std::min(a.z_m, b.z_m)) {
    return false;
  }
  const int o1 = Orientation(a, b, c), o2 = Orientation(a, b, d);
  const int o3 = Orientation(c, d, a), o4 = Orientation(c, d, b);
  if (o1 != o2 && o3 != o4) return true;
  return (o1 == 0 && OnSegment(a, b, c)) || (o2 == 0 && OnSegment(a, b, d)) ||
         (o3 == 0 && OnSegment(c, d, a)) || (o4 == 0 && OnSegment(c, d, b));
}

// The profile closed by the axis must be a simple polygon with the solid on its left: the mesh
// checks are combinatorial and would not notice a surface that passes through itself.
void CheckSimpleCounterClockwise(const std::vector<ProfilePoint>& profile) {
  const std::size_t n = profile.size();  // segment i joins i and (i + 1) % n; n - 1 is the axis
  double twice_area = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const ProfilePoint& a = profile[i];
    const ProfilePoint& b = profile[(i + 1) % n];
    twice_area += a.r_m * b.z_m - b.r_m * a.z_m;
    for (std::size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // neighbours through the closing segment
      if (SegmentsTouch(a, b, profile[j], profile[(j + 1) % n])) {
        throw std::logic_error("Revolve: profile segments " + std::to_string(i) + " and " +
                               std::to_string(j) + " cross");
      }
    }
  }
  if (!(twice_area > 0.0))
    throw std::logic_error("Revolve: the profile must run counter-clockwise");
}

}  // namespace

StiffMesh Revolve(const std::vector<ProfilePoint>& profile, int segments) {
  const std::size_t n = profile.size();
  if (n < 3 || segments < 3) throw std::logic_error("Revolve: need >= 3 points and segments");
  if (profile.front().r_m != 0.0 || profile.back().r_m != 0.0) {
    throw std::logic_error("Revolve: the profile must start and end on the axis");
  }
  for (std::size_t i = 1; i + 1 < n; ++i) {
    if (!(profile[i].r_m > 0.0)) throw std::logic_error("Revolve: inner points need r > 0");
  }
  CheckSimpleCounterClockwise(profile);

  StiffMesh out;
  auto& vertices = out.mesh_m.vertices;
  auto add_vertex = [&](double x, double y, double z, float s) {
    vertices.push_back({x, y, z});
    out.vertex_stiffness.push_back(QuantizeStiffness(s));
  };
  add_vertex(0.0, 0.0, profile.front().z_m, profile.front().stiffness);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    for (int j = 0; j < segments; ++j) {
      const double angle = 2.0 * std::numbers::pi * j / segments;
      add_vertex(profile[i].r_m * std::cos(angle), profile[i].r_m * std::sin(angle), profile[i].z_m,
                 profile[i].stiffness);
    }
  }
  add_vertex(0.0, 0.0, profile.back().z_m, profile.back().stiffness);
  const int last_pole = static_cast<int>(vertices.size()) - 1;

  // Vertex of profile point i at angle step j (poles ignore j).
  auto index = [&](std::size_t i, int j) {
    if (i == 0) return 0;
    if (i == n - 1) return last_pole;
    return 1 + static_cast<int>(i - 1) * segments + (j % segments);
  };
  // Quad (i, j) (i, j+1) (i+1, j+1) (i+1, j): angle step then profile step gives the outward
  // normal theta x profile for a counter-clockwise profile; pole quads lose a degenerate half.
  auto& faces = out.mesh_m.faces;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    for (int j = 0; j < segments; ++j) {
      const int a = index(i, j), b = index(i, j + 1);
      const int c = index(i + 1, j + 1), d = index(i + 1, j);
      if (i + 1 != n - 1) faces.push_back({a, c, d});
      if (i != 0) faces.push_back({a, b, c});
    }
  }
  return out;
}

StiffMesh CellSolid(const CellGrid& grid,
                    const std::function<bool(const Eigen::Vector3d& centre_m)>& occupied,
                    const std::function<float(const Eigen::Vector3d& vertex_m)>& stiffness) {
  const std::array<const std::vector<double>*, 3> axes = {&grid.xs, &grid.ys, &grid.zs};
  std::array<int, 3> cells{};
  for (std::size_t a = 0; a < 3; ++a) {
    cells[a] = static_cast<int>(axes[a]->size()) - 1;
    if (cells[a] < 1) throw std::logic_error("CellSolid: every axis needs >= 2 coordinates");
    if (!std::is_sorted(axes[a]->begin(), axes[a]->end()) ||
        std::adjacent_find(axes[a]->begin(), axes[a]->end()) != axes[a]->end()) {
      throw std::logic_error("CellSolid: grid coordinates must increase strictly");
    }
  }
  auto cell_index = [&](const std::array<int, 3>& c) {
    return (static_cast<std::size_t>(c[2]) * static_cast<std::size_t>(cells[1]) +
            static_cast<std::size_t>(c[1])) *
               static_cast<std::size_t>(cells[0]) +
           static_cast<std::size_t>(c[0]);
  };
  std::vector<char> filled(static_cast<std::size_t>(cells[0] * cells[1] * cells[2]), 0);
  for (int k = 0; k < cells[2]; ++k) {
    for (int j = 0; j < cells[1]; ++j) {
      for (int i = 0; i < cells[0]; ++i) {
        const Eigen::Vector3d centre((grid.xs[i] + grid.xs[i + 1]) / 2,
                                     (grid.ys[j] + grid.ys[j + 1]) / 2,
                                     (grid.zs[k] + grid.zs[k + 1]) / 2);
        filled[cell_index({i, j, k})] = occupied(centre) ? 1 : 0;
      }
    }
  }
  auto is_filled = [&](std::array<int, 3> c) {
    for (std::size_t a = 0; a < 3; ++a) {
      if (c[a] < 0 || c[a] >= cells[a]) return false;
    }
    return filled[cell_index(c)] != 0;
  };

  StiffMesh out;
  // Grid corners get a vertex the first time a boundary quad uses them.
  const std::size_t corner_count = static_cast<std::size_t>(cells[0] + 1) *
                                   static_cast<std::size_t>(cells[1] + 1) *
                                   static_cast<std::size_t>(cells[2] + 1);
  std::vector<int> vertex_of_corner(corner_count, -1);
  auto vertex = [&](const std::array<int, 3>& g) {
    const std::size_t key =
        (static_cast<std::size_t>(g[2]) * static_cast<std::size_t>(cells[1] + 1) +
         static_cast<std::size_t>(g[1])) *
            static_cast<std::size_t>(cells[0] + 1) +
        static_cast<std::size_t>(g[0]);
    if (vertex_of_corner[key] < 0) {
      const Eigen::Vector3d p(grid.xs[static_cast<std::size_t>(g[0])],
                              grid.ys[static_cast<std::size_t>(g[1])],
                              grid.zs[static_cast<std::size_t>(g[2])]);
      vertex_of_corner[key] = static_cast<int>(out.mesh_m.vertices.size());
      out.mesh_m.vertices.push_back({p.x(), p.y(), p.z()});
      out.vertex_stiffness.push_back(QuantizeStiffness(stiffness(p)));
    }
    return vertex_of_corner[key];
  };

  for (int k = 0; k < cells[2]; ++k) {
    for (int j = 0; j < cells[1]; ++j) {
      for (int i = 0; i < cells[0]; ++i) {
        const std::array<int, 3> c = {i, j, k};
        if (!is_filled(c)) continue;
        for (std::size_t a = 0; a < 3; ++a) {
          const std::size_t b = (a + 1) % 3, d = (a + 2) % 3;
          for (const int side : {+1, -1}) {
            std::array<int, 3> next = c;
            next[a] += side;
            if (is_filled(next)) continue;
            // Corners of the face in (b, d) offsets; b x d = a, so this order faces +a, and
            // the reversed order faces -a.
            std::array<std::array<int, 2>, 4> offsets = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
            if (side < 0) std::swap(offsets[1], offsets[3]);
            std::array<int, 4> quad{};
            for (std::size_t q = 0; q < 4; ++q) {
              std::array<int, 3> g = c;
              g[a] += side > 0 ? 1 : 0;
              g[b] += offsets[q][0];
              g[d] += offsets[q][1];
              quad[q] = vertex(g);
            }
            out.mesh_m.faces.push_back({quad[0], quad[1], quad[2]});
            out.mesh_m.faces.push_back({quad[0], quad[2], quad[3]});
          }
        }
      }
    }
  }
  return out;
}

}  // namespace softgrasp::sim::catalogue_internal
