#pragma once
/// strategy=stiffness: stiffness-aware FGE on the stiffness model's map (or a given map), grasps
/// ranked by the mean stiffness under the fingers (core::DetectGraspsStiffness; docs/stiffness.md).

#include "service/core/fge_stiffness.h"
#include "service/engine/strategy.h"

namespace softgrasp::engine {

struct StiffnessOptions final : StrategyOptions {
  /// Its ranking parameters; `params.fge` is replaced by the request's FGE search.
  core::StiffnessFgeParams params;
};

const Strategy& StiffnessStrategy();

}  // namespace softgrasp::engine
