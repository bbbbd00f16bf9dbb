#include "service/models/segmentation_grouping.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

namespace softgrasp::models {
namespace {

struct Peak {
  float value = 0;
  double u = 0, v = 0;  ///< output pixels
};

std::vector<Peak> FindPeaks(const cv::Mat1f& centre, const GroupingParams& p, double sx,
                            double sy) {
  const int window = std::max(1, p.peak_window_px | 1);
  cv::Mat1f dilated;
  cv::dilate(centre, dilated, cv::getStructuringElement(cv::MORPH_RECT, {window, window}));
  struct Candidate {
    float value;
    int u, v;
  };
  std::vector<Candidate> candidates;
  for (int v = 0; v < centre.rows; ++v) {
    for (int u = 0; u < centre.cols; ++u) {
      const float c = centre(v, u);
      if (c > p.centre_threshold && c >= dilated(v, u)) candidates.push_back({c, u, v});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    if (a.value != b.value) return a.value > b.value;
    return a.v != b.v ? a.v < b.v : a.u < b.u;
  });
  // Plateaus give several equal maxima: keep one per window.
  std::vector<Candidate> kept;
  const int min_d2 = (window / 2) * (window / 2);
  for (const Candidate& c : candidates) {
    if (static_cast<int>(kept.size()) >= p.max_instances) break;
    const bool near = std::any_of(kept.begin(), kept.end(), [&](const Candidate& k) {
      return (k.u - c.u) * (k.u - c.u) + (k.v - c.v) * (k.v - c.v) <= min_d2;
    });
    if (!near) kept.push_back(c);
  }
  std::vector<Peak> peaks;
  for (const Candidate& c : kept) {
    peaks.push_back({c.value, (c.u + 0.5) * sx - 0.5, (c.v + 0.5) * sy - 0.5});
  }
  return peaks;
}

}  // namespace

segmentation::InstanceMasks GroupInstances(const HeadMaps& maps, cv::Size output_size,
                                           const GroupingParams& p, cv::Mat1f* foreground_out) {
  const cv::Size model = maps.foreground.size();
  if (maps.foreground.empty() || maps.centre.size() != model || maps.offset_u_px.size() != model ||
      maps.offset_v_px.size() != model || output_size.width <= 0 || output_size.height <= 0) {
    throw std::invalid_argument("GroupInstances: empty or mismatched head maps");
  }
  const double sx = static_cast<double>(output_size.width) / model.width;
  const double sy = static_cast<double>(output_size.height) / model.height;
  const std::vector<Peak> peaks = FindPeaks(maps.centre, p, sx, sy);

  cv::Mat1f fg, du, dv;
  cv::resize(maps.foreground, fg, output_size, 0, 0, cv::INTER_LINEAR);
  cv::resize(maps.offset_u_px, du, output_size, 0, 0, cv::INTER_LINEAR);
  cv::resize(maps.offset_v_px, dv, output_size, 0, 0, cv::INTER_LINEAR);

  cv::Mat1w labels(output_size, std::uint16_t{0});
  std::vector<double> fg_sum(peaks.size() + 1, 0.0);
  std::vector<int> area(peaks.size() + 1, 0);
  const double max_vote_d2 = p.max_vote_distance_px > 0
                                 ? p.max_vote_distance_px * p.max_vote_distance_px * sx * sy
                                 : std::numeric_limits<double>::infinity();
  if (!peaks.empty()) {
    for (int v = 0; v < output_size.height; ++v) {
      const float* f = fg[v];
      const float* ou = du[v];
      const float* ov = dv[v];
      std::uint16_t* lab = labels[v];
      for (int u = 0; u < output_size.width; ++u) {
        if (!(f[u] > p.foreground_threshold)) continue;
        const double tu = u + ou[u] * sx;
        const double tv = v + ov[u] * sy;
        double best = std::numeric_limits<double>::infinity();
        std::size_t best_k = 0;
        for (std::size_t k = 0; k < peaks.size(); ++k) {
          const double d2 =
              (peaks[k].u - tu) * (peaks[k].u - tu) + (peaks[k].v - tv) * (peaks[k].v - tv);
          if (d2 < best) {
            best = d2;
            best_k = k;
          }
        }
        if (!(best <= max_vote_d2)) continue;
        lab[u] = static_cast<std::uint16_t>(best_k + 1);
        fg_sum[best_k + 1] += f[u];
        ++area[best_k + 1];
      }
    }
  }
  if (foreground_out) *foreground_out = fg;
  const segmentation::InstanceMasks compact =
      segmentation::Compact(labels, p.min_area_px, [&](int id) {
        const auto k = static_cast<std::size_t>(id);
        return peaks[k - 1].value * (area[k] > 0 ? fg_sum[k] / area[k] : 0.0);
      });
  const int border_px =
      p.max_border_px > 0
          ? std::max(1, static_cast<int>(std::lround(p.max_border_px * output_size.width / 640.0)))
          : 0;
  return segmentation::DropCutByBorder(compact, border_px);
}

}  // namespace softgrasp::models
