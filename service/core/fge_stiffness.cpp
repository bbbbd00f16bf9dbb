#include "service/core/fge_stiffness.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "service/core/fge_fast.h"
#include "service/core/fge_geometry.h"

namespace softgrasp::core {
namespace {

using fge_detail::AngleOf;
using fge_detail::GripperPx;
using fge_detail::Near;
using fge_detail::SimilarAngle;
using fge_detail::Slice;
using fge_detail::StableContacts;

// At most this many contact checks per map, as in classic FGE.
constexpr int kMaxContactChecksPerMap = 64;
// Closing regions larger than this many pixels are sampled on every second row and column: the
// mean stiffness barely changes and the search gets 4x cheaper.
constexpr int kDenseTemplateMaxPx = 400;

struct Candidate {
  double u_px = 0;
  double v_px = 0;
  double key = 0;  // ranking key: mean stiffness + centre_weight * graspability
  double mean_stiffness = 0;
  float graspability = 0;
  int angle_index = 0;
  int slice_pos = 0;
};

bool Better(const Candidate& a, const Candidate& b) {
  if (a.key != b.key) return a.key > b.key;
  if (a.slice_pos != b.slice_pos) return a.slice_pos < b.slice_pos;
  if (a.angle_index != b.angle_index) return a.angle_index < b.angle_index;
  if (a.v_px != b.v_px) return a.v_px < b.v_px;
  return a.u_px < b.u_px;
}

/// Integer offsets of the closing region T_t (pixel-centre rule) at one angle.
std::vector<cv::Point> ClosingRegionOffsets(double angle_rad, const GripperPx& g, int stride) {
  const double half_len = g.opening_px / 2;
  const double half_w = g.finger_width_px / 2;
  const int reach = static_cast<int>(std::ceil(std::hypot(half_len, half_w))) + 1;
  const double cs = std::cos(angle_rad);
  const double sn = std::sin(angle_rad);
  std::vector<cv::Point> out;
  for (int dv = -reach; dv <= reach; dv += stride) {
    for (int du = -reach; du <= reach; du += stride) {
      const double a = du * cs + dv * sn;
      const double b = -du * sn + dv * cs;
      if (std::abs(a) <= half_len && std::abs(b) <= half_w) out.emplace_back(du, dv);
    }
  }
  return out;
}

/// Mean of `stiffness` over contact pixels (contact != 0) at the offsets around (u, v); NaN
/// when none.
double MeanOverOffsets(const cv::Mat1f& stiffness, const cv::Mat1b& contact, int u, int v,
                       const std::vector<cv::Point>& offsets) {
  double sum = 0;
  int count = 0;
  for (const cv::Point& d : offsets) {
    const int x = u + d.x;
    const int y = v + d.y;
    if (x < 0 || y < 0 || x >= stiffness.cols || y >= stiffness.rows) continue;
    if (contact(y, x) == 0) continue;
    sum += stiffness(y, x);
    ++count;
  }
  return count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
}

struct SliceData {
  Slice slice;
  double px_per_m = 0;
  GripperPx gripper;
  cv::Mat1b contact;  // I_t: graspable surface above the contact height
};

/// Candidates of one (angle, slice) map ranked by the key, NMS, contact check; at most top_k.
std::vector<Candidate> SelectInMap(const FgeMaps& maps, const SliceData& sd,
                                   const cv::Mat1f& stiffness, const Scene& scene, double angle_rad,
                                   int angle_index, int slice_pos,
                                   const StiffnessFgeParams& params) {
  const int step = params.candidate_step_px;
  const int area = static_cast<int>(ClosingRegionOffsets(angle_rad, sd.gripper, 1).size());
  const auto offsets =
      ClosingRegionOffsets(angle_rad, sd.gripper, area > kDenseTemplateMaxPx ? 2 : 1);
  std::vector<Candidate> all;
  for (int v = 0; v < maps.graspability.rows; v += step) {
    const float* g = maps.graspability.ptr<float>(v);
    for (int u = 0; u < maps.graspability.cols; u += step) {
      if (!(g[u] > 0)) continue;
      // Eq. 3.6-3.7 as a mean (A_st / A_t): the thesis' clutter ranking, "same as the mean of
      // stiffness" (eq. 3.14), so region size does not bias it.
      const double mean = MeanOverOffsets(stiffness, sd.contact, u, v, offsets);
      if (!std::isfinite(mean)) continue;
      all.push_back({static_cast<double>(u), static_cast<double>(v),
                     mean + params.centre_weight * g[u], mean, g[u], angle_index, slice_pos});
    }
  }
  std::sort(all.begin(), all.end(), Better);
  std::vector<Candidate> kept;
  int checks = 0;
  for (const Candidate& c : all) {
    if (static_cast<int>(kept.size()) >= params.fge.top_k || checks >= kMaxContactChecksPerMap) {
      break;
    }
    const bool suppressed = std::any_of(kept.begin(), kept.end(), [&](const Candidate& k) {
      return Near(c, k, params.fge.nms_radius_px);
    });
    if (suppressed) continue;
    ++checks;
    if (StableContacts(scene.height_m, c.u_px, c.v_px, angle_rad, sd.gripper, sd.px_per_m,
                       sd.slice.tip_height_m)) {
      kept.push_back(c);
    }
  }
  return kept;
}

Grasp MakeGrasp(const Candidate& c, const SliceData& sd, const Scene& scene, const Camera& camera,
                const Gripper& gripper, const FgeParams& params) {
  Grasp grasp;
  grasp.center_u_px = c.u_px;
  grasp.center_v_px = c.v_px;
  grasp.angle_rad = AngleOf(c.angle_index, params.num_angles);
  grasp.opening_px = sd.gripper.opening_px;
  grasp.opening_m = gripper.opening_stroke_mm * 1e-3;
  grasp.finger_width_px = sd.gripper.finger_width_px;
  grasp.finger_thickness_px = sd.gripper.finger_thickness_px;
  grasp.contact_height_m = sd.slice.contact_height_m;
  grasp.grasp_height_m = sd.slice.tip_height_m;
  grasp.score = c.graspability;
  grasp.height_step = sd.slice.index;
  grasp.p_CG_m =
      fge_detail::PointOnRayAtHeight(camera, scene.floor, c.u_px, c.v_px, sd.slice.tip_height_m);
  grasp.q_CG_wxyz = fge_detail::QuaternionAboutZ(grasp.angle_rad);
  grasp.mean_stiffness = c.mean_stiffness;
  return grasp;
}

}  // namespace

std::vector<Grasp> DetectGraspsStiffness(const Scene& scene, const Camera& camera,
                                         const cv::Mat1f& stiffness_map, const Gripper& gripper,
                                         const StiffnessFgeParams& params) {
  const FgeParams& fp = params.fge;
  fge_detail::CheckInputs(camera, gripper, fp);
  if (!(params.centre_weight >= 0) || params.candidate_step_px < 1 ||
      params.candidate_step_px > 16) {
    throw std::invalid_argument(
        "StiffnessFgeParams: centre_weight must be >= 0, candidate_step_px in 1..16");
  }
  if (scene.height_m.empty()) return {};
  if (stiffness_map.size() != scene.height_m.size()) {
    throw std::invalid_argument(
        "DetectGraspsStiffness: the stiffness map must have the scene's "
        "size");
  }
  const auto search = fge_detail::SearchSlices(scene.height_m, gripper, fp);
  if (search.slices.empty()) return {};
  fge_detail::FastFge fast(scene, camera, gripper, fp, search.slices, search.graspable);

  std::vector<SliceData> slices;
  for (const Slice& s : search.slices) {
    SliceData sd;
    sd.slice = s;
    sd.px_per_m = fge_detail::PxPerMetre(scene.floor, camera, s.contact_height_m);
    sd.gripper = fge_detail::GripperAtScale(gripper, sd.px_per_m);
    sd.contact = (scene.height_m > static_cast<float>(s.contact_height_m)) & search.graspable;
    slices.push_back(std::move(sd));
  }
  // NaN / out-of-range map values count as the softest score (never preferred).
  cv::Mat1f stiffness = stiffness_map.clone();
  cv::patchNaNs(stiffness, 0.0);
  cv::min(cv::max(stiffness, 0.0f), 1.0f, stiffness);

  std::vector<Candidate> all;
  for (int ai = 0; ai < fp.num_angles; ++ai) {
    const double angle = AngleOf(ai, fp.num_angles);
    for (std::size_t si = 0; si < slices.size(); ++si) {
      const FgeMaps maps = fast.Maps(angle, si);
      for (const Candidate& c : SelectInMap(maps, slices[si], stiffness, scene, angle, ai,
                                            static_cast<int>(si), params)) {
        all.push_back(c);
      }
    }
  }
  std::sort(all.begin(), all.end(), Better);
  std::vector<Grasp> grasps;
  std::vector<Candidate> kept;
  for (const Candidate& c : all) {
    if (static_cast<int>(kept.size()) >= fp.top_k) break;
    const bool suppressed = std::any_of(kept.begin(), kept.end(), [&](const Candidate& k) {
      return Near(c, k, fp.nms_radius_px) && SimilarAngle(c, k, fp.num_angles);
    });
    if (suppressed) continue;
    kept.push_back(c);
    grasps.push_back(
        MakeGrasp(c, slices[static_cast<std::size_t>(c.slice_pos)], scene, camera, gripper, fp));
  }
  return grasps;
}

double ContactMeanStiffness(const Scene& scene, const cv::Mat1f& stiffness_map,
                            const Grasp& grasp) {
  if (stiffness_map.size() != scene.height_m.size()) {
    throw std::invalid_argument(
        "ContactMeanStiffness: the stiffness map must have the scene's "
        "size");
  }
  const GripperPx g{grasp.opening_px, grasp.finger_width_px, grasp.finger_thickness_px};
  const auto offsets = ClosingRegionOffsets(grasp.angle_rad, g, 1);
  const cv::Mat1b contact = scene.height_m > static_cast<float>(grasp.contact_height_m);
  cv::Mat1f stiffness = stiffness_map.clone();
  cv::patchNaNs(stiffness, 0.0);
  return MeanOverOffsets(stiffness, contact, static_cast<int>(std::lround(grasp.center_u_px)),
                         static_cast<int>(std::lround(grasp.center_v_px)), offsets);
}

}  // namespace softgrasp::core
