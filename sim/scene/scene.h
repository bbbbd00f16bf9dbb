#pragma once
/// The simulator's world model, shared by the catalogue, physics, rendering and grasp execution.
///
/// Frames and units: the world frame W has z up and the support's top surface (table top, or the
/// bin's floor) at z = 0; its origin is the centre of that surface. Object frames O sit at the
/// object's centre of mass. Everything is in metres, kilograms and seconds.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "service/mesh/mesh.h"

namespace softgrasp::sim {

/// Stiffness scores live on 10 levels, 0.1 ... 1.0 (1 = hard, like a PET bottle cap).
inline constexpr float kMinStiffness = 0.1f;
inline constexpr float kMaxStiffness = 1.0f;

/// Rounds a score to the nearest of the 10 levels (clamping to [0.1, 1.0]); NaN becomes 0.1.
float QuantizeStiffness(float score);

/// A catalogue object in its own frame O (origin at the centre of mass).
struct SimObject {
  std::string
      category;  ///< "bottle", "box", "can", "cup", "sponge", "block", "brush", "fractal", "user"
  nlohmann::json
      shape;  ///< the sampled shape parameters (lengths in metres), as written to manifests
  /// Closed, 2-manifold, outward-oriented surface in frame O, metres.
  mesh::TriangleMesh mesh_o;
  /// One stiffness score per vertex of mesh_o, each on a level (QuantizeStiffness). The stiffness
  /// at a surface point is the barycentric interpolation of its triangle's vertex scores,
  /// quantised again; catalogue builders place vertices so region borders stay sharp.
  std::vector<float> vertex_stiffness;
  double mass_kg = 0.1;
};

/// An object placed in a scene. Instance ids start at 1 (0 is the support / background).
struct PlacedObject {
  int instance_id = 1;
  std::shared_ptr<const SimObject> object;
  Eigen::Isometry3d world_from_object = Eigen::Isometry3d::Identity();
};

/// What the objects rest on: an open table top or a bin (floor plus four walls) standing on a
/// table, centred on W's origin, top of the table / bin floor at z = 0. Objects are spawned over
/// the inner area; the surrounding table (ground_size_m square) fills the camera's view.
struct Support {
  enum class Kind { kTable, kBin };
  Kind kind = Kind::kBin;
  double inner_size_x_m = 0.40;  ///< spawn area on a table, or the bin's inner floor size
  double inner_size_y_m = 0.30;
  double wall_height_m = 0.10;     ///< bin only: wall height above the floor
  double wall_thickness_m = 0.01;  ///< bin only
  double thickness_m = 0.02;       ///< table top / bin floor thickness (below z = 0)
  double ground_size_m = 1.5;      ///< side of the table top (kTable) / the table under the bin
};

/// An axis-aligned box in W.
struct SupportBox {
  Eigen::Vector3d min_w;
  Eigen::Vector3d max_w;
};

/// The support as boxes in W: kTable: the table top (ground_size_m square, top at z = 0);
/// kBin: the table under the bin (top at z = -thickness_m), the bin floor (inner area, top at
/// z = 0) and four walls around it (from the table top up to wall_height_m).
std::vector<SupportBox> SupportBoxes(const Support& support);

/// "table" / "bin".
const char* SupportKindName(Support::Kind kind);

/// SupportBoxes as one mesh of closed, outward-oriented boxes (12 triangles each).
mesh::TriangleMesh SupportMesh(const Support& support);

/// A whole scene: the support and the objects resting on it.
struct SimScene {
  std::uint64_t seed = 0;
  Support support;
  std::vector<PlacedObject> objects;

  /// The object with this instance id, or nullptr.
  const PlacedObject* Find(int instance_id) const;
  /// Removes the object with this instance id (a picked object leaves the scene); false if absent.
  bool Remove(int instance_id);
};

/// A rigid transform as the manifests write it (world_from_object, world_from_camera):
/// {"position_m": [x, y, z], "quaternion_xyzw": [x, y, z, w]}.
nlohmann::json TransformToJson(const Eigen::Isometry3d& transform);

/// JSON for manifests: {"instance_id", "category", "shape", "mass_kg", "position_m": [x,y,z],
/// "quaternion_xyzw": [x,y,z,w]} per object (world_from_object).
nlohmann::json PlacedObjectToJson(const PlacedObject& placed);
/// {"kind", "inner_size_m": [x, y], "wall_height_m", "wall_thickness_m", "thickness_m",
/// "ground_size_m"}.
nlohmann::json SupportToJson(const Support& support);

}  // namespace softgrasp::sim
