#pragma once
/// The grasp execution model (docs/sim-grasp-execution.md): a 4-DoF two-finger grasp evaluated
/// in the true scene (not from the image): finger collisions on the way down, first-contact
/// width l_c, width after squeezing l_g from a Hooke-law contact on the local stiffness,
/// deformation rate (l_c - l_g) / l_c, and whether the lift holds.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "service/core/grasp.h"
#include "service/core/status.h"
#include "sim/render/raycast.h"
#include "sim/scene/scene.h"

namespace softgrasp::sim {

/// A 4-DoF grasp in W: fingertips at height z = fingertip_height_m, centred on (x, y), closing
/// axis at angle_rad from +x towards +y, fingers opened to opening_m before descending.
struct SimGrasp {
  double center_x_m = 0.0;
  double center_y_m = 0.0;
  double fingertip_height_m = 0.0;
  double angle_rad = 0.0;
  double opening_m = 0.05;
};

/// Converts a planner grasp (camera frame C, see core::Grasp) to W using the camera's pose.
SimGrasp SimGraspFromCamera(const core::Grasp& grasp, const Eigen::Isometry3d& world_from_camera);

enum class GraspOutcome {
  kSucceeded,        ///< lifted and held
  kCollision,        ///< a finger hit something on the way down
  kEmpty,            ///< the fingers closed on nothing
  kTooWide,          ///< the object between the fingers is wider than the opening
  kMultipleObjects,  ///< the fingers touched different objects
  kSlipped,          ///< contact outside the friction cone, or friction cannot hold the weight
};

/// "succeeded", "collision", "empty", "too_wide", "multiple_objects", "slipped".
const char* GraspOutcomeName(GraspOutcome outcome);

/// A neighbour a descending finger compressed instead of colliding with it.
struct PressedNeighbour {
  int instance_id = 0;
  double press_depth_m = 0.0;     ///< how far the finger pushed into it, vertically
  double force_n = 0.0;           ///< Hooke's law force at that depth
  double deformation_rate = 0.0;  ///< press depth / the neighbour's height
};

struct GraspExecution {
  GraspOutcome outcome = GraspOutcome::kEmpty;
  std::string reason;             ///< a sentence saying why, with the numbers that decided it
  int instance_id = 0;            ///< the object held (or touched), 0 when none
  double contact_width_m = 0.0;   ///< l_c: finger gap at first contact with both fingers
  double grasped_width_m = 0.0;   ///< l_g: finger gap after squeezing
  double deformation_rate = 0.0;  ///< (l_c - l_g) / l_c
  bool damaged = false;           ///< deformation_rate > 0.2
  float stiffness_left = 0.0f;    ///< surface stiffness under each finger at contact
  float stiffness_right = 0.0f;
  /// Soft neighbours the fingers pressed on the way down (ascending ids); empty = none.
  std::vector<PressedNeighbour> pressed;
  bool succeeded() const { return outcome == GraspOutcome::kSucceeded; }
};

/// Evaluates `grasp` in `scene` (raycaster built from the same scene). Errors: kInvalidArgument
/// for non-finite numbers, an opening outside (0, stroke], or gripper sizes <= 0 (and the other
/// limits listed in docs/sim-grasp-execution.md: sizes <= 1 m, |coordinates| <= 1 km, force > 0,
/// friction >= 0).
core::Result<GraspExecution> ExecuteGrasp(const SimScene& scene, const SceneRaycaster& raycaster,
                                          const SimGrasp& grasp, const core::Gripper& gripper);

/// Builds a raycaster for `*scene`, executes `grasp`, and on success removes the held object from
/// the scene (a picked object leaves, so a bin can be cleared grasp by grasp). The scene is left
/// untouched on any other outcome or error. Errors: those of ExecuteGrasp and
/// SceneRaycaster::Build, and kInvalidArgument for a null scene.
core::Result<GraspExecution> ExecuteAndRemove(SimScene* scene, const SimGrasp& grasp,
                                              const core::Gripper& gripper);

/// The Hooke-law spring rate of a finger contact on a surface of stiffness score `stiffness`
/// (clamped to [0.1, 1]), in N/mm: log-linear from 0.2 N/mm at 0.1 (sponge) to 1000 N/mm at 1.0
/// (rigid). See docs/sim-grasp-execution.md for a table.
double ContactSpringRateNPerMm(float stiffness);

}  // namespace softgrasp::sim
