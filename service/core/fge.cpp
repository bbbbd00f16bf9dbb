// FGE grasp search: multi-height slices x angles with the fast maps, local maxima, a contact
// check, non-maximum suppression, grasp poses. See docs/fge.md.
#include "service/core/fge.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "service/core/fge_fast.h"
#include "service/core/fge_geometry.h"

namespace softgrasp::core {
namespace {

using fge_detail::GripperPx;
using fge_detail::LocalMaximum;
using fge_detail::Slice;

// Contact check (docs/fge.md, "Contact check"): along every line of the closing region parallel
// to the closing axis, the outermost surface point on each side is where that line meets a
// finger. Lines whose contact lies within kContactFaceToleranceM of the first contact form the
// contact patch; each finger needs a patch of kMinContactPatchM (and kMinContactPatchPx).
constexpr double kContactFaceToleranceM = 0.002;
constexpr double kMinContactPatchM = 0.005;
constexpr int kMinContactPatchPx = 2;
constexpr int kMaxContactChecksPerMap = 64;

struct Candidate {
  double u_px = 0;
  double v_px = 0;
  float score = 0;
  int angle_index = 0;
  int slice_pos = 0;  // position in the slice list; slices are ordered highest first
};

// Best first: higher score, then higher slice, then a fixed order (angle, row, column).
bool Better(const Candidate& a, const Candidate& b) {
  if (a.score != b.score) return a.score > b.score;
  if (a.slice_pos != b.slice_pos) return a.slice_pos < b.slice_pos;
  if (a.angle_index != b.angle_index) return a.angle_index < b.angle_index;
  if (a.v_px != b.v_px) return a.v_px < b.v_px;
  return a.u_px < b.u_px;
}

double AngleOf(int index, int num_angles) { return std::numbers::pi * index / num_angles; }

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

bool Near(const Candidate& a, const Candidate& b, double radius_px) {
  const double du = a.u_px - b.u_px;
  const double dv = a.v_px - b.v_px;
  return du * du + dv * dv < radius_px * radius_px;
}

// Angles within one step (180 / num_angles degrees) are similar; the angle wraps at pi.
bool SimilarAngle(const Candidate& a, const Candidate& b, int num_angles) {
  const int d = std::abs(a.angle_index - b.angle_index) % num_angles;
  return std::min(d, num_angles - d) <= 1;
}

struct ContactGeometry {
  double px_per_m = 0;
  GripperPx gripper;
  double tip_height_m = 0;
};

// Number of lines (rows across the finger) touching the finger at the first contact, one side.
int PatchRows(const std::vector<int>& first_contact, int tolerance_px) {
  int best = std::numeric_limits<int>::min();
  for (int a : first_contact) best = std::max(best, a);
  if (best == std::numeric_limits<int>::min()) return 0;
  return static_cast<int>(std::count_if(first_contact.begin(), first_contact.end(),
                                        [&](int a) { return a >= best - tolerance_px; }));
}

bool StableContacts(const cv::Mat1f& height_m, const Candidate& c, double angle_rad,
                    const ContactGeometry& geo) {
  const int half_len = static_cast<int>(std::floor(geo.gripper.opening_px / 2));
  const int half_width = static_cast<int>(std::floor(geo.gripper.finger_width_px / 2));
  const double cs = std::cos(angle_rad);
  const double sn = std::sin(angle_rad);
  const auto tip = static_cast<float>(geo.tip_height_m);
  const int none = std::numeric_limits<int>::min();
  std::vector<int> right(static_cast<std::size_t>(2 * half_width + 1), none);
  std::vector<int> left(right.size(), none);  // stores -a so both sides use "max"
  for (int b = -half_width; b <= half_width; ++b) {
    auto& r = right[static_cast<std::size_t>(b + half_width)];
    auto& l = left[static_cast<std::size_t>(b + half_width)];
    // Walk the line a = -half_len .. half_len; +0.5 and truncation round (coordinates >= -0.5).
    double u = c.u_px - half_len * cs - b * sn + 0.5;
    double v = c.v_px - half_len * sn + b * cs + 0.5;
    for (int a = -half_len; a <= half_len; ++a, u += cs, v += sn) {
      if (u < 0 || v < 0 || u >= height_m.cols || v >= height_m.rows) continue;
      if (!(height_m(static_cast<int>(v), static_cast<int>(u)) > tip)) continue;
      r = a;  // a increases: the last hit is the outermost on the +a side
      if (l == none) l = -a;
    }
  }
  const int tolerance_px =
      std::max(1, static_cast<int>(std::floor(kContactFaceToleranceM * geo.px_per_m)));
  const int min_rows = std::max(kMinContactPatchPx,
                                static_cast<int>(std::ceil(kMinContactPatchM * geo.px_per_m)));
  return PatchRows(right, tolerance_px) >= min_rows && PatchRows(left, tolerance_px) >= min_rows;
}

// Per map: best first, spatial NMS, contact check; keeps at most top_k.
std::vector<Candidate> SelectInMap(std::vector<Candidate> peaks, const Scene& scene,
                                   const ContactGeometry& geo, double angle_rad,
                                   const FgeParams& params) {
  std::sort(peaks.begin(), peaks.end(), Better);
  std::vector<Candidate> kept;
  int checks = 0;
  for (const Candidate& c : peaks) {
    if (static_cast<int>(kept.size()) >= params.top_k || checks >= kMaxContactChecksPerMap) break;
    const bool suppressed = std::any_of(kept.begin(), kept.end(), [&](const Candidate& k) {
      return Near(c, k, params.nms_radius_px);
    });
    if (suppressed) continue;
    ++checks;
    if (StableContacts(scene.height_m, c, angle_rad, geo)) kept.push_back(c);
  }
  return kept;
}

std::vector<Candidate> RankGlobally(std::vector<Candidate> all, const FgeParams& params) {
  std::sort(all.begin(), all.end(), Better);
  std::vector<Candidate> kept;
  for (const Candidate& c : all) {
    if (static_cast<int>(kept.size()) >= params.top_k) break;
    const bool suppressed = std::any_of(kept.begin(), kept.end(), [&](const Candidate& k) {
      return Near(c, k, params.nms_radius_px) && SimilarAngle(c, k, params.num_angles);
    });
    if (!suppressed) kept.push_back(c);
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
  grasp.opening_m = gripper.opening_stroke_mm * 1e-3;
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
  const auto search = fge_detail::SearchSlices(scene.height_m, gripper, params);
  fge_detail::FastFge fast(scene, camera, gripper, params,
                           {fge_detail::SliceAt(contact_height_m, gripper, params)},
                           search.graspable);
  return fast.Maps(angle_rad, 0);
}

std::vector<Grasp> DetectGraspsFge(const Scene& scene, const Camera& camera,
                                   const Gripper& gripper, const FgeParams& params) {
  fge_detail::CheckInputs(camera, gripper, params);
  if (scene.height_m.empty()) return {};
  const auto search = fge_detail::SearchSlices(scene.height_m, gripper, params);
  const std::vector<Slice>& slices = search.slices;
  if (slices.empty()) return {};
  fge_detail::FastFge fast(scene, camera, gripper, params, slices, search.graspable);

  std::vector<ContactGeometry> geometry;
  for (const Slice& s : slices) {
    const double px_per_m = fge_detail::PxPerMetre(scene.floor, camera, s.contact_height_m);
    geometry.push_back({px_per_m, fge_detail::GripperAtScale(gripper, px_per_m), s.tip_height_m});
  }
  std::vector<Candidate> all;
  for (int ai : AngleOrder(params.num_angles)) {
    const double angle = AngleOf(ai, params.num_angles);
    const auto maxima = fast.LocalMaxima(angle);
    for (std::size_t si = 0; si < slices.size(); ++si) {
      std::vector<Candidate> peaks;
      for (const LocalMaximum& m : maxima[si]) {
        peaks.push_back({m.u_px, m.v_px, m.score, ai, static_cast<int>(si)});
      }
      for (const Candidate& c : SelectInMap(std::move(peaks), scene, geometry[si], angle, params)) {
        all.push_back(c);
      }
    }
  }
  std::vector<Grasp> grasps;
  for (const Candidate& c : RankGlobally(std::move(all), params)) {
    grasps.push_back(MakeGrasp(c, slices[static_cast<std::size_t>(c.slice_pos)], scene, camera,
                               gripper, params));
  }
  return grasps;
}

}  // namespace softgrasp::core
