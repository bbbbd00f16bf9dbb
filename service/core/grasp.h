#pragma once
/// Two-finger gripper geometry and the 4-DoF grasps the planners return.

#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace softgrasp::core {

/// A parallel two-finger gripper, the one description the planners (its geometry, seen from
/// above, approach along the camera's +z) and the simulator (geometry and forces) share. SI
/// units: metres and newtons. Data sheets give sizes in millimetres: convert once where they are
/// read (the REST fields and the configuration file say `_mm`).
struct Gripper {
  double opening_stroke_m = 0.05;     ///< largest distance between the inner finger faces
  double finger_width_m = 0.015;      ///< finger size across the closing axis
  double finger_thickness_m = 0.008;  ///< finger size along the closing axis
  double finger_length_m = 0.04;      ///< how far the fingers reach below the palm
  double closing_force_n = 10.0;      ///< force each finger pushes with once in contact
  double friction_coefficient = 0.5;  ///< finger pad / object Coulomb friction
  /// Largest downward force a descending finger may push a neighbour with (the arm stops above
  /// it): a neighbour that yields to the fingertip height under this force is pressed aside
  /// (docs/sim-grasp-execution.md); 0 = every contact on the way down collides.
  double max_press_force_n = 20.0;
};

/// Millimetres (data sheets, the REST fields) to metres, and back rounded to a nanometre so a
/// size given in millimetres reads back exactly as given.
inline double MetresFromMm(double mm) { return mm * 1e-3; }
inline double MmFromMetres(double m) { return std::round(m * 1e9) / 1e6; }

/// One grasp. Pixel quantities are in the input image; the pose is in the camera frame C
/// (OpenCV convention). Heights are measured above the fitted floor plane.
struct Grasp {
  double center_u_px = 0;      ///< image column of the grasp centre
  double center_v_px = 0;      ///< image row of the grasp centre
  double angle_rad = 0;        ///< closing axis angle in the image, from +u towards +v, in [0, pi)
  double opening_px = 0;       ///< distance between the inner finger faces, pixels
  double opening_m = 0;        ///< same, metres, at the grasp point
  double finger_width_px = 0;  ///< finger footprint across the closing axis, pixels
  double finger_thickness_px = 0;  ///< finger footprint along the closing axis, pixels
  double contact_height_m = 0;     ///< slice whose surface the fingers close on, above the floor
  double grasp_height_m = 0;  ///< fingertip height above the floor (contact slice minus grip depth)
  double score = 0;           ///< graspability, in [0, 1]; higher is better
  int height_step = 0;        ///< index of the height slice used (0 = highest)
  /// Grasp point (between the fingertips) in the camera frame, metres.
  std::array<double, 3> p_CG_m{0, 0, 0};
  /// Orientation of the gripper frame G in C as a unit quaternion (w, x, y, z). G's z axis is the
  /// approach direction (= camera +z), G's x axis is the closing axis.
  std::array<double, 4> q_CG_wxyz{1, 0, 0, 0};
  /// Mean stiffness score in [0, 1] of the contact surface inside the closing region (eq. 3.14
  /// on the stiffness map used); NaN when no stiffness map was involved (classic FGE).
  double mean_stiffness = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace softgrasp::core
