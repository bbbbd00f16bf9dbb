#pragma once
/// Internal to the catalogue: seeded shape-parameter draws, meshes with per-vertex stiffness built
/// as solids of revolution or as unions of grid cells, and the per-category builders.
/// Not a public header: other targets use sim/catalogue/catalogue.h.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <utility>
#include <vector>

#include "service/mesh/mesh.h"
#include "sim/catalogue/catalogue.h"

namespace softgrasp::sim::catalogue_internal {

/// A surface with one (already quantised) stiffness score per vertex.
struct StiffMesh {
  mesh::TriangleMesh mesh_m;
  std::vector<float> vertex_stiffness;
};

/// What a category builder hands back; the catalogue recentres it and computes the mass.
struct Built {
  StiffMesh body;
  double density_kg_m3 = 1000.0;
};

/// Held-out parameters split their range [lo, hi) into this many equal bands; validation draws
/// from bands 1 and 3, training from bands 0, 2 and 4 (interleaved, disjoint).
inline constexpr int kHeldOutBands = 5;

/// [lo, hi) of `band` (0-based) of the range [lo, hi).
std::pair<double, double> HeldOutBand(double lo, double hi, int band);

/// Draws shape parameters from a std::mt19937_64 and records each one in the shape JSON.
/// Uniform values are (rng() >> 11) * 2^-53 mapped linearly onto the range, so the bytes are
/// identical on every platform (no std::uniform_real_distribution).
class ShapeSampler {
 public:
  ShapeSampler(std::uint64_t rng_seed, ShapeSplit split);

  /// A value uniform in [lo, hi), recorded under `name` (the same for both splits).
  double Uniform(const char* name, double lo, double hi);
  /// A held-out parameter: uniform over the split's bands of [lo, hi) (kHeldOutBands).
  double HeldOut(const char* name, double lo, double hi);
  /// Records a derived value (not drawn) in the shape JSON.
  void Record(const char* name, double value);

  nlohmann::json& shape() { return shape_; }

 private:
  double Unit();  // [0, 1)

  std::mt19937_64 rng_;
  ShapeSplit split_;
  nlohmann::json shape_ = nlohmann::json::object();
};

/// One point of a revolution profile in the (r, z) half-plane, with the stiffness of its ring.
struct ProfilePoint {
  double r_m = 0.0;
  double z_m = 0.0;
  float stiffness = 1.0f;
};

/// Revolves `profile` about the z axis into a closed surface of genus 0. The profile starts and
/// ends on the axis (r = 0; those become single pole vertices), has r > 0 in between, does not
/// cross itself, and runs with the solid on its left in the (r, z) plane (counter-clockwise),
/// e.g. bottom centre -> outer edge -> up the side -> top centre. `segments` >= 3 vertices per
/// ring. @throws std::logic_error on a profile that breaks these rules.
StiffMesh Revolve(const std::vector<ProfilePoint>& profile, int segments);

/// Coordinates of a rectilinear grid, each axis sorted strictly increasing.
struct CellGrid {
  std::vector<double> xs, ys, zs;
};

/// The boundary of the union of the grid cells for which `occupied(cell centre)` holds, as
/// outward quads split into triangles, vertices shared through their grid index (no T-junctions).
/// The occupied cells must form one solid whose boundary is a 2-manifold (e.g. a union of boxes
/// overlapping along faces). `stiffness(vertex)` gives each vertex's score (quantised here).
StiffMesh CellSolid(const CellGrid& grid,
                    const std::function<bool(const Eigen::Vector3d& centre_m)>& occupied,
                    const std::function<float(const Eigen::Vector3d& vertex_m)>& stiffness);

/// Sorted, de-duplicated `breakpoints` with every interval split evenly into pieces no longer
/// than `max_step_m`.
std::vector<double> Subdivide(std::vector<double> breakpoints, double max_step_m);

/// Linear interpolation from a (t <= 0) to b (t >= 1), clamped.
double Ramp(double a, double b, double t);

// Category builders (one per procedural category); each draws its parameters from `sampler`.
Built BuildBottle(ShapeSampler& sampler);
Built BuildCan(ShapeSampler& sampler);
Built BuildCup(ShapeSampler& sampler);
Built BuildBox(ShapeSampler& sampler);
Built BuildSponge(ShapeSampler& sampler);
Built BuildBlock(ShapeSampler& sampler);
Built BuildBrush(ShapeSampler& sampler);

}  // namespace softgrasp::sim::catalogue_internal
