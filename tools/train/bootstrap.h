#pragma once
/// Confidence intervals for `softgrasp-train evaluate`'s grasp figures: a percentile bootstrap
/// over scenes. The evaluation draws each scene once and runs every planner on it, so one
/// resample of scene indices serves all planners (a paired bootstrap): ratios and differences
/// between planners get intervals of their own. See docs/stiffness.md, "Evaluation".

#include <cmath>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace softgrasp::tools {

struct Interval {
  double low = std::nan("");
  double high = std::nan("");
};

/// A scene's statistic: `sample` holds scene indices in [0, units), drawn with replacement.
using SceneStatistic = std::function<double(std::span<const int> sample)>;

/// The central `level` (e.g. 0.95) percentile interval of `statistic` over `resamples` bootstrap
/// samples of `units` scenes, drawn with a std::mt19937_64 seeded by `seed` (the same arguments
/// give the same interval). Resamples where the statistic is not finite (no grasp to average,
/// a zero denominator) are left out; when more than half are, the interval is NaN (too few
/// scenes to say). Throws std::invalid_argument for units < 1, resamples < 10, or a level
/// outside (0, 1).
Interval BootstrapInterval(int units, const SceneStatistic& statistic, int resamples,
                           std::uint64_t seed, double level = 0.95);

/// A running mean of the finite values added (NaN and infinities are skipped); NaN while empty.
struct Mean {
  double sum = 0;
  int n = 0;
  void Add(double v) {
    if (std::isfinite(v)) {
      sum += v;
      ++n;
    }
  }
  double value() const { return n > 0 ? sum / n : std::nan(""); }
};

/// The mean of the finite `per_scene` values at the sampled indices (an index drawn twice counts
/// twice); NaN when there is none. A NaN value marks a scene without that figure (no grasp, or no
/// contact to measure deformation on).
double SampleMean(const std::vector<double>& per_scene, std::span<const int> sample);

}  // namespace softgrasp::tools
