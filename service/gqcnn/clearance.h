#pragma once
/// What an open parallel-jaw gripper would meet on its way down to a grasp, read from one depth
/// image (docs/gqcnn.md, "The gripper's clearance"). Shared by the dataset generator, which stores
/// it with every datapoint, and the `strategy=gqcnn` planner, which drops candidates it does not
/// admit, so that the network is judged on, and asked about, the same grasps.
///
/// The gripper comes down the camera's optical axis with its jaws open to the full stroke. Seen
/// from the camera it covers two finger boxes (finger thickness beyond half the stroke along the
/// grasp axis, finger width across) and, a finger length behind the fingertips, a palm spanning
/// both fingers and the gap between them. A surface under a box that is nearer the camera than the
/// box's lowest point stops it. Surfaces less than `min_height_m` above the floor do not count:
/// the table is no obstacle to fingertips that touch it (Dex-Net's collision check lets the
/// gripper sink 5 mm into the table).
///
/// Units: metres; image coordinates in pixels, at the grasp depth.

#include <opencv2/core/mat.hpp>

#include "service/core/grasp.h"
#include "service/gqcnn/crop.h"

namespace softgrasp::gqcnn {

/// A clearance when no surface above the floor is under a box (and the cap of stored values).
inline constexpr double kNothingUnderGripperM = 1.0;

/// How near the surfaces under the gripper come, as (surface z - grasp depth): negative when a
/// surface is nearer the camera than the grasp centre. kNothingUnderGripperM when none is there,
/// and never more.
struct GripperClearance {
  double jaws_m = kNothingUnderGripperM;  ///< under the two finger boxes
  double palm_m = kNothingUnderGripperM;  ///< under the palm: both fingers and the gap between
};

/// Surfaces under the gripper at `pose`: pixels whose centre lies inside a box (the box sizes of
/// `gripper`, opened to its stroke, scaled by fx / pose.depth_m), with a positive finite depth and
/// a height above the floor (`height_m`, same size as `depth_m`) of at least `min_height_m`. Pixels
/// outside the image are not seen and do not count.
GripperClearance MeasureClearance(const cv::Mat1f& depth_m, const cv::Mat1f& height_m,
                                  const GraspImagePose& pose, double fx_px,
                                  const core::Gripper& gripper, double min_height_m);

/// When a clearance lets `gripper` reach its grasp: its fingertips reach `fingertip_reach_m`
/// beyond the grasp centre and the palm's face is its finger length behind them. The defaults
/// are the rule that agrees best with the mesh collision labels of 150 training fractals (92 % of
/// their grasps, docs/gqcnn.md); the fingertips of the labels' gripper reach 5 mm.
struct ClearanceRule {
  double fingertip_reach_m = 0.003;
  /// Surfaces lower than this above the floor are not obstacles.
  double min_height_m = 0.008;

  bool Admits(const GripperClearance& clearance, const core::Gripper& gripper) const {
    return clearance.jaws_m > fingertip_reach_m &&
           clearance.palm_m > fingertip_reach_m - gripper.finger_length_m;
  }
};

}  // namespace softgrasp::gqcnn
