#include "sim/physics/drop.h"

#include <LinearMath/btConvexHullComputer.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <utility>

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;

// Bullet's default margin (0.04 units) is as large as small objects; 1 mm keeps GJK robust while
// the hull is shrunk by the same amount, so hull + margin is the mesh's hull again (edges rounded
// by 1 mm).
constexpr double kCollisionMargin_m = 0.001;
// Bullet is tuned for bodies of about one unit (its contact thresholds and solver slops are
// absolute); a 3 cm cube in metres jitters for seconds and walks off small tables. The world is
// therefore simulated in decimetres: lengths and gravity scaled by 10, masses and time unchanged,
// which is the same physics with Bullet's tolerances ten times finer relative to the objects.
constexpr double kUnitsPerMetre = 10.0;
// Rolling and spinning resistance (a lever arm, metres). Without it a faceted cylinder lying on
// its side rocks and a dense sphere rolls for many seconds; 2 mm settles them within ~1 s.
constexpr double kRollingFriction_m = 0.002;
// Convex hulls with more vertices than this are reduced (support points in fixed directions).
constexpr int kMaxHullPoints = 256;
// An object whose centre falls below this is off the support; it is removed at once so that a
// falling object does not keep the scene from settling.
constexpr double kLostBelowZ_m = -0.05;
// Every body must stay below the sleep speeds this long for the scene to count as settled.
constexpr double kSettleWindow_s = 0.25;
// Smallest extent of a mesh's hull in any direction; below that the object is flat.
constexpr double kMinThickness_m = 1e-4;

// ---------------------------------------------------------------------------------------------
// Validation.

std::optional<core::Error> CheckFiniteAtLeast(double value, double min, bool inclusive,
                                              const std::string& field) {
  const bool ok = std::isfinite(value) && (inclusive ? value >= min : value > min);
  if (ok) return std::nullopt;
  return MakeError(ErrorCode::kInvalidArgument,
                   field + " must be a finite number " + (inclusive ? ">= " : "> ") +
                       std::to_string(min) + ", got " + std::to_string(value),
                   field);
}

std::optional<core::Error> ValidateSupport(const Support& s) {
  const std::pair<double, const char*> positive[] = {
      {s.inner_size_x_m, "support.inner_size_x_m"},
      {s.inner_size_y_m, "support.inner_size_y_m"},
      {s.thickness_m, "support.thickness_m"},
      {s.ground_size_m, "support.ground_size_m"},
  };
  for (const auto& [value, field] : positive) {
    if (auto e = CheckFiniteAtLeast(value, 0.0, false, field)) return e;
  }
  if (s.kind == Support::Kind::kBin) {
    if (auto e = CheckFiniteAtLeast(s.wall_height_m, 0.0, false, "support.wall_height_m")) return e;
    if (auto e = CheckFiniteAtLeast(s.wall_thickness_m, 0.0, false, "support.wall_thickness_m")) {
      return e;
    }
  }
  return std::nullopt;
}

std::optional<core::Error> ValidateOptions(const DropOptions& o) {
  if (auto e = CheckFiniteAtLeast(o.margin_m, 0.0, true, "options.margin_m")) return e;
  if (auto e = CheckFiniteAtLeast(o.drop_height_min_m, 0.0, true, "options.drop_height_min_m")) {
    return e;
  }
  if (auto e = CheckFiniteAtLeast(o.spawn_gap_m, 0.0, true, "options.spawn_gap_m")) return e;
  if (auto e = CheckFiniteAtLeast(o.time_step_s, 0.0, false, "options.time_step_s")) return e;
  if (o.time_step_s > 0.1) {
    return MakeError(
        ErrorCode::kInvalidArgument,
        "options.time_step_s must be at most 0.1 s, got " + std::to_string(o.time_step_s),
        "options.time_step_s");
  }
  if (o.max_steps < 1 || o.max_steps > 10'000'000) {
    return MakeError(
        ErrorCode::kInvalidArgument,
        "options.max_steps must be in [1, 10000000], got " + std::to_string(o.max_steps),
        "options.max_steps");
  }
  if (auto e = CheckFiniteAtLeast(o.friction, 0.0, true, "options.friction")) return e;
  if (auto e = CheckFiniteAtLeast(o.restitution, 0.0, true, "options.restitution")) return e;
  if (o.restitution > 1.0) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "options.restitution must be in [0, 1], got " + std::to_string(o.restitution),
                     "options.restitution");
  }
  if (auto e = CheckFiniteAtLeast(o.sleep_linear_m_s, 0.0, false, "options.sleep_linear_m_s")) {
    return e;
  }
  if (auto e =
          CheckFiniteAtLeast(o.sleep_angular_rad_s, 0.0, false, "options.sleep_angular_rad_s")) {
    return e;
  }
  return std::nullopt;
}

