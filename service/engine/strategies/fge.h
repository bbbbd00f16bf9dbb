#pragma once
/// strategy=fge: the thesis' finger-gripper extraction, grasps at the centre of the contact
/// surface (core::DetectGraspsFge; docs/fge.md). No options of its own: it plans with the
/// request's gripper and FGE search. On request each grasp reports the stiffness model's mean over
/// its contact surface (mean_stiffness).

#include "service/engine/strategy.h"

namespace softgrasp::engine {

const Strategy& FgeStrategy();

}  // namespace softgrasp::engine
