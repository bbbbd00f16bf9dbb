#include "service/segmentation/instances.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace softgrasp::segmentation {

const char* MethodName(Method method) {
  switch (method) {
    case Method::kModel:
      return "model";
    case Method::kPcl:
      return "pcl";
    case Method::kFused:
      return "fused";
  }
  return "unknown";
}

namespace detail {

std::vector<OldIdStats> CountOldIds(const cv::Mat1w& labels) {
  std::vector<int> area(std::numeric_limits<std::uint16_t>::max() + 1, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const std::uint16_t* row = labels[v];
    for (int u = 0; u < labels.cols; ++u) ++area[row[u]];
  }
  std::vector<OldIdStats> stats;
  for (std::size_t id = 1; id < area.size(); ++id) {
    if (area[id] > 0) stats.push_back({static_cast<int>(id), area[id], 0.0f});
  }
  return stats;
}

InstanceMasks Renumber(const cv::Mat1w& labels, std::vector<OldIdStats> stats, int min_area_px) {
  std::erase_if(stats, [&](const OldIdStats& s) { return s.area_px < min_area_px; });
  std::sort(stats.begin(), stats.end(), [](const OldIdStats& a, const OldIdStats& b) {
    if (a.score != b.score) return a.score > b.score;
    if (a.area_px != b.area_px) return a.area_px > b.area_px;
    return a.old_id < b.old_id;
  });
  std::vector<std::uint16_t> new_id(std::numeric_limits<std::uint16_t>::max() + 1, 0);
  InstanceMasks out;
  for (std::size_t i = 0; i < stats.size(); ++i) {
    new_id[static_cast<std::size_t>(stats[i].old_id)] = static_cast<std::uint16_t>(i + 1);
    out.scores.push_back(std::clamp(stats[i].score, 0.0f, 1.0f));
  }
  out.labels.create(labels.size());
  for (int v = 0; v < labels.rows; ++v) {
    const std::uint16_t* in = labels[v];
    std::uint16_t* o = out.labels[v];
    for (int u = 0; u < labels.cols; ++u) o[u] = new_id[in[u]];
  }
  return out;
}

}  // namespace detail

InstanceMasks DropCutByBorder(const InstanceMasks& masks, int max_border_px) {
  if (max_border_px <= 0 || masks.labels.empty()) return masks;
  const int w = masks.labels.cols, h = masks.labels.rows;
  std::vector<int> border(static_cast<std::size_t>(masks.count()) + 1, 0);
  for (int v = 0; v < h; ++v) {
    const std::uint16_t* row = masks.labels[v];
    const bool edge_row = v == 0 || v == h - 1;
    for (int u = 0; u < w; ++u) {
      if ((edge_row || u == 0 || u == w - 1) && row[u] > 0 && row[u] <= masks.count()) {
        ++border[row[u]];
      }
    }
  }
  std::vector<std::uint16_t> new_id(border.size(), 0);
  InstanceMasks out;
  for (std::size_t id = 1; id < border.size(); ++id) {
    if (border[id] >= max_border_px) continue;
    out.scores.push_back(masks.scores[id - 1]);
    new_id[id] = static_cast<std::uint16_t>(out.scores.size());
  }
  out.labels.create(masks.labels.size());
  for (int v = 0; v < h; ++v) {
    const std::uint16_t* in = masks.labels[v];
    std::uint16_t* o = out.labels[v];
    for (int u = 0; u < w; ++u) o[u] = in[u] < new_id.size() ? new_id[in[u]] : 0;
  }
  return out;
}

std::vector<InstanceInfo> DescribeInstances(const InstanceMasks& masks, const core::Scene& scene,
                                            const core::Camera& camera,
                                            const cv::Mat1f& deformability,
                                            const cv::Mat1f& stiffness) {
  const cv::Size size = masks.labels.size();
  if (scene.depth_filled_m.size() != size || scene.height_m.size() != size) {
    throw std::invalid_argument("DescribeInstances: labels and scene differ in size");
  }
  if ((!deformability.empty() && deformability.size() != size) ||
      (!stiffness.empty() && stiffness.size() != size)) {
    throw std::invalid_argument("DescribeInstances: a map's size differs from the labels'");
  }
  struct Acc {
    int area = 0;
    int u0 = std::numeric_limits<int>::max(), v0 = std::numeric_limits<int>::max(), u1 = -1,
        v1 = -1;
    double su = 0, sv = 0, sx = 0, sy = 0, sz = 0, top = -std::numeric_limits<double>::infinity();
    double sdef = 0, sstiff = 0;
  };
  std::vector<Acc> acc(static_cast<std::size_t>(masks.count()));
  for (int v = 0; v < size.height; ++v) {
    const std::uint16_t* lab = masks.labels[v];
    const float* z = scene.depth_filled_m[v];
    const float* h = scene.height_m[v];
    for (int u = 0; u < size.width; ++u) {
      const int id = lab[u];
      if (id == 0 || id > masks.count()) continue;
      Acc& a = acc[static_cast<std::size_t>(id - 1)];
      ++a.area;
      a.u0 = std::min(a.u0, u);
      a.v0 = std::min(a.v0, v);
      a.u1 = std::max(a.u1, u);
      a.v1 = std::max(a.v1, v);
      a.su += u;
      a.sv += v;
      const double zm = z[u];
      a.sx += (u - camera.cx) * zm / camera.fx;
      a.sy += (v - camera.cy) * zm / camera.fy;
      a.sz += zm;
      a.top = std::max(a.top, static_cast<double>(h[u]));
      if (!deformability.empty()) a.sdef += deformability(v, u);
      if (!stiffness.empty()) a.sstiff += stiffness(v, u);
    }
  }
  std::vector<InstanceInfo> out;
  for (int i = 0; i < masks.count(); ++i) {
    const Acc& a = acc[static_cast<std::size_t>(i)];
    InstanceInfo info;
    info.id = i + 1;
    info.score = masks.scores[static_cast<std::size_t>(i)];
    info.area_px = a.area;
    if (a.area > 0) {
      const double n = a.area;
      info.bbox_px = cv::Rect(a.u0, a.v0, a.u1 - a.u0 + 1, a.v1 - a.v0 + 1);
      info.centroid_px = {a.su / n, a.sv / n};
      info.centroid_m = {a.sx / n, a.sy / n, a.sz / n};
      info.top_height_m = a.top;
      if (!deformability.empty()) info.mean_deformability = a.sdef / n;
      if (!stiffness.empty()) info.mean_stiffness = a.sstiff / n;
    }
    out.push_back(info);
  }
  return out;
}

}  // namespace softgrasp::segmentation
