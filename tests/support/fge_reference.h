#pragma once
/// FGE's maps the straightforward way: cv::filter2D with rotated templates at full resolution.
/// Slow on purpose; the yardstick the fast path (core::ComputeFgeMaps) is tested against and the
/// benchmark's baseline (docs/fge.md).

#include "service/core/fge.h"

namespace softgrasp::core {

/// The maps of core::ComputeFgeMaps for one angle and one contact height.
FgeMaps ComputeFgeMapsReference(const Scene& scene, const Camera& camera, const Gripper& gripper,
                                const FgeParams& params, double angle_rad, double contact_height_m);

}  // namespace softgrasp::core
