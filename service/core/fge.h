#pragma once
/// Fast Graspability Evaluation (Domae et al. 2014) for a two-finger gripper, with the
/// multi-height search of the thesis' clutter experiments. See docs/fge.md.

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

/// Ranked grasps, best first; empty when nothing is graspable.
std::vector<Grasp> DetectGraspsFge(const Scene& scene, const Camera& camera, const Gripper& gripper,
                                   const FgeParams& params = {});

/// Maps for one angle and one contact height, fast implementation (box sums over rotated
/// images). `contact_height_m` is the slice height above the floor.
FgeMaps ComputeFgeMaps(const Scene& scene, const Camera& camera, const Gripper& gripper,
                       const FgeParams& params, double angle_rad, double contact_height_m);

/// The same maps by straightforward cv::filter2D with rotated templates. Slow; kept as the
/// reference for tests and as the benchmark baseline.
FgeMaps ComputeFgeMapsReference(const Scene& scene, const Camera& camera, const Gripper& gripper,
                                const FgeParams& params, double angle_rad, double contact_height_m);

}  // namespace softgrasp::core
