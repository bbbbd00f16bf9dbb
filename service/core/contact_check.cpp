#include "service/core/contact_check.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace softgrasp::core {
namespace {

// See CheckContacts.
constexpr double kContactFaceToleranceM = 0.002;
constexpr double kMinContactPatchM = 0.005;
// A firm contact: the finger rests on at least half its width (CheckContacts).
constexpr double kFirmContactPatchFraction = 0.5;
constexpr int kMinContactPatchPx = 2;

// Number of lines (rows across the finger) touching the finger at the first contact, one side.
int PatchRows(const std::vector<int>& first_contact, int tolerance_px) {
  int best = std::numeric_limits<int>::min();
  for (int a : first_contact) best = std::max(best, a);
  if (best == std::numeric_limits<int>::min()) return 0;
  return static_cast<int>(std::count_if(first_contact.begin(), first_contact.end(),
                                        [&](int a) { return a >= best - tolerance_px; }));
}

// The smaller of the two fingers' contact patches, in lines (CheckContacts); once the first
// finger's patch has fewer than `enough` lines, that patch (the other finger is not looked at).
int ContactPatchLines(const cv::Mat1f& height_m, double u_px, double v_px, double angle_rad,
                      const GripperPx& gripper, double px_per_m, double tip_height_m, int enough) {
  const int half_len = static_cast<int>(std::floor(gripper.opening_px / 2));
  const int half_width = static_cast<int>(std::floor(gripper.finger_width_px / 2));
  const double cs = std::cos(angle_rad);
  const double sn = std::sin(angle_rad);
  const auto tip = static_cast<float>(tip_height_m);
  const int none = std::numeric_limits<int>::min();
  std::vector<int> right(static_cast<std::size_t>(2 * half_width + 1), none);
  std::vector<int> left(right.size(), none);  // stores -a so both sides use "max"
  const float* const heights = height_m.ptr<float>(0);
  const std::size_t row_step = height_m.step1();
  const auto cols = static_cast<std::uint64_t>(height_m.cols);
  const auto rows = static_cast<std::uint64_t>(height_m.rows);
  // The walk runs in fixed point (32 fractional bits): an arithmetic shift is the floor, and
  // negative coordinates become huge when unsigned, so one compare per axis tells outside.
  constexpr double kOne = 4294967296.0;
  const auto fixed = [](double x) { return static_cast<std::int64_t>(std::llround(x * kOne)); };
  const std::int64_t step_u = fixed(cs), step_v = fixed(sn);
  // Whether the surface at (u, v) + 0.5 (the floor of the shifted coordinates rounds) is above
  // the tips; outside the image it is not.
  const auto above_tips = [&](std::int64_t u, std::int64_t v) {
    const auto x = static_cast<std::uint64_t>(u >> 32), y = static_cast<std::uint64_t>(v >> 32);
    return x < cols && y < rows && heights[y * row_step + x] > tip;
  };
  // Line b starts (a = -half_len) here.
  const auto start = [&](int b) {
    return std::pair{u_px - half_len * cs - b * sn + 0.5, v_px - half_len * sn + b * cs + 0.5};
  };
  // Each finger meets the line's outermost surface pixel on its side: walk in from each end and
  // stop at the first hit (the gap between finger and object, not the whole line).
  for (int b = -half_width; b <= half_width; ++b) {
    const auto [u_left, v_left] = start(b);
    int a_right = half_len;
    std::int64_t u = fixed(u_left + 2 * half_len * cs), v = fixed(v_left + 2 * half_len * sn);
    for (; a_right >= -half_len && !above_tips(u, v); --a_right, u -= step_u, v -= step_v) {
    }
    if (a_right >= -half_len) right[static_cast<std::size_t>(b + half_width)] = a_right;
  }
  const int tolerance_px =
      std::max(1, static_cast<int>(std::floor(kContactFaceToleranceM * px_per_m)));
  const int right_lines = PatchRows(right, tolerance_px);
  if (right_lines < enough) return right_lines;
  for (int b = -half_width; b <= half_width; ++b) {
    const int a_right = right[static_cast<std::size_t>(b + half_width)];
    if (a_right == none) continue;  // nothing on this line
    const auto [u_left, v_left] = start(b);
    int a_left = -half_len;
    std::int64_t u = fixed(u_left), v = fixed(v_left);
    for (; !above_tips(u, v) && a_left < a_right; ++a_left, u += step_u, v += step_v) {
    }
    left[static_cast<std::size_t>(b + half_width)] = -a_left;  // -a so both sides use "max"
  }
  return std::min(right_lines, PatchRows(left, tolerance_px));
}

}  // namespace

