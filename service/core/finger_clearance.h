#pragma once
/// Whether a top-down grasp's fingers descend through surfaces the camera saw, tested in 3-D.
///
/// FGE tests finger footprints on the image grid at the grasp's scale, as if the camera looked
/// straight down at every pixel. A vertical surface seen obliquely (a bin wall towards the image
/// border, the side of a tall neighbour) then shows, inside a footprint, heights below the
/// fingertips, while the solid behind it stands in the finger's way: the finger's column, seen
/// in perspective, leans outwards with height and meets the wall's top. This test back-projects
/// the observed surfaces around each finger and counts those inside the finger's column.
#include "service/core/depth.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"

namespace softgrasp::core {

class FingerClearance {
 public:
  /// Surfaces lower than this above the fingertips are not in the way (depth noise, the surface
  /// the fingertips rest on).
  static constexpr double kToleranceM = 0.002;
  /// The finger box is grown by this on every side, as FGE's templates are by one pixel: a
  /// neighbour's edge that a footprint misses by less than a pixel still meets the finger (on
  /// 200 simulated clutter scenes it removed the deformability planner's remaining collisions
  /// and most `too_wide` failures: docs/fge.md).
  static constexpr double kMarginM = 0.001;
  /// A finger is blocked from this many observed points inside its column (one stray pixel on
  /// an edge is not a wall).
  static constexpr int kMinBlockingPoints = 3;

  /// `scene`: its depth_filled_m gives where each pixel's surface is, its height_m how high it
  /// stands (a planner's view may lower surfaces a finger may press into). Both must outlive
  /// this object.
  FingerClearance(const Scene& scene, const Camera& camera);

  /// Observed points inside the finger columns of `g` (its pose p_CG_m / q_CG_wxyz, opening_m
  /// and grasp_height_m; the gripper's finger width and thickness, grown by kMarginM): footprint
  /// in the camera's x-y plane (the approach is along the camera's +z), more than kToleranceM
  /// above the fingertips. The larger count of the two fingers.
  int PointsInFingers(const Grasp& g, const Gripper& gripper) const;

  bool Clear(const Grasp& g, const Gripper& gripper) const {
    return PointsInFingers(g, gripper) < kMinBlockingPoints;
  }

 private:
  const Scene& scene_;
  Camera camera_;
  double nearest_depth_m_ = 0;  ///< the nearest observed surface: the columns' top
};

}  // namespace softgrasp::core
