#include "service/core/fge_stiffness.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "service/core/fge_fast.h"
#include "service/core/fge_geometry.h"
#include "service/core/finger_clearance.h"

namespace softgrasp::core {
namespace {

using fge_detail::AngleOf;

using fge_detail::kMaxContactChecksPerMap;
using fge_detail::Near;
using fge_detail::SimilarAngle;
using fge_detail::Slice;

void CheckParams(const Camera& camera, const Gripper& gripper, const StiffnessFgeParams& params) {
  if (auto error = ValidateStiffnessFgeInputs(camera, gripper, params)) {
    throw std::invalid_argument(error->message);
  }
}

struct Candidate {
  double u_px = 0;
  double v_px = 0;
  double key = 0;  // ranking key: mean stiffness + centre_weight * graspability
  double mean_stiffness = 0;
  float graspability = 0;
  int angle_index = 0;
  int slice_pos = 0;
  int batch = 0;  // slice batch (SliceBatches): grasps of a higher batch always rank first
};

bool Better(const Candidate& a, const Candidate& b) {
  if (a.batch != b.batch) return a.batch < b.batch;
  if (a.key != b.key) return a.key > b.key;
  if (a.slice_pos != b.slice_pos) return a.slice_pos < b.slice_pos;
  if (a.angle_index != b.angle_index) return a.angle_index < b.angle_index;
  if (a.v_px != b.v_px) return a.v_px < b.v_px;
  return a.u_px < b.u_px;
}

/// Integer offsets of the closing region T_t (pixel-centre rule) at one angle.
std::vector<cv::Point> ClosingRegionOffsets(double angle_rad, const GripperPx& g) {
  const double half_len = g.opening_px / 2;
  const double half_w = g.finger_width_px / 2;
  const int reach = static_cast<int>(std::ceil(std::hypot(half_len, half_w))) + 1;
  const double cs = std::cos(angle_rad);
  const double sn = std::sin(angle_rad);
  std::vector<cv::Point> out;
  for (int dv = -reach; dv <= reach; ++dv) {
    for (int du = -reach; du <= reach; ++du) {
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
};

/// Candidates of one (angle, slice) map with the ranking key; A_st / A_t from the box sums.
void AddCandidates(const std::vector<fge_detail::FastFge::RegionCandidate>& found, int angle_index,
                   int slice_pos, int batch, double centre_weight, double key_step,
                   std::vector<Candidate>& all) {
  for (const auto& rc : found) {
    // Eq. 3.6-3.7 as a mean (A_st / A_t): the thesis' clutter ranking, "same as the mean of
    // stiffness" (eq. 3.14), so region size does not bias it. sums = (A_st, A_t).
    if (!(rc.sums[1] > 0)) continue;  // no contact pixel at image resolution
    const double mean = rc.sums[0] / rc.sums[1];
    // A small epsilon keeps exact multiples of the step (0.1 levels) in their own band.
    const double ranked = key_step > 0 ? std::floor(mean / key_step + 1e-6) * key_step : mean;
    all.push_back({rc.u_px, rc.v_px, ranked + centre_weight * rc.graspability, mean,
                   rc.graspability, angle_index, slice_pos, batch});
  }
}

Grasp MakeGrasp(const Candidate& c, const SliceData& sd, const Scene& scene, const Camera& camera,
                const Gripper& gripper, const FgeParams& params) {
  Grasp grasp;
  grasp.center_u_px = c.u_px;
  grasp.center_v_px = c.v_px;
  grasp.angle_rad = AngleOf(c.angle_index, params.num_angles);
  grasp.opening_px = sd.gripper.opening_px;
  grasp.opening_m = gripper.opening_stroke_m;
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

// Per map (angle, slice): best key first, NMS, contact check, finger clearance, at most top_k
// kept and kMaxContactChecksPerMap checks; then the maps' grasps ranked together with NMS across
// similar angles. Popping all maps' candidates in one key order gives exactly that while checking
// only the candidates that can still make the top_k. Only firm contacts count (ContactHold); grasps
// whose contacts are only stable are kept aside, ranked the same way, and returned when no firm
// one is found.
std::vector<Grasp> SelectGrasps(std::vector<Candidate> all, const std::vector<SliceData>& slices,
                                const Scene& scene, const Camera& camera, const Gripper& gripper,
                                const FgeParams& fp) {
  struct MapState {
    int checks = 0;
    std::vector<Candidate> kept;
  };
  struct Ranked {
    std::vector<Candidate> kept;
    std::vector<Grasp> grasps;
  };
  // Whether a grasp kept in `to` is near c with a similar angle (c is then not a grasp).
  const auto suppressed = [&](const Ranked& to, const Candidate& c) {
    return std::any_of(to.kept.begin(), to.kept.end(), [&](const Candidate& k) {
      return Near(c, k, fp.nms_radius_px) && SimilarAngle(c, k, fp.num_angles);
    });
  };
  // The 3-D finger clearance, tested only for a candidate that would become a grasp: a blocked
  // one neither counts nor suppresses a neighbour.
  std::optional<FingerClearance> clearance;
  if (fp.check_finger_clearance) clearance.emplace(scene, camera);
  const auto clear = [&](const Candidate& c, const SliceData& sd) {
    return !clearance || clearance->Clear(MakeGrasp(c, sd, scene, camera, gripper, fp), gripper);
  };
  const auto add = [&](Ranked& to, const Candidate& c, const SliceData& sd) {
    to.kept.push_back(c);
    to.grasps.push_back(MakeGrasp(c, sd, scene, camera, gripper, fp));
  };
  std::vector<MapState> maps(static_cast<std::size_t>(fp.num_angles) * slices.size());
  const auto worse = [](const Candidate& a, const Candidate& b) { return Better(b, a); };
  std::make_heap(all.begin(), all.end(), worse);
  Ranked firm, stable;
  for (auto end = all.end(); end != all.begin() && static_cast<int>(firm.kept.size()) < fp.top_k;) {
    std::pop_heap(all.begin(), end, worse);
    --end;
    const Candidate& c = *end;
    const auto slice_pos = static_cast<std::size_t>(c.slice_pos);
    MapState& map = maps[static_cast<std::size_t>(c.angle_index) * slices.size() + slice_pos];
    if (static_cast<int>(map.kept.size()) >= fp.top_k || map.checks >= kMaxContactChecksPerMap) {
      continue;
    }
    const bool near_in_map = std::any_of(map.kept.begin(), map.kept.end(), [&](const Candidate& k) {
      return Near(c, k, fp.nms_radius_px);
    });
    if (near_in_map) continue;
    ++map.checks;
    const SliceData& sd = slices[slice_pos];
    const ContactHold hold =
        CheckContacts(scene.height_m, c.u_px, c.v_px, AngleOf(c.angle_index, fp.num_angles),
                      sd.gripper, sd.px_per_m, sd.slice.tip_height_m);
    if (hold == ContactHold::kFirm) {
      const bool near_kept = suppressed(firm, c);
      if (!near_kept && !clear(c, sd)) continue;
      map.kept.push_back(c);
      if (!near_kept) add(firm, c, sd);
    } else if (hold == ContactHold::kStable && static_cast<int>(stable.kept.size()) < fp.top_k &&
               !suppressed(stable, c) && clear(c, sd)) {
      add(stable, c, sd);
    }
  }
  return firm.grasps.empty() ? stable.grasps : firm.grasps;
}

}  // namespace

std::vector<Grasp> DetectGraspsStiffness(const Scene& scene, const Camera& camera,
                                         const cv::Mat1f& stiffness_map, const Gripper& gripper,
                                         const StiffnessFgeParams& params) {
  return DetectGraspsStiffness(scene, camera, stiffness_map, gripper, params,
                               StiffnessSliceSearch(scene, camera, gripper, params));
}

fge_detail::SliceSearch StiffnessSliceSearch(const Scene& scene, const Camera& camera,
                                             const Gripper& gripper,
                                             const StiffnessFgeParams& params) {
  CheckParams(camera, gripper, params);
  if (scene.height_m.empty()) return {};
  return fge_detail::SearchSlices(scene.height_m, scene.contact_allowed,
                                  fge_detail::PxPerMetre(scene.floor, camera, 0), gripper,
                                  params.fge);
}

fge_detail::SliceSearch StiffnessSliceSearch(const Scene& scene, const Camera& camera,
                                             const Gripper& gripper,
                                             const StiffnessFgeParams& params,
                                             fge_detail::FreeSpace& free_space) {
  CheckParams(camera, gripper, params);
  if (scene.height_m.empty()) return {};
  if (free_space.height_m().data != scene.height_m.data) {
    throw std::invalid_argument("StiffnessSliceSearch: the free space is for other heights");
  }
  return fge_detail::SearchSlices(free_space, scene.contact_allowed, gripper, params.fge);
}

std::vector<Grasp> DetectGraspsStiffness(const Scene& scene, const Camera& camera,
                                         const cv::Mat1f& stiffness_map, const Gripper& gripper,
                                         const StiffnessFgeParams& params,
                                         const fge_detail::SliceSearch& search) {
  const FgeParams& fp = params.fge;
  CheckParams(camera, gripper, params);
  if (scene.height_m.empty()) return {};
  if (stiffness_map.size() != scene.height_m.size()) {
    throw std::invalid_argument(
        "DetectGraspsStiffness: the stiffness map must have the scene's "
        "size");
  }
  // NaN / out-of-range map values count as the softest score (never preferred): PoolSums reads
  // the map as fractions in [0, 1], so it is not copied and cleaned here.
  std::vector<SliceData> slices;
  std::vector<Candidate> all;
  std::vector<Grasp> grasps;
  // num_height_steps slices at a time, from the top down, until top_k grasps are found; the
  // grasps of a higher batch rank before those of a lower one.
  auto batches = fge_detail::SliceBatches(search.slices.size(), fp);
  if (params.max_slice_batches > 0 &&
      batches.size() > static_cast<std::size_t>(params.max_slice_batches)) {
    batches.resize(static_cast<std::size_t>(params.max_slice_batches));
  }
  for (std::size_t b = 0; b < batches.size(); ++b) {
    const auto [first, last] = batches[b];
    const std::vector<Slice> batch(search.slices.begin() + static_cast<std::ptrdiff_t>(first),
                                   search.slices.begin() + static_cast<std::ptrdiff_t>(last));
    fge_detail::FastFge fast(scene, camera, gripper, fp, batch, search.graspable);
    // Per slice, S * I_t and I_t block-summed to the fast path's resolution: their box sums over
    // a closing region are A_st and A_t (eq. 3.6-3.8) in image pixels.
    std::vector<cv::Mat2f> pooled;
    for (const Slice& s : batch) {
      SliceData sd;
      sd.slice = s;
      sd.px_per_m = fge_detail::PxPerMetre(scene.floor, camera, s.contact_height_m);
      sd.gripper = fge_detail::GripperAtScale(gripper, sd.px_per_m);
      const cv::Mat1b contact =  // I_t: graspable surface above the contact height
          (scene.height_m > static_cast<float>(s.contact_height_m)) & search.graspable;
      pooled.push_back(fast.PoolSums(stiffness_map, contact));
      slices.push_back(std::move(sd));
    }
    const int grid_step = std::max(1, params.candidate_step_px / fast.scale());
    std::vector<double> angles;
    for (int ai = 0; ai < fp.num_angles; ++ai) angles.push_back(AngleOf(ai, fp.num_angles));
    const auto found = fast.CandidatesAtAngles(angles, pooled, grid_step);
    for (int ai = 0; ai < fp.num_angles; ++ai) {
      for (std::size_t si = 0; si < batch.size(); ++si) {
        AddCandidates(found[static_cast<std::size_t>(ai)][si], ai, static_cast<int>(first + si),
                      static_cast<int>(b), params.centre_weight, params.key_step, all);
      }
    }
    grasps = SelectGrasps(all, slices, scene, camera, gripper, fp);
    if (static_cast<int>(grasps.size()) >= fp.top_k) break;
  }
  return grasps;
}

std::optional<Error> ValidateStiffnessFgeInputs(const Camera& camera, const Gripper& gripper,
                                                const StiffnessFgeParams& params) {
  if (auto error = ValidateFgeInputs(camera, gripper, params.fge)) return error;
  if (!(params.centre_weight >= 0) || params.candidate_step_px < 1 ||
      params.candidate_step_px > 16 || params.max_slice_batches < 0 ||
      !(params.key_step >= 0 && params.key_step <= 1)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "StiffnessFgeParams: centre_weight must be >= 0, candidate_step_px in 1..16, "
                     "max_slice_batches >= 0, key_step in [0, 1]",
                     "stiffness");
  }
  return std::nullopt;
}

double ContactMeanStiffness(const Scene& scene, const cv::Mat1f& stiffness_map,
                            const Grasp& grasp) {
  if (stiffness_map.size() != scene.height_m.size()) {
    throw std::invalid_argument(
        "ContactMeanStiffness: the stiffness map must have the scene's "
        "size");
  }
  const GripperPx g{grasp.opening_px, grasp.finger_width_px, grasp.finger_thickness_px};
  const auto offsets = ClosingRegionOffsets(grasp.angle_rad, g);
  const cv::Mat1b contact = scene.height_m > static_cast<float>(grasp.contact_height_m);
  cv::Mat1f stiffness = stiffness_map.clone();
  cv::patchNaNs(stiffness, 0.0);
  return MeanOverOffsets(stiffness, contact, static_cast<int>(std::lround(grasp.center_u_px)),
                         static_cast<int>(std::lround(grasp.center_v_px)), offsets);
}

}  // namespace softgrasp::core