Eigen::Vector3d Vertex(const mesh::TriangleMesh& mesh, std::size_t i) {
  return {mesh.vertices[i][0], mesh.vertices[i][1], mesh.vertices[i][2]};
}

// True when the vertices span a solid: the farthest-point tetrahedron (p0, the farthest point
// from it, the farthest from that line, the farthest from that plane) is at least
// kMinThickness_m thick at every step.
bool SpansSolid(const mesh::TriangleMesh& mesh) {
  const std::size_t n = mesh.vertices.size();
  const Eigen::Vector3d p0 = Vertex(mesh, 0);
  auto farthest = [&](auto distance) {
    double best = -1.0;
    std::size_t best_i = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double d = distance(Vertex(mesh, i));
      if (d > best) best = d, best_i = i;
    }
    return std::make_pair(best_i, best);
  };
  const auto [i1, d1] = farthest([&](const Eigen::Vector3d& p) { return (p - p0).norm(); });
  if (d1 < kMinThickness_m) return false;
  const Eigen::Vector3d axis = (Vertex(mesh, i1) - p0) / d1;
  const auto [i2, d2] = farthest([&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d v = p - p0;
    return (v - v.dot(axis) * axis).norm();
  });
  if (d2 < kMinThickness_m) return false;
  const Eigen::Vector3d normal = axis.cross(Vertex(mesh, i2) - p0).normalized();
  const auto [i3, d3] =
      farthest([&](const Eigen::Vector3d& p) { return std::abs((p - p0).dot(normal)); });
  return d3 >= kMinThickness_m;
}

std::optional<core::Error> ValidateObject(const SimObject* object, std::size_t index) {
  const std::string field = "objects[" + std::to_string(index) + "]";
  if (object == nullptr) {
    return MakeError(ErrorCode::kInvalidArgument, field + " is null", field);
  }
  const mesh::TriangleMesh& mesh = object->mesh_o;
  if (mesh.vertices.empty() || mesh.faces.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, field + ".mesh_o is empty", field + ".mesh_o");
  }
  for (const auto& v : mesh.vertices) {
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
      return MakeError(ErrorCode::kInvalidArgument,
                       field + ".mesh_o has a non-finite vertex coordinate", field + ".mesh_o");
    }
  }
  if (!SpansSolid(mesh)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     field + ".mesh_o is flat or a point (thinner than 0.1 mm in some direction)",
                     field + ".mesh_o");
  }
  if (auto e = CheckFiniteAtLeast(object->mass_kg, 0.0, false, field + ".mass_kg")) return e;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// Shapes.

// The convex hull of the mesh vertices, shrunk by (about) the collision margin, as points.
struct HullPoints {
  std::vector<btVector3> points;
  double margin = 0.0;  ///< the shrink actually applied (clamped for thin objects), Bullet units
};

// Directions spread evenly over the sphere (Fibonacci lattice), fixed for determinism.
std::vector<btVector3> FibonacciDirections(int count) {
  std::vector<btVector3> out;
  out.reserve(static_cast<std::size_t>(count));
  const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    out.emplace_back(static_cast<btScalar>(r * std::cos(phi)),
                     static_cast<btScalar>(r * std::sin(phi)), static_cast<btScalar>(z));
  }
  return out;
}

