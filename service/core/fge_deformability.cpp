#include "service/core/fge_deformability.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "service/core/fge_geometry.h"
#include "service/core/fge_stiffness.h"

namespace softgrasp::core {
namespace {

// The top of an instance: this quantile of its heights (a few flying pixels do not set it).
constexpr double kTopQuantile = 0.98;
// SoftNeighbourInReach: added to the gripper's reach for the fast path's pooled work pixels
// (up to 4 image pixels) and the 3-D finger check's margin.
constexpr double kReachMarginM = 0.01;

}  // namespace

std::optional<Error> ValidateDeformabilityParams(const DeformabilityParams& p,
                                                 const Gripper& gripper) {
  const bool fractions_in_range =
      std::all_of(p.opening_fractions.begin(), p.opening_fractions.end(),
                  [](double f) { return f > 0 && f <= 1; });
  struct Check {
    bool ok;
    const char* field;
    const char* what;
  };
  const Check checks[] = {
      {p.min_target_area_px >= 0 && std::isfinite(p.min_target_area_px), "min_target_area_px",
       "min_target_area_px (K) must be >= 0"},
      {p.slice_step_m > 0 && p.slice_step_m <= gripper.finger_length_m, "slice_step_m",
       "slice_step_m (L) must be > 0 and not exceed the finger length"},
      {p.num_slices >= 1 && p.num_slices <= 40, "num_slices", "num_slices (M) must be in 1..40"},
      {p.min_score >= 0 && p.min_score <= 1, "min_score", "min_score (R) must be in [0, 1]"},
      {p.target_id >= 0, "target_id", "target_id must be >= 0"},
      {!p.opening_fractions.empty(), "opening_fractions", "opening_fractions must not be empty"},
      {fractions_in_range, "opening_fractions", "opening_fractions must be in (0, 1]"},
      {p.min_graspability >= 0 && p.min_graspability <= 1, "min_graspability",
       "min_graspability must be in [0, 1]"},
      {std::is_sorted(p.opening_fractions.begin(), p.opening_fractions.end()), "opening_fractions",
       "opening_fractions must be in increasing order"},
      {p.stiff_part_fraction >= 0 && p.stiff_part_fraction <= 1, "stiff_part_fraction",
       "stiff_part_fraction must be in [0, 1]"},
      {p.min_part_contrast >= 0 && p.min_part_contrast <= 1, "min_part_contrast",
       "min_part_contrast must be in [0, 1]"},
      {p.soft_obstacle_threshold >= 0 && std::isfinite(p.soft_obstacle_threshold),
       "soft_obstacle_threshold", "soft_obstacle_threshold must be >= 0"},
      {p.max_press_depth_m >= 0 && p.max_press_depth_m <= 1, "max_press_depth_m",
       "max_press_depth_m must be in [0, 1]"},
      {p.tie_tolerance >= 0 && std::isfinite(p.tie_tolerance), "tie_tolerance",
       "tie_tolerance must be >= 0"},
      {p.max_targets >= 1, "max_targets", "max_targets must be >= 1"},
      {p.centre_weight >= 0 && std::isfinite(p.centre_weight), "centre_weight",
       "centre_weight must be >= 0"},
      {p.deformability_step >= 0 && p.deformability_step <= 1, "deformability_step",
       "deformability_step must be in [0, 1]"},
  };
  for (const Check& c : checks) {
    if (!c.ok) {
      return MakeError(ErrorCode::kInvalidArgument, std::string("DeformabilityParams: ") + c.what,
                       c.field);
    }
  }
  return std::nullopt;
}

namespace {

void CheckParams(const DeformabilityParams& p, const Gripper& gripper) {
  if (auto error = ValidateDeformabilityParams(p, gripper)) {
    throw std::invalid_argument(error->message);
  }
}

void CheckMaps(const Scene& scene, const ObjectMaps& objects) {
  const cv::Size size = scene.height_m.size();
  if (objects.labels.size() != size || objects.deformability.size() != size ||
      (!objects.foreground.empty() && objects.foreground.size() != size)) {
    throw std::invalid_argument(
        "DetectGraspsDeformability: labels, deformability and foreground must have the scene's "
        "size");
  }
  double max_id = 0;
  if (!objects.labels.empty()) cv::minMaxLoc(objects.labels, nullptr, &max_id);
  if (static_cast<std::size_t>(max_id) > objects.scores.size()) {
    throw std::invalid_argument("DetectGraspsDeformability: label " +
                                std::to_string(static_cast<int>(max_id)) + " has no score");
  }
}

/// 1 - deformability clamped to [0, 1]; NaN counts as the softest.
cv::Mat1f StiffnessOf(const cv::Mat1f& deformability) {
  cv::Mat1f stiffness = 1.0f - deformability;
  cv::patchNaNs(stiffness, 0.0);
  cv::min(cv::max(stiffness, 0.0f), 1.0f, stiffness);
  return stiffness;
}

/// The target's stiff part: pixels in the mask and in scene.contact_allowed at least
/// stiff_part_fraction of the target's maximum stiffness there, unless the two parts differ by
/// less than min_part_contrast in mean stiffness (then the whole mask: one material seen through
/// a noisy map, as rigid targets packed among sponges look; infinity: always the whole mask).
/// `target_in_box`: the mask inside `box` (image pixels); the part is returned inside `box`.
cv::Mat1b StiffPartInBox(const Scene& scene, const cv::Mat1b& target_in_box, const cv::Rect& box,
                         const cv::Mat1f& stiffness, const DeformabilityParams& params,
                         double min_part_contrast) {
  cv::Mat1b allowed = target_in_box.clone();
  if (!scene.contact_allowed.empty()) allowed &= scene.contact_allowed(box);
  const cv::Mat1f in_box = stiffness(box);
  double max_stiffness = 0;
  cv::minMaxLoc(in_box, nullptr, &max_stiffness, nullptr, nullptr, allowed);
  const cv::Mat1b soft =
      allowed & (in_box < static_cast<float>(params.stiff_part_fraction * max_stiffness));
  const cv::Mat1b stiff = allowed & ~soft;
  if (cv::countNonZero(soft) == 0 || cv::countNonZero(stiff) == 0 ||
      cv::mean(in_box, stiff)[0] - cv::mean(in_box, soft)[0] < min_part_contrast) {
    return allowed;
  }
  return stiff;
}

/// StiffPartInBox on the whole image (0 outside the target's bounding box).
cv::Mat1b StiffPart(const Scene& scene, const cv::Mat1b& target, const cv::Mat1f& stiffness,
                    const DeformabilityParams& params, double min_part_contrast) {
  const cv::Rect box = cv::boundingRect(target);
  cv::Mat1b part(target.size(), static_cast<unsigned char>(0));
  if (!box.empty()) {
    StiffPartInBox(scene, target(box), box, stiffness, params, min_part_contrast).copyTo(part(box));
  }
  return part;
}

struct TargetStats {
  int id = 0;
  double top_m = 0;
  double mean_deformability = 0;
};

double Quantile(std::vector<float> values, double q) {
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

/// The unlabelled foreground (foreground >= 0.5 where no instance is) in 8-connected pieces,
/// found once per request: a target grows into the pieces that touch it (GrownTarget).
class ForegroundPieces {
 public:
  explicit ForegroundPieces(const ObjectMaps& objects) {
    if (objects.foreground.empty()) return;
    const cv::Mat1b unlabelled = (objects.labels == 0) & (objects.foreground >= 0.5f);
    cv::Mat centroids;
    count_ = cv::connectedComponentsWithStats(unlabelled, pieces_, stats_, centroids, 8, CV_32S);
  }

  /// The target's mask grown into the unlabelled foreground connected to it: the pieces with a
  /// pixel 8-adjacent to the target (the same as the target's connected components in the
  /// target together with the unlabelled foreground).
  cv::Mat1b GrownTarget(const cv::Mat1w& labels, int target_id) const {
    cv::Mat1b grown = labels == target_id;
    if (count_ <= 1) return grown;
    const cv::Rect image(cv::Point(0, 0), labels.size());
    const cv::Rect box = cv::boundingRect(grown);
    const cv::Rect around = cv::Rect(box.x - 1, box.y - 1, box.width + 2, box.height + 2) & image;
    std::vector<bool> touching(static_cast<std::size_t>(count_), false);
    for (int v = around.y; v < around.y + around.height; ++v) {
      for (int u = around.x; u < around.x + around.width; ++u) {
        const int piece = pieces_(v, u);
        if (piece == 0 || touching[static_cast<std::size_t>(piece)]) continue;
        const cv::Rect near = cv::Rect(u - 1, v - 1, 3, 3) & image;
        if (cv::countNonZero(grown(near)) > 0) touching[static_cast<std::size_t>(piece)] = true;
      }
    }
    for (int piece = 1; piece < count_; ++piece) {
      if (!touching[static_cast<std::size_t>(piece)]) continue;
      const cv::Rect b(stats_(piece, cv::CC_STAT_LEFT), stats_(piece, cv::CC_STAT_TOP),
                       stats_(piece, cv::CC_STAT_WIDTH), stats_(piece, cv::CC_STAT_HEIGHT));
      grown(b).setTo(255, pieces_(b) == piece);
    }
    return grown;
  }

 private:
  int count_ = 0;  ///< pieces + 1 (label 0 is the rest)
  cv::Mat1i pieces_;
  cv::Mat1i stats_;
};

/// The part of `target` joined to `seed` by 8-connected neighbours whose heights differ by at
/// most `step_m` (DeformabilityParams::target_px); the whole target when the seed is not on it.
cv::Mat1b ClickedPart(const Scene& scene, const cv::Mat1b& target, cv::Point seed, double step_m) {
  if (!cv::Rect(cv::Point(0, 0), target.size()).contains(seed) || target(seed) == 0) {
    return target;
  }
  constexpr unsigned char kBlocked = 1, kFilled = 2;
  cv::Mat1b mask(target.rows + 2, target.cols + 2, kBlocked);
  mask(cv::Rect(1, 1, target.cols, target.rows)).setTo(0, target);
  cv::Mat heights = scene.height_m;  // only read: FLOODFILL_MASK_ONLY
  cv::floodFill(heights, mask, seed, cv::Scalar(), nullptr, cv::Scalar(step_m), cv::Scalar(step_m),
                8 | cv::FLOODFILL_MASK_ONLY | (kFilled << 8));
  return mask(cv::Rect(1, 1, target.cols, target.rows)) == kFilled;
}

/// Heights with soft pixels lowered by the press depth (a finger may push that far into them).
cv::Mat1f Pressed(const cv::Mat1f& height_m, const cv::Mat1b& soft, double press_depth_m) {
  cv::Mat1f out = height_m.clone();
  const cv::Mat1f lowered = cv::max(height_m - static_cast<float>(press_depth_m), 0.0f);
  lowered.copyTo(out, soft);
  return out;
}

/// What the slice search finds before it looks at a target (fge_detail::FreeSpace), made at
/// most once per request for the heights as seen and once for the heights with every soft
/// instance pressed: the latter is what every target that is not soft itself sees when it
/// presses its soft neighbours. Both are made when first asked for.
class SharedSearch {
 public:
  SharedSearch(const Scene& scene, const ObjectMaps& objects, const Camera& camera,
               const DeformabilityParams& params, const FgeParams& fge)
      : scene_(scene), camera_(camera), params_(params), fge_(fge) {
    soft_ = (objects.labels != 0) &
            (objects.deformability > static_cast<float>(params.soft_obstacle_threshold));
  }

  /// Every soft instance's pixels.
  const cv::Mat1b& soft() const { return soft_; }

  fge_detail::FreeSpace& AsSeen() {
    if (!as_seen_) as_seen_.emplace(scene_.height_m, PxPerMetre(), fge_);
    return *as_seen_;
  }

  /// The heights with every soft instance pressed, and their free space.
  std::pair<cv::Mat1f, fge_detail::FreeSpace*> AllPressed() {
    if (!all_pressed_) {
      pressed_heights_ = Pressed(scene_.height_m, soft_, params_.max_press_depth_m);
      all_pressed_.emplace(pressed_heights_, PxPerMetre(), fge_);
    }
    return {pressed_heights_, &*all_pressed_};
  }

 private:
  double PxPerMetre() const { return fge_detail::PxPerMetre(scene_.floor, camera_, 0); }

  const Scene& scene_;
  const Camera& camera_;
  const DeformabilityParams& params_;
  const FgeParams fge_;
  cv::Mat1b soft_;
  std::optional<fge_detail::FreeSpace> as_seen_;
  cv::Mat1f pressed_heights_;
  std::optional<fge_detail::FreeSpace> all_pressed_;
};

/// The scene the planner sees for one target: contact only on the (grown) target's stiff part
/// (thesis §5.3.3: the soft part is never contact and stays an obstacle; `contact` as
/// StiffPart made it). `soft`: the pixels of soft neighbours; with `press` they are lowered by
/// the press depth (a finger may push that far into them).
struct TargetView {
  Scene scene;
  cv::Mat1b soft;
  bool pressable = false;  ///< there are soft neighbours and a press depth
  /// For scene.height_m, shared with other targets; null: the target's own (a soft target).
  fge_detail::FreeSpace* free_space = nullptr;
};

TargetView ViewForTarget(const Scene& scene, const Camera& camera, const Gripper& gripper,
                         const ObjectMaps& objects, int target_id, const cv::Mat1b& contact,
                         const DeformabilityParams& params, bool press, SharedSearch& shared) {
  TargetView out{scene, {}, false, nullptr};
  out.scene.contact_allowed = contact;
  const cv::Mat1b own = objects.labels == target_id;
  const bool soft_target = cv::countNonZero(shared.soft() & own) > 0;
  out.soft = soft_target ? shared.soft() & ~own : shared.soft();
  out.pressable = params.max_press_depth_m > 0 &&
                  SoftNeighbourInReach(scene, camera, gripper, contact, out.soft);
  if (!press) {
    out.free_space = &shared.AsSeen();
  } else if (out.pressable && soft_target) {
    out.scene.height_m = Pressed(scene.height_m, out.soft, params.max_press_depth_m);
  } else if (out.pressable) {
    std::tie(out.scene.height_m, out.free_space) = shared.AllPressed();
  }
  return out;
}

/// Calls fn(u, v) for the image pixels (pixel-centre rule) around grasp g whose offset along the
/// closing axis has a_min < |a| <= a_max and across it |b| <= the finger's half width (for the
/// finger footprints: a_min = opening / 2, a_max = opening / 2 + finger thickness).
template <class Fn>
void ForEachGraspPixel(const Grasp& g, cv::Size image, double a_min, double a_max, Fn&& fn) {
  const double half_b = g.finger_width_px / 2;
  const int reach = static_cast<int>(std::ceil(std::hypot(a_max, half_b))) + 1;
  const double cs = std::cos(g.angle_rad);
  const double sn = std::sin(g.angle_rad);
  const int u0 = static_cast<int>(std::lround(g.center_u_px));
  const int v0 = static_cast<int>(std::lround(g.center_v_px));
  for (int dv = -reach; dv <= reach; ++dv) {
    for (int du = -reach; du <= reach; ++du) {
      const double a = std::abs(du * cs + dv * sn);
      if (a <= a_min || a > a_max || std::abs(-du * sn + dv * cs) > half_b) continue;
      const int u = u0 + du;
      const int v = v0 + dv;
      if (u >= 0 && v >= 0 && u < image.width && v < image.height) fn(u, v);
    }
  }
}

/// Soft neighbours under the finger footprints above the fingertips.
void FillPressed(const Scene& scene, const cv::Mat1w& labels, int target_id,
                 DeformabilityGrasp* out) {
  const Grasp& g = out->grasp;
  std::set<int> ids;
  double depth = 0;
  ForEachGraspPixel(g, labels.size(), g.opening_px / 2, g.opening_px / 2 + g.finger_thickness_px,
                    [&](int u, int v) {
                      const int id = labels(v, u);
                      const double above = scene.height_m(v, u) - g.grasp_height_m;
                      if (id == 0 || id == target_id || !(above > 0)) return;
                      ids.insert(id);
                      depth = std::max(depth, above);
                    });
  out->pressed_ids.assign(ids.begin(), ids.end());
  out->press_depth_m = depth;
}

/// A soft neighbour reaching into the closing region above the fingertips: the fingers would
/// land on it and squeeze it with the target (pressing only works under the finger footprints,
/// so the closing region must be judged on the heights as seen).
bool SoftNeighbourBetweenFingers(const Scene& scene, const cv::Mat1b& soft, const Grasp& g) {
  bool found = false;
  ForEachGraspPixel(g, soft.size(), -1.0, g.opening_px / 2, [&](int u, int v) {
    if (soft(v, u) != 0 && scene.height_m(v, u) > g.grasp_height_m) found = true;
  });
  return found;
}

}  // namespace

const char* TargetPolicyName(TargetPolicy policy) {
  return policy == TargetPolicy::kHighest ? "highest" : "least_deformable";
}

namespace {

/// The candidate targets with their statistics, in policy order (OrderTargets). `stiffness`:
/// StiffnessOf(objects.deformability).
std::vector<TargetStats> RankTargets(const Scene& scene, const ObjectMaps& objects,
                                     const cv::Mat1f& stiffness,
                                     const DeformabilityParams& params) {
  if (params.target_id > 0) return {TargetStats{params.target_id, 0, 0}};
  std::map<int, std::vector<float>> heights;
  std::map<int, cv::Rect> boxes;  // of each instance's pixels
  for (int v = 0; v < objects.labels.rows; ++v) {
    for (int u = 0; u < objects.labels.cols; ++u) {
      const int id = objects.labels(v, u);
      if (id == 0) continue;
      const cv::Rect pixel(u, v, 1, 1);
      auto [box, first] = boxes.try_emplace(id, pixel);
      if (!first) box->second |= pixel;
      if (objects.scores[static_cast<std::size_t>(id - 1)] < params.min_score) continue;
      if (!scene.contact_allowed.empty() && scene.contact_allowed(v, u) == 0) continue;
      heights[id].push_back(scene.height_m(v, u));
    }
  }
  std::vector<TargetStats> stats;
  for (const auto& [id, h] : heights) {
    if (static_cast<double>(h.size()) < std::max(1.0, params.min_target_area_px)) continue;
    TargetStats s;
    s.id = id;
    s.top_m = Quantile(h, kTopQuantile);
    const cv::Rect& box = boxes.at(id);
    const cv::Mat1b part =
        StiffPartInBox(scene, objects.labels(box) == id, box, stiffness, params, 0.0);
    s.mean_deformability = 1.0 - cv::mean(stiffness(box), part)[0];
    stats.push_back(s);
  }
  const auto higher = [](const TargetStats& a, const TargetStats& b) {
    return a.top_m != b.top_m ? a.top_m > b.top_m : a.id < b.id;
  };
  if (params.policy == TargetPolicy::kHighest || stats.empty()) {
    std::sort(stats.begin(), stats.end(), higher);
  } else {
    // Bands of tie_tolerance from the least deformable; the highest first within a band.
    double least = 1;
    for (const auto& s : stats) least = std::min(least, s.mean_deformability);
    const auto band = [&](const TargetStats& s) {
      return params.tie_tolerance > 0 ? static_cast<int>(std::floor((s.mean_deformability - least) /
                                                                    params.tie_tolerance))
                                      : (s.mean_deformability > least ? 1 : 0);
    };
    std::sort(stats.begin(), stats.end(), [&](const TargetStats& a, const TargetStats& b) {
      const int ba = band(a), bb = band(b);
      if (ba != bb) return ba < bb;
      if (params.tie_tolerance == 0 && a.mean_deformability != b.mean_deformability) {
        return a.mean_deformability < b.mean_deformability;
      }
      return higher(a, b);
    });
  }
  return stats;
}

}  // namespace

std::vector<int> OrderTargets(const Scene& scene, const ObjectMaps& objects,
                              const DeformabilityParams& params) {
  CheckMaps(scene, objects);
  std::vector<int> ids;
  for (const auto& s : RankTargets(scene, objects, StiffnessOf(objects.deformability), params)) {
    ids.push_back(s.id);
  }
  return ids;
}

namespace {

/// Algorithm 1 on one target's view (`scene` as seen) with each opening in turn, the smallest
/// that gives a grasp kept; with `pressed`, grasps with a soft neighbour between the fingers are
/// dropped. Returns 0 when no opening gave a grasp, 1 when the grasps replaced `result`'s (the
/// first found, or less deformable than *best_deformability by more than the tie tolerance), -1
/// when a grasp was found but not kept.
int PlanOpenings(const Scene& scene, const TargetView& view, bool pressed, const Camera& camera,
                 const cv::Mat1f& stiffness, const Gripper& gripper, const StiffnessFgeParams& sp,
                 const DeformabilityParams& params, int id, const cv::Mat1w& labels,
                 double* best_deformability, DeformabilityResult* result) {
  const fge_detail::SliceSearch search =
      view.free_space ? StiffnessSliceSearch(view.scene, camera, gripper, sp, *view.free_space)
                      : StiffnessSliceSearch(view.scene, camera, gripper, sp);
  for (std::size_t k = 0; k < params.opening_fractions.size(); ++k) {
    const double fraction = params.opening_fractions[k];
    Gripper opened = gripper;
    opened.opening_stroke_m = gripper.opening_stroke_m * fraction;
    auto grasps = DetectGraspsStiffness(view.scene, camera, stiffness, opened, sp, search);
    if (k + 1 < params.opening_fractions.size()) {
      std::erase_if(grasps, [&](const Grasp& g) { return g.score < params.min_graspability; });
    }
    if (pressed) {
      std::erase_if(
          grasps, [&](const Grasp& g) { return SoftNeighbourBetweenFingers(scene, view.soft, g); });
    }
    if (grasps.empty()) continue;
    const double found = 1.0 - grasps.front().mean_stiffness;
    if (result->target_id > 0 && !(found < *best_deformability - params.tie_tolerance)) {
      return -1;
    }
    *best_deformability = found;
    result->target_id = id;
    result->grasps.clear();
    for (const Grasp& g : grasps) {
      DeformabilityGrasp dg;
      dg.grasp = g;
      dg.instance_id = id;
      dg.mean_deformability = 1.0 - g.mean_stiffness;
      dg.opening_fraction = fraction;
      FillPressed(scene, labels, id, &dg);
      result->grasps.push_back(std::move(dg));
    }
    return 1;
  }
  return 0;
}

}  // namespace

bool SoftNeighbourInReach(const Scene& scene, const Camera& camera, const Gripper& gripper,
                          const cv::Mat1b& contact, const cv::Mat1b& soft) {
  if (cv::countNonZero(soft) == 0) return false;
  const cv::Mat1f& depth = scene.depth_filled_m;
  const cv::Rect box = cv::boundingRect(contact);
  if (box.empty()) return false;
  if (depth.size() != soft.size() || contact.size() != soft.size()) return true;
  // The contact pixels' camera x-y (metres at their own depth).
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo;
  double y_lo = x_lo, y_hi = -x_lo;
  for (int v = box.y; v < box.y + box.height; ++v) {
    const unsigned char* c_row = contact.ptr<unsigned char>(v);
    const float* z_row = depth.ptr<float>(v);
    for (int u = box.x; u < box.x + box.width; ++u) {
      const double z = z_row[u];
      if (c_row[u] == 0 || !(z > 0) || !std::isfinite(z)) continue;
      const double x = (u - camera.cx) * z / camera.fx, y = (v - camera.cy) * z / camera.fy;
      x_lo = std::min(x_lo, x), x_hi = std::max(x_hi, x);
      y_lo = std::min(y_lo, y), y_hi = std::max(y_hi, y);
    }
  }
  double z_near = 0, z_far = 0;
  cv::minMaxIdx(depth, &z_near, &z_far);
  if (!(x_lo <= x_hi) || !(z_near > 0) || !std::isfinite(z_far)) return true;
  // Everything a grasp on a contact pixel can touch (closing region, fingers, palm, the fast
  // path's pooled work pixels) lies within this distance of it in x-y.
  const double reach_m =
      std::hypot(gripper.opening_stroke_m + gripper.finger_thickness_m, gripper.finger_width_m) +
      kReachMarginM;
  // u = cx + fx x / z is monotone in x and in 1 / z: the box's corners at the nearest and the
  // farthest depth bound where any point of it is seen.
  double u_lo = std::numeric_limits<double>::infinity(), u_hi = -u_lo, v_lo = u_lo, v_hi = -u_lo;
  for (const double z : {z_near, z_far}) {
    for (const double x : {x_lo - reach_m, x_hi + reach_m}) {
      const double u = camera.cx + camera.fx * x / z;
      u_lo = std::min(u_lo, u), u_hi = std::max(u_hi, u);
    }
    for (const double y : {y_lo - reach_m, y_hi + reach_m}) {
      const double v = camera.cy + camera.fy * y / z;
      v_lo = std::min(v_lo, v), v_hi = std::max(v_hi, v);
    }
  }
  const auto clamp_to = [](double x, int size) {
    return static_cast<int>(std::clamp(x, 0.0, static_cast<double>(size)));
  };
  const int u0 = clamp_to(std::floor(u_lo) - 1, soft.cols),
            u1 = clamp_to(std::ceil(u_hi) + 2, soft.cols);
  const int v0 = clamp_to(std::floor(v_lo) - 1, soft.rows),
            v1 = clamp_to(std::ceil(v_hi) + 2, soft.rows);
  if (u0 >= u1 || v0 >= v1) return false;
  return cv::countNonZero(soft(cv::Rect(u0, v0, u1 - u0, v1 - v0))) > 0;
}

DeformabilityResult DetectGraspsDeformability(const Scene& scene, const Camera& camera,
                                              const ObjectMaps& objects, const Gripper& gripper,
                                              const DeformabilityParams& params) {
  CheckParams(params, gripper);
  DeformabilityResult result;
  if (scene.height_m.empty()) return result;
  CheckMaps(scene, objects);
  const cv::Mat1f stiffness = StiffnessOf(objects.deformability);
  const std::vector<TargetStats> order = RankTargets(scene, objects, stiffness, params);

  StiffnessFgeParams sp;
  sp.fge = params.fge;
  sp.fge.height_step_m = params.slice_step_m;
  sp.fge.grip_depth_m = params.slice_step_m;
  sp.fge.num_height_steps = params.num_slices;
  sp.fge.min_object_area_px = params.min_target_area_px;
  sp.centre_weight = params.centre_weight;
  sp.key_step = params.deformability_step;
  sp.max_slice_batches = 1;

  // least_deformable looks past the first reachable target while a later one, whose touchable
  // part is less deformable by more than the tie tolerance, could give a gentler grasp.
  const bool compare = params.policy == TargetPolicy::kLeastDeformable && params.target_id == 0;
  double best_deformability = std::numeric_limits<double>::infinity();
  // Pass 1 keeps every soft part out of the contact (thesis §5.3.3). Only when no target gives a
  // grasp that way, pass 2 lets a target's soft-looking pixels be contact where they differ from
  // the rest by less than min_part_contrast (a learned map shows rigid objects packed among
  // sponges half soft); real parts stay out. A target the request named gets a last pass on
  // the whole of it (the gentlest closing region still ranks first): the user asked for that
  // object, and the rule would otherwise leave a bottle whose cap is out of reach, or a carton
  // whose soft-looking lid the rule cuts away, with no grasp at all.
  // The heights as seen are the same for every target, and so are the pressed heights of every
  // target that is not soft itself: what the slice search finds on them before it looks at a
  // target is found once.
  SharedSearch shared(scene, objects, camera, params, sp.fge);
  const ForegroundPieces pieces(objects);
  const bool named = params.target_id > 0;
  const double passes[] = {0.0, params.min_part_contrast,
                           named ? std::numeric_limits<double>::infinity() : 0.0};
  for (std::size_t pass = 0; pass < std::size(passes); ++pass) {
    const double contrast = passes[pass];
    if (result.target_id > 0 || (pass > 0 && (contrast == 0 || params.min_part_contrast == 0))) {
      break;
    }
    int planned = 0;
    for (const TargetStats& candidate : order) {
      if (planned >= params.max_targets) break;
      if (result.target_id > 0 &&
          (!compare || candidate.mean_deformability >= best_deformability - params.tie_tolerance)) {
        break;
      }
      const int id = candidate.id;
      ++planned;
      if (pass == 0) result.tried_ids.push_back(id);
      cv::Mat1b grown = pieces.GrownTarget(objects.labels, id);
      if (named && params.target_px) {
        grown = ClickedPart(scene, grown, *params.target_px, params.fge.seam_step_m);
      }
      const cv::Mat1b contact = StiffPart(scene, grown, stiffness, params, contrast);
      if (pass > 0 && cv::countNonZero(contact != StiffPart(scene, grown, stiffness, params,
                                                            passes[pass - 1])) == 0) {
        continue;  // nothing more allowed than the last pass saw
      }
      // Grasps that touch no neighbour first; pressing soft neighbours aside only when the
      // target gives none without (a "neighbour" is sometimes a piece of the target itself that
      // the segmentation split off, and pressing into it lands the finger on the target).
      for (const bool press : {false, true}) {
        if (cv::countNonZero(contact) == 0) break;
        const TargetView view =
            ViewForTarget(scene, camera, gripper, objects, id, contact, params, press, shared);
        if (press && !view.pressable) break;
        const int found = PlanOpenings(scene, view, press, camera, stiffness, gripper, sp, params,
                                       id, objects.labels, &best_deformability, &result);
        if (found != 0) break;  // a grasp (kept or not better than the best): no pressing needed
      }
    }
    result.soft_part_allowed = pass > 0 && result.target_id > 0;
  }
  if (result.target_id == 0 && params.whole_scene_fallback && params.target_id == 0) {
    StiffnessFgeParams whole;
    whole.fge = params.fge;
    whole.centre_weight = params.centre_weight;
    whole.key_step = params.deformability_step;
    for (const Grasp& g : DetectGraspsStiffness(scene, camera, stiffness, gripper, whole)) {
      DeformabilityGrasp dg;
      dg.grasp = g;
      const int u =
          std::clamp(static_cast<int>(std::lround(g.center_u_px)), 0, scene.height_m.cols - 1);
      const int v =
          std::clamp(static_cast<int>(std::lround(g.center_v_px)), 0, scene.height_m.rows - 1);
      dg.instance_id = objects.labels(v, u);
      dg.mean_deformability = 1.0 - g.mean_stiffness;
      result.grasps.push_back(std::move(dg));
    }
    result.fallback = !result.grasps.empty();
  }
  return result;
}

}  // namespace softgrasp::core
