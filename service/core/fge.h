#pragma once
/// Fast Graspability Evaluation (Domae et al. 2014) for a two-finger gripper, with the
/// multi-height search of the thesis' clutter experiments. See docs/fge.md.

#include <optional>
#include <vector>

#include "service/core/depth.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"

namespace softgrasp::core {

/// num_height_steps at most: the fast path encodes up to 126 threshold levels (3 per slice).
inline constexpr int kMaxHeightSteps = 40;

struct FgeParams {
  int num_angles = 16;               ///< closing-axis angles over [0, pi)
  double height_step_m = 0.010;      ///< distance between height slices
  int num_height_steps = 5;          ///< slices searched, from the top down
  double grip_depth_m = 0.010;       ///< how far below the contact slice the fingertips go
  double min_object_area_px = 100;   ///< a slice starts where this much surface lies above it
  double floor_clearance_m = 0.003;  ///< fingertips never go lower than this above the floor
  double seam_step_m = 0.010;        ///< a height jump this large inside the closing region
                                     ///< means two surfaces (a seam): rejected
  int top_k = 5;                     ///< grasps returned, best first
  double nms_radius_px = 10;         ///< grasps closer than this (and at a similar angle) merge
  /// Candidates whose fingers would descend through a surface the camera saw (FingerClearance,
  /// tested in 3-D) are dropped before they count towards top_k or suppress a neighbour.
  bool check_finger_clearance = true;
};

/// The per-angle maps FGE computes, exposed so the fast and the reference implementation can be
/// compared map for map. All maps have the image size.
struct FgeMaps {
  cv::Mat1f contact;       ///< A_t: surface pixels inside the closing region
  cv::Mat1f collision;     ///< A_c: surface pixels under the two finger footprints
  cv::Mat1f graspability;  ///< Gaussian-blurred candidate map (A_t > 0 and A_c = 0), [0, 1]
};

/// Why FGE cannot plan with these inputs (kInvalidArgument naming the field: intrinsics not
/// finite, gripper sizes not positive, search parameters out of range); nullopt when it can.
/// The planners take valid inputs only: callers that pass on a user's values check them here.
std::optional<Error> ValidateFgeInputs(const Camera& camera, const Gripper& gripper,
                                       const FgeParams& params);

/// Where FGE lets fingers make contact on `scene`: surfaces of objects that stand free of the
/// image border at some height up to the objects' top (their top faces, or the parts of a pile
/// above where it meets a wall), within scene.contact_allowed. What reaches in from the border and
/// never stands free of it is an obstacle only: the robot's own fingers in a wrist camera's view,
/// bin walls, objects cut by the frame. When every object touches the border at every height,
/// everything allowed counts. The scene's size (empty for an empty scene); 255 = a contact may
/// lie here.
cv::Mat1b GraspableSurfaces(const Scene& scene, const Camera& camera, const Gripper& gripper,
                            const FgeParams& params = {});

/// Ranked grasps, best first; empty when nothing is graspable. @throws std::invalid_argument
/// for inputs ValidateFgeInputs refuses.
std::vector<Grasp> DetectGraspsFge(const Scene& scene, const Camera& camera, const Gripper& gripper,
                                   const FgeParams& params = {});

/// Maps for one angle and one contact height, fast implementation (box sums over rotated
/// images). `contact_height_m` is the slice height above the floor.
FgeMaps ComputeFgeMaps(const Scene& scene, const Camera& camera, const Gripper& gripper,
                       const FgeParams& params, double angle_rad, double contact_height_m);

}  // namespace softgrasp::core
