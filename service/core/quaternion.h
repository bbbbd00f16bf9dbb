#pragma once
/// Unit quaternions in the two component orders the project meets: (w, x, y, z) in core and
/// the REST API (`q_CG_wxyz`, `orientation_wxyz`), (x, y, z, w) on DDS / ROS 2 and in the
/// simulator's manifests (`orientation_xyzw`, `quaternion_xyzw`, Eigen's coeffs()). The one
/// place the order is converted.

#include <array>
#include <cmath>

namespace softgrasp::core {

using QuaternionWxyz = std::array<double, 4>;
using QuaternionXyzw = std::array<double, 4>;

inline QuaternionXyzw XyzwFromWxyz(const QuaternionWxyz& q) { return {q[1], q[2], q[3], q[0]}; }
inline QuaternionWxyz WxyzFromXyzw(const QuaternionXyzw& q) { return {q[3], q[0], q[1], q[2]}; }

/// Euclidean norm of the four components (1 for a rotation).
inline double QuaternionNorm(const std::array<double, 4>& q) {
  return std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
}

}  // namespace softgrasp::core
