// The one place strategies are registered, in order of preference: the default strategy is the
// last one the loaded models serve. A new strategy is a room in this folder and a line here.
#include "service/engine/strategies/deformability.h"
#include "service/engine/strategies/fge.h"
#include "service/engine/strategies/gqcnn.h"
#include "service/engine/strategies/stiffness.h"
#include "service/engine/strategy.h"

namespace softgrasp::engine {

const std::vector<const Strategy*>& AllStrategies() {
  static const std::vector<const Strategy*> strategies = {
      &FgeStrategy(),
      &GqcnnStrategy(),
      &StiffnessStrategy(),
      &DeformabilityStrategy(),
  };
  return strategies;
}

}  // namespace softgrasp::engine
