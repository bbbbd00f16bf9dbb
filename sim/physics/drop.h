#pragma once
/// Physics scenes on Bullet: drop objects at random poses into a bin or onto a table, let them
/// settle, record the resting poses (docs/sim-physics.md). Deterministic: the same inputs and
/// seed give bit-identical poses.

#include <cstdint>
#include <memory>
#include <vector>

#include "service/core/status.h"
#include "sim/scene/scene.h"

namespace softgrasp::sim {

struct DropOptions {
  double margin_m = 0.03;           ///< keep spawn points this far inside the support's edges
  double drop_height_min_m = 0.05;  ///< lowest spawn height of an object's centre above z = 0
  double spawn_gap_m = 0.02;        ///< vertical gap between stacked spawn slots
  double time_step_s = 1.0 / 240.0;
  int max_steps = 2400;   ///< simulated time cap (10 s at the default step)
  double friction = 0.6;  ///< Coulomb friction of every surface
  double restitution = 0.05;
  double sleep_linear_m_s = 0.005;  ///< settled once every body is slower than these
  double sleep_angular_rad_s = 0.05;
};

/// What happened during a drop.
struct DropReport {
  int steps = 0;         ///< simulation steps run
  bool settled = false;  ///< every object came to rest before max_steps
  /// Objects that left the support, ascending: their centre fell below z = -0.05 m, or came to
  /// rest outside the bin's inner walls / beyond the table top (ground_size_m square). They are
  /// dropped from the scene.
  std::vector<int> lost_instance_ids;
};

struct DropResult {
  /// Objects that stayed on the support, in input order; each keeps instance id = input index + 1
  /// (lost objects are omitted, not renumbered), so ids may have gaps.
  SimScene scene;
  DropReport report;
};

/// Drops `objects` (in order: instance id i + 1) from random spawn poses drawn with `seed`.
/// Collision shapes are convex hulls of each mesh (documented); the support is static boxes.
/// Errors: kInvalidArgument for an empty list, a null object, an empty/non-finite mesh, a
/// non-positive mass (field names the object index), or options out of range.
core::Result<DropResult> DropObjects(const Support& support,
                                     const std::vector<std::shared_ptr<const SimObject>>& objects,
                                     std::uint64_t seed, const DropOptions& options = {});

}  // namespace softgrasp::sim