HullPoints BuildHull(const mesh::TriangleMesh& mesh) {
  btConvexHullComputer hull;
  std::vector<std::array<double, 3>> scaled = mesh.vertices;
  for (auto& v : scaled) {
    for (double& c : v) c *= kUnitsPerMetre;
  }
  const int stride = static_cast<int>(sizeof(scaled[0]));
  const int count = static_cast<int>(scaled.size());
  HullPoints out;
  out.margin =
      hull.compute(scaled.front().data(), stride, count,
                   static_cast<btScalar>(kCollisionMargin_m * kUnitsPerMetre), btScalar(0.25));
  if (out.margin <= 0.0 || hull.vertices.size() < 4) {
    // Shrinking failed (cannot happen for the solid meshes validation lets through, but an
    // empty shape would be worse): use the plain hull with no margin.
    out.margin = 0.0;
    hull.compute(scaled.front().data(), stride, count, btScalar(0), btScalar(0));
  }
  const int n = hull.vertices.size();
  if (n <= kMaxHullPoints) {
    out.points.assign(&hull.vertices[0], &hull.vertices[0] + n);
    return out;
  }
  // Too many hull vertices for fast contact queries: keep the extreme vertex in each of
  // kMaxHullPoints evenly spread directions (duplicates dropped, order fixed).
  std::vector<bool> kept(static_cast<std::size_t>(n), false);
  for (const btVector3& d : FibonacciDirections(kMaxHullPoints)) {
    int best = 0;
    btScalar best_dot = hull.vertices[0].dot(d);
    for (int i = 1; i < n; ++i) {
      const btScalar dot = hull.vertices[i].dot(d);
      if (dot > best_dot) best_dot = dot, best = i;
    }
    kept[static_cast<std::size_t>(best)] = true;
  }
  for (int i = 0; i < n; ++i) {
    if (kept[static_cast<std::size_t>(i)]) out.points.push_back(hull.vertices[i]);
  }
  return out;
}

double BoundingRadius(const mesh::TriangleMesh& mesh) {
  double r2 = 0.0;
  for (const auto& v : mesh.vertices) r2 = std::max(r2, v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return std::sqrt(r2);
}

// A length vector in metres to Bullet units.
btVector3 ToBt(const Eigen::Vector3d& v_m) {
  const Eigen::Vector3d u = v_m * kUnitsPerMetre;
  return {static_cast<btScalar>(u.x()), static_cast<btScalar>(u.y()), static_cast<btScalar>(u.z())};
}

// ---------------------------------------------------------------------------------------------
// Randomness: one engine, doubles built from its raw bits so every standard library draws the
// same numbers (std::uniform_real_distribution is implementation-defined).

class Uniform {
 public:
  explicit Uniform(std::uint64_t seed) : engine_(seed) {}
  /// In [0, 1).
  double Next() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  /// In [-half, half].
  double Centered(double half) { return (2.0 * Next() - 1.0) * half; }

 private:
  std::mt19937_64 engine_;
};

// Shoemake's uniform random rotation.
Eigen::Quaterniond UniformRotation(Uniform& rng) {
  const double u1 = rng.Next();
  const double u2 = rng.Next();
  const double u3 = rng.Next();
  const double a = std::sqrt(1.0 - u1);
  const double b = std::sqrt(u1);
  const double two_pi = 2.0 * std::numbers::pi;
  return Eigen::Quaterniond(b * std::cos(two_pi * u3), a * std::sin(two_pi * u2),
                            a * std::cos(two_pi * u2), b * std::sin(two_pi * u3))
      .normalized();
}

// Spawn poses: (x, y) uniform in the inner area shrunk by the margin (and, in a bin, by the
// object's bounding radius so it cannot start inside a wall), uniform orientation, and stacked
// height slots so no two bounding spheres (nor a sphere and the floor) overlap.
std::vector<Eigen::Isometry3d> SpawnPoses(const Support& support, const std::vector<double>& radii,
                                          const DropOptions& options, std::uint64_t seed) {
  Uniform rng(seed);
  std::vector<Eigen::Isometry3d> poses;
  double previous_top_m = 0.0;  // top of the previous slot's bounding sphere
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const double r = radii[i];
    const double inset =
        support.kind == Support::Kind::kBin ? std::max(options.margin_m, r) : options.margin_m;
    const double half_x = std::max(0.0, support.inner_size_x_m / 2.0 - inset);
    const double half_y = std::max(0.0, support.inner_size_y_m / 2.0 - inset);
    const double x = rng.Centered(half_x);
    const double y = rng.Centered(half_y);
    const Eigen::Quaterniond q = UniformRotation(rng);
    const double z = std::max(options.drop_height_min_m, previous_top_m + options.spawn_gap_m + r);
    previous_top_m = z + r;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = q.toRotationMatrix();
    pose.translation() = Eigen::Vector3d(x, y, z);
    poses.push_back(pose);
  }
  return poses;
}