ContactHold CheckContacts(const cv::Mat1f& height_m, double u_px, double v_px, double angle_rad,
                          const GripperPx& gripper, double px_per_m, double tip_height_m) {
  const int stable_lines =
      std::max(kMinContactPatchPx, static_cast<int>(std::ceil(kMinContactPatchM * px_per_m)));
  const int lines = ContactPatchLines(height_m, u_px, v_px, angle_rad, gripper, px_per_m,
                                      tip_height_m, stable_lines);
  const int firm_lines =
      std::max(stable_lines,
               static_cast<int>(std::ceil(kFirmContactPatchFraction * gripper.finger_width_px)));
  if (lines >= firm_lines) return ContactHold::kFirm;
  return lines >= stable_lines ? ContactHold::kStable : ContactHold::kNone;
}

bool ContactFacesSteep(const cv::Mat1f& height_m, double u_px, double v_px, double angle_rad,
                       const GripperPx& gripper, double px_per_m, double tip_height_m,
                       double friction_coefficient) {
  const int half_len = static_cast<int>(std::floor(gripper.opening_px / 2));
  const int half_width = static_cast<int>(std::floor(gripper.finger_width_px / 2));
  const double cs = std::cos(angle_rad);
  const double sn = std::sin(angle_rad);
  const int run_px = std::max(1, static_cast<int>(std::lround(kSteepRunM * px_per_m)));
  const double rise_per_px_m = 1.0 / px_per_m / friction_coefficient;
  // The surface at offset a along the closing axis (towards `side`) and b across it; outside
  // the image there is none.
  const auto height = [&](int side, int a, int b) {
    const auto u = static_cast<int>(std::floor(u_px + side * a * cs - b * sn + 0.5));
    const auto v = static_cast<int>(std::floor(v_px + side * a * sn + b * cs + 0.5));
    if (u < 0 || v < 0 || u >= height_m.cols || v >= height_m.rows) {
      return -std::numeric_limits<double>::infinity();
    }
    return static_cast<double>(height_m(v, u));
  };
  struct Line {
    int contact = 0;  // a of the finger's contact on this line (outwards positive)
    bool steep = false;
  };
  std::vector<Line> lines;
  for (const int side : {1, -1}) {
    lines.clear();
    for (int b = -half_width; b <= half_width; ++b) {
      for (int a = half_len; a >= -half_len; --a) {
        if (!(height(side, a, b) > tip_height_m)) continue;
        // The face crosses the tips' height between a + 1 and a: k pixels inward of a, it is at
        // most k + 1 pixels away.
        bool steep = false;
        for (int k = 0; k <= run_px && !steep; ++k) {
          steep = height(side, a - k, b) - tip_height_m >= (k + 1) * rise_per_px_m;
        }
        lines.push_back({a, steep});
        break;
      }
    }
    if (lines.empty()) return false;
    int first = std::numeric_limits<int>::min();
    for (const Line& l : lines) first = std::max(first, l.contact);
    int touching = 0;
    int steep = 0;
    for (const Line& l : lines) {
      if (l.contact < first - 1) continue;
      ++touching;
      steep += l.steep ? 1 : 0;
    }
    if (2 * steep < touching) return false;
  }
  return true;
}

}  // namespace softgrasp::core
