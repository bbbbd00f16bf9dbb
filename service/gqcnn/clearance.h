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
/// box's lowest point stops it. Surfaces less than `min_height_m` above the floor are floor: the
/// fingertips may come down onto it, into its sensor noise, but not below it (Dex-Net's collision
/// check lets its gripper, whose tips reach 5 mm beyond the grasp centre, sink 5 mm into the
/// table; the simulator's fingertips stop at the grasp centre's height). That also refuses a
/// grasp placed under the real table by a floor plane fitted a few millimetres off, and fingers
/// landing on a flat object lower than `min_height_m`.
///
/// Units: metres; image coordinates in pixels, at the grasp depth.

#include <opencv2/core/mat.hpp>

#include "service/core/grasp.h"
#include "service/gqcnn/crop.h"
#include "service/gqcnn/dataset_format.h"

namespace softgrasp::gqcnn {

/// A clearance when nothing is under a box (and the largest value a clearance takes).
inline constexpr double kNothingUnderGripperM = 1.0;

/// How near the surfaces under the gripper come, as (surface z - grasp depth): negative when a
/// surface is nearer the camera than the grasp centre. kNothingUnderGripperM when none is there,
/// and never more.
struct GripperClearance {
  double jaws_m = kNothingUnderGripperM;   ///< surfaces above the floor under the finger boxes
  double palm_m = kNothingUnderGripperM;   ///< the same under the palm: fingers and the gap
  double floor_m = kNothingUnderGripperM;  ///< the floor under the finger boxes
};

/// The clearance a dataset record stores (NaN in records written before clearances were).
inline GripperClearance StoredClearance(const GraspDatapoint& d) {
  return {d.jaw_clearance_m, d.palm_clearance_m, d.floor_clearance_m};
}

/// Surfaces under the gripper at `pose`: pixels a box touches (whose centre lies inside the box
/// grown by half a pixel; the box sizes of `gripper`, opened to its stroke, scaled by
/// fx / pose.depth_m) that have a positive finite depth and a finite height above the floor
/// (`height_m`, same size as `depth_m`). Those at least `min_height_m` high are obstacles, the
/// others floor. Pixels outside the image are not seen and do not count.
GripperClearance MeasureClearance(const cv::Mat1f& depth_m, const cv::Mat1f& height_m,
                                  const GraspImagePose& pose, double fx_px,
                                  const core::Gripper& gripper, double min_height_m);

/// When a clearance lets `gripper` reach its grasp: obstacles under the fingers lie more than
/// `fingertip_reach_m` beyond the grasp centre, under the palm more than the finger length less
/// than that, and the floor under the fingers less than `floor_noise_m` nearer than the grasp
/// centre. The obstacle numbers are the rule that agrees best with the mesh collision labels of
/// 150 training fractals (92 % of their grasps, docs/gqcnn.md); the fingertips of the labels'
/// gripper reach 5 mm.
struct ClearanceRule {
  double fingertip_reach_m = 0.003;
  /// Surfaces lower than this above the floor are floor.
  double min_height_m = 0.008;
  /// How far floor readings may rise above the fingertips (sensor noise, not a surface).
  double floor_noise_m = 0.003;

  bool Admits(const GripperClearance& clearance, const core::Gripper& gripper) const {
    return clearance.jaws_m > fingertip_reach_m &&
           clearance.palm_m > fingertip_reach_m - gripper.finger_length_m &&
           clearance.floor_m > -floor_noise_m;
  }
};

}  // namespace softgrasp::gqcnn