// ---------------------------------------------------------------------------------------------
// The Bullet world. Owns everything; bodies leave the world before anything is deleted.

class DropWorld {
 public:
  explicit DropWorld(const DropOptions& options)
      : dispatcher_(&config_), world_(&dispatcher_, &broadphase_, &solver_, &config_) {
    world_.setGravity(btVector3(0, 0, btScalar(-9.81 * kUnitsPerMetre)));
    // Bullet multiplies the two surfaces' coefficients; the square roots make every contact
    // (object-support and object-object) use the configured values.
    friction_ = static_cast<btScalar>(std::sqrt(options.friction));
    restitution_ = static_cast<btScalar>(std::sqrt(options.restitution));
    sleep_linear_ = static_cast<btScalar>(options.sleep_linear_m_s * kUnitsPerMetre);
    sleep_angular_ = static_cast<btScalar>(options.sleep_angular_rad_s);
  }
  ~DropWorld() {
    for (auto& body : bodies_) {
      if (body && body->isInWorld()) world_.removeRigidBody(body.get());
    }
  }
  DropWorld(const DropWorld&) = delete;
  DropWorld& operator=(const DropWorld&) = delete;

  void AddStaticBox(const SupportBox& box) {
    const Eigen::Vector3d half = (box.max_w - box.min_w) / 2.0;
    auto shape = std::make_unique<btBoxShape>(ToBt(half));
    shape->setMargin(static_cast<btScalar>(kCollisionMargin_m * kUnitsPerMetre));  // inside the box
    btTransform pose;
    pose.setIdentity();
    pose.setOrigin(ToBt((box.min_w + box.max_w) / 2.0));
    btRigidBody::btRigidBodyConstructionInfo info(0, nullptr, shape.get());
    info.m_startWorldTransform = pose;
    info.m_friction = friction_;
    info.m_restitution = restitution_;
    AddBody(std::move(shape), info);
  }

  /// Adds a dynamic body; returns its index in Body().
  int AddObject(const HullPoints& hull, double mass_kg, const Eigen::Isometry3d& world_from_o) {
    auto shape = std::make_unique<btConvexHullShape>(
        &hull.points[0].x(), static_cast<int>(hull.points.size()), sizeof(btVector3));
    shape->setMargin(static_cast<btScalar>(hull.margin));
    const btScalar mass = static_cast<btScalar>(mass_kg);
    btVector3 inertia(0, 0, 0);
    shape->calculateLocalInertia(mass, inertia);
    const Eigen::Quaterniond q(world_from_o.linear());
    btTransform pose(btQuaternion(static_cast<btScalar>(q.x()), static_cast<btScalar>(q.y()),
                                  static_cast<btScalar>(q.z()), static_cast<btScalar>(q.w())),
                     ToBt(world_from_o.translation()));
    btRigidBody::btRigidBodyConstructionInfo info(mass, nullptr, shape.get(), inertia);
    info.m_startWorldTransform = pose;
    info.m_friction = friction_;
    info.m_restitution = restitution_;
    info.m_rollingFriction = static_cast<btScalar>(kRollingFriction_m * kUnitsPerMetre);
    info.m_spinningFriction = info.m_rollingFriction;
    info.m_linearSleepingThreshold = sleep_linear_;
    info.m_angularSleepingThreshold = sleep_angular_;
    return AddBody(std::move(shape), info);
  }

  btRigidBody& Body(int index) { return *bodies_[static_cast<std::size_t>(index)]; }
  void Remove(int index) { world_.removeRigidBody(&Body(index)); }
  void Step(double dt_s) {
    // maxSubSteps = 0: exactly one internal step of dt, no interpolation.
    world_.stepSimulation(static_cast<btScalar>(dt_s), 0);
  }

 private:
  int AddBody(std::unique_ptr<btCollisionShape> shape,
              const btRigidBody::btRigidBodyConstructionInfo& info) {
    bodies_.push_back(std::make_unique<btRigidBody>(info));
    world_.addRigidBody(bodies_.back().get());
    shapes_.push_back(std::move(shape));
    return static_cast<int>(bodies_.size()) - 1;
  }

  btDefaultCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_;
  btDbvtBroadphase broadphase_;
  btSequentialImpulseConstraintSolver solver_;
  btDiscreteDynamicsWorld world_;
  std::vector<std::unique_ptr<btCollisionShape>> shapes_;
  std::vector<std::unique_ptr<btRigidBody>> bodies_;
  btScalar friction_ = 0;
  btScalar restitution_ = 0;
  btScalar sleep_linear_ = 0;
  btScalar sleep_angular_ = 0;
};

