#include "tools/train/bootstrap.h"

#include <algorithm>
#include <random>
#include <stdexcept>

namespace softgrasp::tools {

Interval BootstrapInterval(int units, const SceneStatistic& statistic, int resamples,
                           std::uint64_t seed, double level) {
  if (units < 1 || resamples < 10 || !(level > 0.0 && level < 1.0)) {
    throw std::invalid_argument(
        "BootstrapInterval: needs units >= 1, resamples >= 10 and a level in (0, 1)");
  }
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> pick(0, units - 1);
  std::vector<int> sample(static_cast<std::size_t>(units));
  std::vector<double> values;
  values.reserve(static_cast<std::size_t>(resamples));
  for (int r = 0; r < resamples; ++r) {
    for (int& index : sample) index = pick(rng);
    const double v = statistic(sample);
    if (std::isfinite(v)) values.push_back(v);
  }
  if (2 * values.size() < static_cast<std::size_t>(resamples)) return {};
  std::sort(values.begin(), values.end());
  // Nearest-rank percentiles of the sorted resample statistics.
  const auto at = [&](double q) {
    const double rank = q * static_cast<double>(values.size() - 1);
    return values[static_cast<std::size_t>(std::lround(rank))];
  };
  const double tail = (1.0 - level) / 2.0;
  return {at(tail), at(1.0 - tail)};
}

double SampleMean(const std::vector<double>& per_scene, std::span<const int> sample) {
  double sum = 0.0;
  int n = 0;
  for (const int index : sample) {
    const double v = per_scene.at(static_cast<std::size_t>(index));
    if (!std::isfinite(v)) continue;
    sum += v;
    ++n;
  }
  return n > 0 ? sum / n : std::nan("");
}

}  // namespace softgrasp::tools
