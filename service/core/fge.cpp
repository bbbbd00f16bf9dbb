// FGE grasp search: multi-height slices x angles with the fast maps, local maxima, a contact
// check, non-maximum suppression, grasp poses. See docs/fge.md.
#include "service/core/fge.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <vector>

#include "service/core/fge_fast.h"
#include "service/core/fge_geometry.h"
#include "service/core/finger_clearance.h"

namespace softgrasp::core {
namespace {

using fge_detail::AngleOf;
using fge_detail::LocalMaximum;
using fge_detail::Near;
using fge_detail::SimilarAngle;
using fge_detail::Slice;

using fge_detail::kMaxContactChecksPerMap;

struct Candidate {
  double u_px = 0;
  double v_px = 0;
  float score = 0;
  int angle_index = 0;
  int slice_pos = 0;  // position in the slice list; slices are ordered highest first
  int batch = 0;      // slice batch (SliceBatches): grasps of a higher batch always rank first
  int clear = -1;     // finger clearance: -1 not tested yet, 0 blocked, 1 clear
};

// Best first: higher batch, higher score, then higher slice, then a fixed order (angle, row,
// column).
bool Better(const Candidate& a, const Candidate& b) {
  if (a.batch != b.batch) return a.batch < b.batch;
  if (a.score != b.score) return a.score > b.score;
  if (a.slice_pos != b.slice_pos) return a.slice_pos < b.slice_pos;
  if (a.angle_index != b.angle_index) return a.angle_index < b.angle_index;
  if (a.v_px != b.v_px) return a.v_px < b.v_px;
  return a.u_px < b.u_px;
}

// Angle indices in the order the fast path likes: with an even count, each angle is followed by
// the one 90 degrees further, whose rotated image is an exact turn of the previous one.
std::vector<int> AngleOrder(int num_angles) {
  std::vector<int> order;
  const int half = num_angles / 2;
  if (num_angles % 2 == 0) {
    for (int i = 0; i < half; ++i) order.insert(order.end(), {i, i + half});
  } else {
    for (int i = 0; i < num_angles; ++i) order.push_back(i);
  }
  return order;
}

struct ContactGeometry {
  double px_per_m = 0;
  GripperPx gripper;
  double tip_height_m = 0;
};

// One map's candidates that pass the contact check: firm ones, and (kept aside for when no map
// has a firm one) those whose contacts are only stable (ContactHold).
struct MapSelection {
  std::vector<Candidate> firm;
  std::vector<Candidate> stable;
};

// Per map: best first, spatial NMS, contact check; keeps at most top_k of each kind.
MapSelection SelectInMap(std::vector<Candidate> peaks, const Scene& scene,
                         const ContactGeometry& geo, double angle_rad, const FgeParams& params) {
  std::sort(peaks.begin(), peaks.end(), Better);
  MapSelection out;
  const auto near_one_of = [&](const std::vector<Candidate>& kept, const Candidate& c) {
    return std::any_of(kept.begin(), kept.end(),
                       [&](const Candidate& k) { return Near(c, k, params.nms_radius_px); });
  };
  int checks = 0;
  for (const Candidate& c : peaks) {
    if (static_cast<int>(out.firm.size()) >= params.top_k || checks >= kMaxContactChecksPerMap) {
      break;
    }
    if (near_one_of(out.firm, c)) continue;
    ++checks;
    const ContactHold hold = CheckContacts(scene.height_m, c.u_px, c.v_px, angle_rad, geo.gripper,
                                           geo.px_per_m, geo.tip_height_m);
    if (hold == ContactHold::kFirm) {
      out.firm.push_back(c);
    } else if (hold == ContactHold::kStable && static_cast<int>(out.stable.size()) < params.top_k &&
               !near_one_of(out.stable, c)) {
      out.stable.push_back(c);
    }
  }
  return out;
}

// Best first, NMS across similar angles, at most top_k. A candidate whose fingers are blocked
// (`clear`, tested only when it would be kept, and remembered in `all`) neither counts nor
// suppresses a neighbour.
std::vector<Candidate> RankGlobally(std::vector<Candidate>& all, const FgeParams& params,
                                    const std::function<bool(const Candidate&)>& clear) {
  std::sort(all.begin(), all.end(), Better);
  std::vector<Candidate> kept;
  for (Candidate& c : all) {
    if (static_cast<int>(kept.size()) >= params.top_k) break;
    if (c.clear == 0) continue;
    const bool suppressed = std::any_of(kept.begin(), kept.end(), [&](const Candidate& k) {
      return Near(c, k, params.nms_radius_px) && SimilarAngle(c, k, params.num_angles);
    });
    if (suppressed) continue;
    if (c.clear < 0) c.clear = clear(c) ? 1 : 0;
    if (c.clear == 1) kept.push_back(c);
  }
  return kept;
}

Grasp MakeGrasp(const Candidate& c, const Slice& slice, const Scene& scene, const Camera& camera,
                const Gripper& gripper, const FgeParams& params) {
  const double px_per_m = fge_detail::PxPerMetre(scene.floor, camera, slice.contact_height_m);
  const GripperPx g = fge_detail::GripperAtScale(gripper, px_per_m);
  Grasp grasp;
  grasp.center_u_px = c.u_px;
  grasp.center_v_px = c.v_px;
  grasp.angle_rad = AngleOf(c.angle_index, params.num_angles);
  grasp.opening_px = g.opening_px;
  grasp.opening_m = gripper.opening_stroke_m;
  grasp.finger_width_px = g.finger_width_px;
  grasp.finger_thickness_px = g.finger_thickness_px;
  grasp.contact_height_m = slice.contact_height_m;
  grasp.grasp_height_m = slice.tip_height_m;
  grasp.score = c.score;
  grasp.height_step = slice.index;
  grasp.p_CG_m =
      fge_detail::PointOnRayAtHeight(camera, scene.floor, c.u_px, c.v_px, slice.tip_height_m);
  grasp.q_CG_wxyz = fge_detail::QuaternionAboutZ(grasp.angle_rad);
  return grasp;
}

}  // namespace

FgeMaps ComputeFgeMaps(const Scene& scene, const Camera& camera, const Gripper& gripper,
                       const FgeParams& params, double angle_rad, double contact_height_m) {
  fge_detail::CheckInputs(camera, gripper, params);
  const auto search =
      fge_detail::SearchSlices(scene.height_m, scene.contact_allowed,
                               fge_detail::PxPerMetre(scene.floor, camera, 0), gripper, params);
  fge_detail::FastFge fast(scene, camera, gripper, params,
                           {fge_detail::SliceAt(contact_height_m, gripper, params)},
                           search.graspable);
  return fast.Maps(angle_rad, 0);
}

cv::Mat1b GraspableSurfaces(const Scene& scene, const Camera& camera, const Gripper& gripper,
                            const FgeParams& params) {
  fge_detail::CheckInputs(camera, gripper, params);
  if (scene.height_m.empty()) return {};
  return fge_detail::SearchSlices(scene.height_m, scene.contact_allowed,
                                  fge_detail::PxPerMetre(scene.floor, camera, 0), gripper, params)
      .graspable;
}

std::vector<Grasp> DetectGraspsFge(const Scene& scene, const Camera& camera, const Gripper& gripper,
                                   const FgeParams& params) {
  fge_detail::CheckInputs(camera, gripper, params);
  if (scene.height_m.empty()) return {};
  const auto search =
      fge_detail::SearchSlices(scene.height_m, scene.contact_allowed,
                               fge_detail::PxPerMetre(scene.floor, camera, 0), gripper, params);
  const std::vector<Slice>& slices = search.slices;
  std::optional<FingerClearance> clearance;
  if (params.check_finger_clearance) clearance.emplace(scene, camera);
  const auto clear = [&](const Candidate& c) {
    return !clearance ||
           clearance->Clear(MakeGrasp(c, slices[static_cast<std::size_t>(c.slice_pos)], scene,
                                      camera, gripper, params),
                            gripper);
  };
  std::vector<Candidate> firm;    // every map's firm candidates so far
  std::vector<Candidate> stable;  // and those whose contacts are only stable
  std::vector<Candidate> ranked;
  // num_height_steps slices at a time, from the top down, until top_k grasps are found; the
  // grasps of a higher batch rank before those of a lower one.
  const auto batches = fge_detail::SliceBatches(slices.size(), params);
  for (std::size_t b = 0; b < batches.size(); ++b) {
    const auto [first, last] = batches[b];
    const std::vector<Slice> batch(slices.begin() + static_cast<std::ptrdiff_t>(first),
                                   slices.begin() + static_cast<std::ptrdiff_t>(last));
    fge_detail::FastFge fast(scene, camera, gripper, params, batch, search.graspable);
    std::vector<ContactGeometry> geometry;
    for (const Slice& s : batch) {
      const double px_per_m = fge_detail::PxPerMetre(scene.floor, camera, s.contact_height_m);
      geometry.push_back({px_per_m, fge_detail::GripperAtScale(gripper, px_per_m), s.tip_height_m});
    }
    for (int ai : AngleOrder(params.num_angles)) {
      const double angle = AngleOf(ai, params.num_angles);
      const auto maxima = fast.LocalMaxima(angle);
      for (std::size_t si = 0; si < batch.size(); ++si) {
        std::vector<Candidate> peaks;
        for (const LocalMaximum& m : maxima[si]) {
          peaks.push_back(
              {m.u_px, m.v_px, m.score, ai, static_cast<int>(first + si), static_cast<int>(b)});
        }
        MapSelection selected = SelectInMap(std::move(peaks), scene, geometry[si], angle, params);
        firm.insert(firm.end(), selected.firm.begin(), selected.firm.end());
        stable.insert(stable.end(), selected.stable.begin(), selected.stable.end());
      }
    }
    // Firm contacts first: stable-only ones are grasps only when no map has a clear firm one.
    ranked = RankGlobally(firm, params, clear);
    if (ranked.empty()) ranked = RankGlobally(stable, params, clear);
    if (static_cast<int>(ranked.size()) >= params.top_k) break;
  }
  std::vector<Grasp> grasps;
  for (const Candidate& c : ranked) {
    grasps.push_back(MakeGrasp(c, slices[static_cast<std::size_t>(c.slice_pos)], scene, camera,
                               gripper, params));
  }
  return grasps;
}

}  // namespace softgrasp::core
