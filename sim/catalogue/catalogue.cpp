// The catalogue's entry points: category lookup, seeding, and turning any closed mesh into a
// SimObject (validation, recentring on the centre of mass, mass).
#include "sim/catalogue/catalogue.h"

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include "service/mesh/mesh_check.h"
#include "sim/catalogue/builder.h"

namespace softgrasp::sim {
namespace {

using catalogue_internal::Built;
using catalogue_internal::ShapeSampler;

struct Category {
  const char* name;
  Built (*build)(ShapeSampler&);
};

// The fixed order of CatalogueCategories(); the index also feeds the seed derivation.
constexpr std::array<Category, 7> kCategories = {{
    {"bottle", catalogue_internal::BuildBottle},
    {"box", catalogue_internal::BuildBox},
    {"can", catalogue_internal::BuildCan},
    {"cup", catalogue_internal::BuildCup},
    {"sponge", catalogue_internal::BuildSponge},
    {"block", catalogue_internal::BuildBlock},
    {"brush", catalogue_internal::BuildBrush},
}};

// SplitMix64's output function (Steele, Lea, Flood 2014): decorrelates neighbouring seeds.
std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Each (category, split, seed) gets its own stream: docs/sim-catalogue.md, "Seeds".
std::uint64_t RngSeed(std::size_t category_index, ShapeSplit split, std::uint64_t seed) {
  const std::uint64_t split_index = split == ShapeSplit::kVal ? 1 : 0;
  return SplitMix64(SplitMix64(seed) + 2 * category_index + split_index);
}

// Enclosed volume and centroid of a closed outward mesh (divergence theorem over tetrahedra
// from `origin`, which only has to be near the mesh for precision).
std::pair<double, Eigen::Vector3d> VolumeAndCentroid(const mesh::TriangleMesh& m,
                                                     const Eigen::Vector3d& origin) {
  double six_volume = 0.0;
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  for (const auto& f : m.faces) {
    const Eigen::Vector3d a = Eigen::Vector3d::Map(m.vertices[f[0]].data()) - origin;
    const Eigen::Vector3d b = Eigen::Vector3d::Map(m.vertices[f[1]].data()) - origin;
    const Eigen::Vector3d c = Eigen::Vector3d::Map(m.vertices[f[2]].data()) - origin;
    const double v6 = a.dot(b.cross(c));
    six_volume += v6;
    weighted += v6 * (a + b + c);  // tetra centroid (a + b + c + 0) / 4, weighted by 6 V
  }
  return {six_volume / 6.0, origin + weighted / (4.0 * six_volume)};
}

void Translate(mesh::TriangleMesh& m, const Eigen::Vector3d& offset) {
  for (auto& v : m.vertices) {
    for (int i = 0; i < 3; ++i) v[static_cast<std::size_t>(i)] += offset[i];
  }
}

core::Error InvalidArgument(std::string message, std::string field) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, std::move(message), std::move(field));
}

}  // namespace

const char* ShapeSplitName(ShapeSplit split) { return split == ShapeSplit::kVal ? "val" : "train"; }

const std::vector<std::string>& CatalogueCategories() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const Category& c : kCategories) out.emplace_back(c.name);
    return out;
  }();
  return names;
}

core::Result<SimObject> MakeCatalogueObject(std::string_view category, ShapeSplit split,
                                            std::uint64_t seed) {
  for (std::size_t i = 0; i < kCategories.size(); ++i) {
    if (category != kCategories[i].name) continue;
    ShapeSampler sampler(RngSeed(i, split, seed), split);
    Built built = kCategories[i].build(sampler);
    sampler.Record("density_kg_m3", built.density_kg_m3);
    core::Result<SimObject> object = MakeMeshObject(
        std::move(built.body.mesh_m), std::move(built.body.vertex_stiffness), kMaxStiffness,
        built.density_kg_m3, kCategories[i].name, std::move(sampler.shape()));
    if (!object.ok()) {  // a builder produced a bad mesh: our bug, not the caller's
      return core::MakeError(core::ErrorCode::kInternal,
                             "catalogue " + std::string(category) + ": " + object.error().message);
    }
    return object;
  }
  std::string known;
  for (const Category& c : kCategories) known += std::string(known.empty() ? "" : ", ") + c.name;
  return InvalidArgument(
      "unknown catalogue category '" + std::string(category) + "'; expected one of: " + known,
      "category");
}

core::Result<SimObject> MakeMeshObject(mesh::TriangleMesh mesh_m,
                                       std::vector<float> vertex_stiffness,
                                       float constant_stiffness, double density_kg_m3,
                                       std::string category, nlohmann::json shape) {
  const mesh::MeshReport report = mesh::CheckMesh(mesh_m);
  if (!report.ok()) {
    std::string problems;
    for (const std::string& p : report.problems) problems += (problems.empty() ? "" : "; ") + p;
    return InvalidArgument(
        "the mesh must be a closed, 2-manifold, connected, outward surface with positive "
        "volume: " +
            problems,
        "mesh");
  }
  const std::size_t num_vertices = mesh_m.vertices.size();
  if (vertex_stiffness.empty()) {
    if (!(constant_stiffness >= kMinStiffness && constant_stiffness <= kMaxStiffness)) {
      return InvalidArgument(
          "stiffness " + std::to_string(constant_stiffness) + " is outside [0.1, 1] (1 = hard)",
          "stiffness");
    }
    vertex_stiffness.assign(num_vertices, QuantizeStiffness(constant_stiffness));
  } else {
    if (vertex_stiffness.size() != num_vertices) {
      return InvalidArgument("vertex_stiffness has " + std::to_string(vertex_stiffness.size()) +
                                 " scores for " + std::to_string(num_vertices) +
                                 " vertices; give one per vertex or none",
                             "vertex_stiffness");
    }
    for (std::size_t i = 0; i < num_vertices; ++i) {
      if (!std::isfinite(vertex_stiffness[i])) {
        return InvalidArgument("vertex_stiffness[" + std::to_string(i) + "] is not a finite number",
                               "vertex_stiffness");
      }
      vertex_stiffness[i] = QuantizeStiffness(vertex_stiffness[i]);
    }
  }
  if (!(density_kg_m3 > 0.0 && density_kg_m3 <= 20000.0)) {
    return InvalidArgument(
        "density_kg_m3 " + std::to_string(density_kg_m3) + " is outside (0, 20000] kg/m^3",
        "density_kg_m3");
  }

  // Move the centre of mass to the origin. A second pass removes the rounding left by the first
  // (the centroid is then computed about a point already within micrometres of it).
  const auto& v0 = mesh_m.vertices.front();
  auto [volume_m3, centroid] = VolumeAndCentroid(mesh_m, Eigen::Vector3d(v0[0], v0[1], v0[2]));
  Translate(mesh_m, -centroid);
  Translate(mesh_m, -VolumeAndCentroid(mesh_m, Eigen::Vector3d::Zero()).second);

  SimObject object;
  object.category = std::move(category);
  object.shape = std::move(shape);
  object.mesh_o = std::move(mesh_m);
  object.vertex_stiffness = std::move(vertex_stiffness);
  object.mass_kg = volume_m3 * density_kg_m3;
  return object;
}

}  // namespace softgrasp::sim
