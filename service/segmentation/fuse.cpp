#include "service/segmentation/fuse.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <vector>

namespace softgrasp::segmentation {
namespace {

void CheckLabels(const InstanceMasks& masks, const char* name) {
  double max_id = 0;
  if (!masks.labels.empty()) cv::minMaxLoc(masks.labels, nullptr, &max_id);
  if (static_cast<int>(max_id) > masks.count()) {
    throw std::invalid_argument(std::string("FuseInstances: ") + name + " labels exceed its " +
                                std::to_string(masks.count()) + " scores");
  }
}

}  // namespace

InstanceMasks FuseInstances(const InstanceMasks& model, const InstanceMasks& pcl,
                            const FuseParams& params, std::vector<bool>* from_geometry) {
  if (model.labels.size() != pcl.labels.size()) {
    throw std::invalid_argument("FuseInstances: the model's and PCL's label images differ in size");
  }
  CheckLabels(model, "model");
  CheckLabels(pcl, "pcl");
  const int model_count = model.count();
  if (model_count + pcl.count() > std::numeric_limits<std::uint16_t>::max()) {
    throw std::invalid_argument("FuseInstances: too many instances");
  }
  std::vector<bool> confident(static_cast<std::size_t>(model_count) + 1, false);
  for (int id = 1; id <= model_count; ++id) {
    confident[static_cast<std::size_t>(id)] =
        model.scores[static_cast<std::size_t>(id - 1)] >= params.confident_score;
  }

  // How much of each PCL instance the model's confident instances already hold, and how well
  // it matches each model instance (pixel counts of every pair of ids).
  std::vector<int> area(static_cast<std::size_t>(pcl.count()) + 1, 0);
  std::vector<int> covered(area.size(), 0);
  std::vector<int> model_area(static_cast<std::size_t>(model_count) + 1, 0);
  std::map<std::pair<int, int>, int> both;
  for (int v = 0; v < pcl.labels.rows; ++v) {
    const std::uint16_t* p = pcl.labels[v];
    const std::uint16_t* m = model.labels[v];
    for (int u = 0; u < pcl.labels.cols; ++u) {
      ++model_area[m[u]];
      if (p[u] == 0) continue;
      ++area[p[u]];
      if (confident[m[u]]) ++covered[p[u]];
      if (m[u] != 0) ++both[{p[u], m[u]}];
    }
  }
  std::vector<double> best_model_iou(area.size(), 0.0);
  for (const auto& [ids, inter] : both) {
    const auto [p, m] = ids;
    const double iou = static_cast<double>(inter) / (area[p] + model_area[m] - inter);
    best_model_iou[p] = std::max(best_model_iou[p], iou);
  }
  std::vector<bool> adds(area.size(), false);
  for (std::size_t id = 1; id < area.size(); ++id) {
    adds[id] = area[id] > 0 && covered[id] <= params.max_covered_fraction * area[id] &&
               best_model_iou[id] >= params.min_model_iou;
  }

  // A PCL instance that overlaps one confident model instance only, and holds at least
  // extend_min_inside_fraction of it, gives it its pixels the model left as background.
  std::vector<int> extends(area.size(), 0);
  std::vector<int> holders(area.size(), 0);
  for (const auto& [ids, inter] : both) {
    const auto [p, m] = ids;
    if (!confident[static_cast<std::size_t>(m)]) continue;
    ++holders[static_cast<std::size_t>(p)];
    if (inter >= params.extend_min_inside_fraction * model_area[static_cast<std::size_t>(m)]) {
      extends[static_cast<std::size_t>(p)] = m;
    }
  }
  for (std::size_t id = 1; id < area.size(); ++id) {
    if (holders[id] != 1) extends[id] = 0;
  }

  // Model ids keep theirs; the geometry's new objects follow them.
  cv::Mat1w fused = model.labels.clone();
  for (int v = 0; v < fused.rows; ++v) {
    const std::uint16_t* p = pcl.labels[v];
    std::uint16_t* f = fused[v];
    for (int u = 0; u < fused.cols; ++u) {
      if (p[u] != 0 && adds[p[u]] && !confident[f[u]]) {
        f[u] = static_cast<std::uint16_t>(model_count + p[u]);
      } else if (p[u] != 0 && f[u] == 0 && extends[p[u]] != 0) {
        f[u] = static_cast<std::uint16_t>(extends[p[u]]);
      }
    }
  }
  const double scale = static_cast<double>(fused.total()) / (640.0 * 480.0);
  const int min_area = static_cast<int>(std::lround(params.min_area_px * scale));
  InstanceMasks out = Compact(fused, min_area, [&](int old_id) {
    return old_id <= model_count ? model.scores[static_cast<std::size_t>(old_id - 1)]
                                 : params.geometry_score;
  });
  if (from_geometry != nullptr) {
    from_geometry->assign(static_cast<std::size_t>(out.count()), false);
    for (int v = 0; v < fused.rows; ++v) {
      const std::uint16_t* old_id = fused[v];
      const std::uint16_t* new_id = out.labels[v];
      for (int u = 0; u < fused.cols; ++u) {
        if (new_id[u] != 0 && old_id[u] > model_count) (*from_geometry)[new_id[u] - 1u] = true;
      }
    }
  }
  return out;
}

}  // namespace softgrasp::segmentation