Eigen::Isometry3d ToIsometry(const btTransform& t) {
  const btQuaternion q = t.getRotation();
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).normalized().toRotationMatrix();
  out.translation() =
      Eigen::Vector3d(t.getOrigin().x(), t.getOrigin().y(), t.getOrigin().z()) / kUnitsPerMetre;
  return out;
}

bool FiniteState(const btRigidBody& body) {
  const btTransform& t = body.getWorldTransform();
  const btQuaternion q = t.getRotation();
  const btVector3& p = t.getOrigin();
  for (const btScalar v : {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()}) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// Where a resting object's centre must lie: inside the bin's walls, or over the table top.
bool InsideSupportArea(const Support& support, const Eigen::Vector3d& p_w) {
  const double hx = support.kind == Support::Kind::kBin ? support.inner_size_x_m / 2.0
                                                        : support.ground_size_m / 2.0;
  const double hy = support.kind == Support::Kind::kBin ? support.inner_size_y_m / 2.0
                                                        : support.ground_size_m / 2.0;
  return p_w.z() >= kLostBelowZ_m && std::abs(p_w.x()) <= hx && std::abs(p_w.y()) <= hy;
}

}  // namespace

core::Result<DropResult> DropObjects(const Support& support,
                                     const std::vector<std::shared_ptr<const SimObject>>& objects,
                                     std::uint64_t seed, const DropOptions& options) {
  if (objects.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, "objects is empty: give at least one object",
                     "objects");
  }
  if (auto e = ValidateSupport(support)) return *e;
  if (auto e = ValidateOptions(options)) return *e;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    if (auto e = ValidateObject(objects[i].get(), i)) return *e;
  }

  std::vector<double> radii;
  for (const auto& object : objects) radii.push_back(BoundingRadius(object->mesh_o));
  const std::vector<Eigen::Isometry3d> spawn = SpawnPoses(support, radii, options, seed);

  DropWorld world(options);
  for (const SupportBox& box : SupportBoxes(support)) world.AddStaticBox(box);
  std::vector<int> body_of_object;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    body_of_object.push_back(
        world.AddObject(BuildHull(objects[i]->mesh_o), objects[i]->mass_kg, spawn[i]));
  }

  DropResult result;
  result.scene.seed = seed;
  result.scene.support = support;
  std::vector<bool> in_world(objects.size(), true);
  std::size_t num_in_world = objects.size();
  const int settle_steps =
      std::max(1, static_cast<int>(std::ceil(kSettleWindow_s / options.time_step_s)));
  int quiet_steps = 0;
  while (result.report.steps < options.max_steps) {
    world.Step(options.time_step_s);
    ++result.report.steps;
    bool quiet = true;
    for (std::size_t i = 0; i < objects.size(); ++i) {
      if (!in_world[i]) continue;
      btRigidBody& body = world.Body(body_of_object[i]);
      if (!FiniteState(body) ||
          body.getWorldTransform().getOrigin().z() < kLostBelowZ_m * kUnitsPerMetre) {
        world.Remove(body_of_object[i]);  // fell off (or blew up): it cannot settle
        in_world[i] = false;
        --num_in_world;
        continue;
      }
      quiet = quiet &&
              body.getLinearVelocity().length() < options.sleep_linear_m_s * kUnitsPerMetre &&
              body.getAngularVelocity().length() < options.sleep_angular_rad_s;
    }
    quiet_steps = quiet ? quiet_steps + 1 : 0;
    if (num_in_world == 0 || quiet_steps >= settle_steps) {
      result.report.settled = true;
      break;
    }
  }

  for (std::size_t i = 0; i < objects.size(); ++i) {
    const int instance_id = static_cast<int>(i) + 1;
    if (in_world[i]) {
      const Eigen::Isometry3d pose = ToIsometry(world.Body(body_of_object[i]).getWorldTransform());
      if (InsideSupportArea(support, pose.translation())) {
        result.scene.objects.push_back(PlacedObject{instance_id, objects[i], pose});
        continue;
      }
    }
    result.report.lost_instance_ids.push_back(instance_id);
  }
  return result;
}

}  // namespace softgrasp::sim
