#pragma once
/// The contact check (docs/fge.md, "Contact check"): whether two fingers closing at an image
/// pose meet faces square enough to hold. A face slanted more than the friction cone, an
/// object's corner or its rounded end slips (in the simulator the contact normal must lie
/// within atan(mu) of the closing axis). FGE's planners and the GQ-CNN policy use it.

#include <opencv2/core.hpp>

namespace softgrasp::core {

/// Gripper sizes in pixels at one image scale.
struct GripperPx {
  double opening_px = 0;
  double finger_width_px = 0;
  double finger_thickness_px = 0;
};

/// kStable: each finger's contact patch is 5 mm (and >= 2 px) long; kFirm: it also covers at
/// least half the finger's width (a face within ~10 deg of the finger pad at typical scales,
/// not an object's end or corner). Planners take firm grasps and fall back to stable ones only
/// when no firm one is found.
enum class ContactHold { kNone, kStable, kFirm };

/// `height_m`: each pixel's surface height above the floor (metres; larger = nearer the
/// approaching gripper). The closing region is centred at (u_px, v_px), its axis at angle_rad
/// (image, from +u towards +v), `gripper.opening_px` long and `gripper.finger_width_px` wide;
/// `px_per_m` is the image scale there. Along every line of the region parallel to the closing
/// axis, the outermost surface pixel above tip_height_m on each side is where that line meets
/// a finger; lines within 2 mm of the finger's first contact form its patch. Outside the image
/// there is no surface.
ContactHold CheckContacts(const cv::Mat1f& height_m, double u_px, double v_px, double angle_rad,
                          const GripperPx& gripper, double px_per_m, double tip_height_m);

/// CheckContacts sees faces only in the image plane. A rounded top cut below its crown (a dome,
/// a can's rim, an animal's back) gives long patches there, but its faces at the fingertips
/// lean back: their normals point up, out of the friction cone, and the grasp slips. This
/// checks the faces' steepness where each finger first touches: a face whose normal lies
/// within atan(friction_coefficient) of the horizontal closing axis rises at least
/// 1 / friction_coefficient per unit of run. On each line where the finger meets the surface
/// (as in CheckContacts: the outermost pixel above the tips), the surface somewhere within
/// kSteepRunM (>= 1 px) inward of the contact must stand that much above the tips, the run
/// counted from the pixel outside the contact (the face crosses the tips' height in between).
/// A vertical wall seen from above is a jump and passes once its top is 1 px / mu above the
/// tips. True when, on each finger, at least half of the lines whose contact lies within a
/// pixel of that finger's first contact are steep; false when a finger meets nothing.
inline constexpr double kSteepRunM = 0.002;
bool ContactFacesSteep(const cv::Mat1f& height_m, double u_px, double v_px, double angle_rad,
                       const GripperPx& gripper, double px_per_m, double tip_height_m,
                       double friction_coefficient);

}  // namespace softgrasp::core
