#include "sim/grasp/execute.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;

// Every ray fan (finger footprints, finger faces, descent levels) samples its rectangle on a
// grid this fine, edges included: at most 1 mm between rays (a few thousand rays a grasp).
constexpr double kRaySpacingM = 0.001;
// A fingertip may rest on a surface (the table, at fingertip height 0) without colliding: hits
// within this distance above the fingertip plane do not count.
constexpr double kSkinM = 1e-4;
// Hits within this distance of a finger's first contact form its contact patch.
constexpr double kContactPatchM = 5e-4;
// The fingers start their descent this far above the highest surface of the scene.
constexpr double kStartClearanceM = 0.01;
// Bounds the horizontal descent rays on absurdly tall scenes (the level spacing then widens).
constexpr int kMaxDescentLevels = 2000;
// Gripper sizes above this are rejected: they are not grippers, and they bound the ray count.
constexpr double kMaxGripperSizeM = 1.0;
// Grasp coordinates beyond this are rejected: no scene is that large, and Embree traces in float.
constexpr double kMaxCoordinateM = 1000.0;
// Squeezing cannot bring the object below this fraction of its first-contact width l_c.
constexpr double kMinSqueezedFraction = 0.5;
constexpr double kDamageRate = 0.2;
// A descending finger may compress a neighbour by at most this fraction of its height.
constexpr double kMaxPressFraction = 0.5;
constexpr double kGravityMPerS2 = 9.81;
// Spring-rate anchors of ContactSpringRateNPerMm (log-linear in between).
constexpr double kSoftestRateNPerMm = 0.2;
constexpr double kRigidRateNPerMm = 1000.0;
constexpr double kPi = 3.14159265358979323846;

std::string Mm(double length_m) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.2f mm", length_m * 1000.0);
  return buf;
}

std::string Num(double value, const char* unit) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.3g%s", value, unit);
  return buf;
}

std::string Deg(double angle_rad) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.1f deg", angle_rad * 180.0 / kPi);
  return buf;
}

std::string What(const SimScene& scene, int instance_id) {
  if (instance_id == 0) {
    return std::string("the support (") + SupportKindName(scene.support.kind) + ")";
  }
  return "object " + std::to_string(instance_id);
}

/// `lo`, `hi` and evenly spaced samples between them, no further apart than `spacing`.
std::vector<double> Samples(double lo, double hi, double spacing, int max_intervals) {
  if (!(hi > lo)) return {lo};
  // Clamp in double: a huge span must not overflow the int.
  const int intervals = static_cast<int>(std::clamp(
      std::ceil((hi - lo) / spacing), 1.0, static_cast<double>(std::max(1, max_intervals))));
  std::vector<double> out(intervals + 1);
  for (int i = 0; i <= intervals; ++i) out[i] = lo + (hi - lo) * i / intervals;
  out.back() = hi;
  return out;
}

std::vector<double> Samples(double lo, double hi) {
  return Samples(lo, hi, kRaySpacingM, std::numeric_limits<int>::max());
}

/// The grasp in W: origin on the fingertip plane at the grasp centre, closing axis a (from the
/// left finger towards the right one), lateral axis b, z up.
struct GraspFrame {
  Eigen::Vector3d origin_w;
  Eigen::Vector3d closing_w;
  Eigen::Vector3d lateral_w;

  explicit GraspFrame(const SimGrasp& g)
      : origin_w(g.center_x_m, g.center_y_m, g.fingertip_height_m),
        closing_w(std::cos(g.angle_rad), std::sin(g.angle_rad), 0.0),
        lateral_w(-std::sin(g.angle_rad), std::cos(g.angle_rad), 0.0) {}

  /// The point at closing coordinate a, lateral b and height z_above_tip over the fingertips.
  Eigen::Vector3d At(double a, double b, double z_above_tip) const {
    return origin_w + a * closing_w + b * lateral_w + Eigen::Vector3d(0.0, 0.0, z_above_tip);
  }
};

/// The two fingers; `sign` is the side of the closing axis each one sits on.
struct Finger {
  const char* name;
  double sign;
};
constexpr Finger kLeft{"left", -1.0};
constexpr Finger kRight{"right", 1.0};

struct ZRange {
  double lo_m;
  double hi_m;
};

/// Lowest and highest point of everything in the scene (support and objects), in W.
ZRange SceneZRange(const SimScene& scene) {
  ZRange z{-scene.support.thickness_m,
           scene.support.kind == Support::Kind::kBin ? scene.support.wall_height_m : 0.0};
  for (const PlacedObject& placed : scene.objects) {
    if (!placed.object) continue;
    for (const auto& v : placed.object->mesh_o.vertices) {
      const double vz = (placed.world_from_object * Eigen::Vector3d(v[0], v[1], v[2])).z();
      z.lo_m = std::min(z.lo_m, vz);
      z.hi_m = std::max(z.hi_m, vz);
    }
  }
  return z;
}

std::optional<core::Error> Validate(const SimGrasp& g, const core::Gripper& p) {
  const std::pair<const char*, double> finite[] = {{"center_x_m", g.center_x_m},
                                                   {"center_y_m", g.center_y_m},
                                                   {"fingertip_height_m", g.fingertip_height_m},
                                                   {"angle_rad", g.angle_rad},
                                                   {"opening_m", g.opening_m},
                                                   {"opening_stroke_m", p.opening_stroke_m},
                                                   {"finger_width_m", p.finger_width_m},
                                                   {"finger_thickness_m", p.finger_thickness_m},
                                                   {"finger_length_m", p.finger_length_m},
                                                   {"closing_force_n", p.closing_force_n},
                                                   {"friction_coefficient", p.friction_coefficient},
                                                   {"max_press_force_n", p.max_press_force_n}};
  for (const auto& [field, value] : finite) {
    if (!std::isfinite(value)) {
      return MakeError(ErrorCode::kInvalidArgument, std::string(field) + " must be finite", field);
    }
  }
  const std::pair<const char*, double> coordinates[] = {
      {"center_x_m", g.center_x_m},
      {"center_y_m", g.center_y_m},
      {"fingertip_height_m", g.fingertip_height_m}};
  for (const auto& [field, value] : coordinates) {
    if (std::abs(value) > kMaxCoordinateM) {
      return MakeError(ErrorCode::kInvalidArgument,
                       std::string(field) + " is " + Num(value, " m") + "; expected within +-" +
                           Num(kMaxCoordinateM, " m") + " of the scene's origin",
                       field);
    }
  }
  const std::pair<const char*, double> sizes[] = {{"opening_stroke_m", p.opening_stroke_m},
                                                  {"finger_width_m", p.finger_width_m},
                                                  {"finger_thickness_m", p.finger_thickness_m},
                                                  {"finger_length_m", p.finger_length_m}};
  for (const auto& [field, value] : sizes) {
    if (!(value > 0.0 && value <= kMaxGripperSizeM)) {
      return MakeError(ErrorCode::kInvalidArgument,
                       std::string(field) + " is " + Num(value, " m") + "; expected (0, " +
                           Num(kMaxGripperSizeM, " m") + "]",
                       field);
    }
  }
  if (!(p.closing_force_n > 0.0)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "closing_force_n is " + Num(p.closing_force_n, " N") + "; expected > 0",
                     "closing_force_n");
  }
  if (!(p.max_press_force_n >= 0.0)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "max_press_force_n is " + Num(p.max_press_force_n, " N") + "; expected >= 0",
                     "max_press_force_n");
  }
  if (!(p.friction_coefficient >= 0.0)) {
    return MakeError(
        ErrorCode::kInvalidArgument,
        "friction_coefficient is " + Num(p.friction_coefficient, "") + "; expected >= 0",
        "friction_coefficient");
  }
  if (!(g.opening_m > 0.0 && g.opening_m <= p.opening_stroke_m)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "opening_m is " + Mm(g.opening_m) + "; expected in (0, " +
                         Mm(p.opening_stroke_m) + "] (the gripper's stroke)",
                     "opening_m");
  }
  return std::nullopt;
}

/// The highest point of one instance (or the support) a finger meets on its way down.
struct DescentHit {
  const char* finger;
  RayHit hit;
};

/// Sweeps both finger boxes from above the scene down to the fingertip plane. Vertical rays over
/// each footprint find surfaces with some extent in plan; horizontal rays across the footprint
/// on levels kRaySpacingM apart find thin vertical features that fall between vertical rays.
/// Returns, per instance met (0 = the support), its highest hit: the first a descending finger
/// would touch. Highest first.
std::vector<DescentHit> Descend(const SceneRaycaster& raycaster, const GraspFrame& frame,
                                const SimGrasp& grasp, const core::Gripper& gripper,
                                const ZRange& scene_z) {
  const double tip_z = grasp.fingertip_height_m;
  const double top_z = std::max(scene_z.hi_m, tip_z) + kStartClearanceM;
  const double drop_m = top_z - tip_z - kSkinM;
  if (!(drop_m > 0.0)) return {};
  const Eigen::Vector3d down(0.0, 0.0, -1.0);
  const double half_width = gripper.finger_width_m / 2.0;
  const std::vector<double> bs = Samples(-half_width, half_width);
  // Below the scene's lowest point there is nothing to hit.
  const std::vector<double> levels =
      Samples(std::max(tip_z + kSkinM, scene_z.lo_m), top_z, kRaySpacingM, kMaxDescentLevels);

  std::map<int, DescentHit> by_instance;
  auto consider = [&](const Finger& finger, const std::optional<RayHit>& hit) {
    if (!hit) return;
    auto [it, inserted] = by_instance.try_emplace(hit->instance_id, DescentHit{finger.name, *hit});
    DescentHit& d = it->second;
    if (!inserted && hit->point_w.z() > d.hit.point_w.z()) {
      d.finger = finger.name;
      d.hit = *hit;
    }
  };
  for (const Finger& finger : {kLeft, kRight}) {
    const double inner = finger.sign * grasp.opening_m / 2.0;
    const double outer = finger.sign * (grasp.opening_m / 2.0 + gripper.finger_thickness_m);
    const double a_lo = std::min(inner, outer);
    const double a_hi = std::max(inner, outer);
    const std::vector<double> as = Samples(a_lo, a_hi);
    for (double a : as) {
      for (double b : bs) {
        consider(finger, raycaster.Cast(frame.At(a, b, top_z - tip_z), down, drop_m));
      }
    }
    for (double z : levels) {
      const double dz = z - tip_z;
      for (double b : bs) {
        consider(finger, raycaster.Cast(frame.At(a_lo, b, dz), frame.closing_w, a_hi - a_lo));
      }
      for (double a : as) {
        consider(finger,
                 raycaster.Cast(frame.At(a, -half_width, dz), frame.lateral_w, 2.0 * half_width));
      }
    }
  }
  std::vector<DescentHit> out;
  for (auto& [id, d] : by_instance) out.push_back(d);
  std::sort(out.begin(), out.end(), [](const DescentHit& a, const DescentHit& b) {
    if (a.hit.point_w.z() != b.hit.point_w.z()) return a.hit.point_w.z() > b.hit.point_w.z();
    return a.hit.instance_id < b.hit.instance_id;
  });
  return out;
}

/// Height of an object: its vertices' z range in W.
double ObjectHeightM(const PlacedObject& placed) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const auto& v : placed.object->mesh_o.vertices) {
    const double vz = (placed.world_from_object * Eigen::Vector3d(v[0], v[1], v[2])).z();
    lo = std::min(lo, vz);
    hi = std::max(hi, vz);
  }
  return hi > lo ? hi - lo : 0.0;
}

/// Instance ids of the surfaces above the fingertip plane between the open fingers.
std::set<int> IdsBetweenFingers(const SceneRaycaster& raycaster, const GraspFrame& frame,
                                const SimGrasp& grasp, const core::Gripper& gripper,
                                const ZRange& scene_z) {
  std::set<int> ids;
  const double tip_z = grasp.fingertip_height_m;
  const double top_z = std::max(scene_z.hi_m, tip_z) + kStartClearanceM;
  const double drop_m = top_z - tip_z - kSkinM;
  if (!(drop_m > 0.0)) return ids;
  const double half_opening = grasp.opening_m / 2.0;
  const double half_width = gripper.finger_width_m / 2.0;
  for (double a : Samples(-half_opening, half_opening)) {
    for (double b : Samples(-half_width, half_width)) {
      const auto hit = raycaster.Cast(frame.At(a, b, top_z - tip_z), {0.0, 0.0, -1.0}, drop_m);
      if (hit) ids.insert(hit->instance_id);
    }
  }
  return ids;
}

/// Where a closing finger first touches something.
struct Contact {
  bool touched = false;
  double travel_m = 0.0;        ///< finger travel from the open position to first contact
  bool started_inside = false;  ///< the finger face began inside a solid
  int instance_id = 0;          ///< of the first hit
  std::set<int> patch_ids;      ///< every instance in the contact patch
  float stiffness = 0.0f;       ///< stiffest surface of the first-hit object in the patch
  Eigen::Vector3d normal_w{0.0, 0.0, 0.0};  ///< mean outward surface normal over the patch
};

/// Closes one finger: rays from its inner face (over the face's width and from the fingertip up
/// to the finger length) along the closing direction, across the whole opening.
Contact Close(const SceneRaycaster& raycaster, const GraspFrame& frame, const SimGrasp& grasp,
              const core::Gripper& gripper, const Finger& finger) {
  const Eigen::Vector3d direction_w = -finger.sign * frame.closing_w;
  const double face_a = finger.sign * grasp.opening_m / 2.0;
  const double half_width = gripper.finger_width_m / 2.0;
  std::vector<RayHit> hits;
  for (double b : Samples(-half_width, half_width)) {
    for (double dz : Samples(kSkinM, gripper.finger_length_m)) {
      auto hit = raycaster.Cast(frame.At(face_a, b, dz), direction_w, grasp.opening_m);
      if (hit) hits.push_back(*hit);
    }
  }
  Contact c;
  if (hits.empty()) return c;
  const auto first = std::min_element(hits.begin(), hits.end(), [](const auto& x, const auto& y) {
    return x.distance_m < y.distance_m;
  });
  c.touched = true;
  c.travel_m = first->distance_m;
  c.instance_id = first->instance_id;
  // The hit of a ray that starts inside a solid is an exit face, whose outward normal points
  // along the ray.
  c.started_inside = first->normal_w.dot(direction_w) > 1e-9;
  Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
  for (const RayHit& hit : hits) {
    if (hit.distance_m > c.travel_m + kContactPatchM) continue;
    c.patch_ids.insert(hit.instance_id);
    if (hit.instance_id != c.instance_id) continue;
    // A rigid finger pressed on a patch of mixed stiffness is stopped by its stiffest part.
    c.stiffness = std::max(c.stiffness, hit.stiffness);
    normal_sum += hit.normal_w;
  }
  c.normal_w = normal_sum.norm() > 0.0 ? normal_sum.normalized() : Eigen::Vector3d(-direction_w);
  return c;
}

GraspExecution Outcome(GraspOutcome outcome, std::string reason, int instance_id = 0) {
  GraspExecution e;
  e.outcome = outcome;
  e.reason = std::move(reason);
  e.instance_id = instance_id;
  return e;
}

/// Outcomes decided while closing (before any squeeze); nullopt when both fingers hold one
/// object.
std::optional<GraspExecution> JudgeContacts(const SimScene& scene, const SimGrasp& grasp,
                                            const Contact& left, const Contact& right) {
  if (!left.touched && !right.touched) {
    return Outcome(GraspOutcome::kEmpty,
                   "the fingers closed from " + Mm(grasp.opening_m) + " on nothing");
  }
  if (!left.touched || !right.touched) {
    // Both fingers sweep the same segments in opposite directions, so this needs an open or
    // degenerate surface.
    const Contact& toucher = left.touched ? left : right;
    return Outcome(GraspOutcome::kEmpty,
                   std::string("only the ") + (left.touched ? "left" : "right") +
                       " finger touched something (" + What(scene, toucher.instance_id) + ")",
                   toucher.instance_id);
  }
  for (const auto& [name, c] : {std::pair{"left", &left}, std::pair{"right", &right}}) {
    if (c->started_inside) {
      if (c->instance_id == 0) {
        return Outcome(GraspOutcome::kCollision,
                       std::string("the ") + name + " finger face starts inside the support", 0);
      }
      return Outcome(GraspOutcome::kTooWide,
                     What(scene, c->instance_id) + " is wider than the " + Mm(grasp.opening_m) +
                         " opening: the " + name + " finger face starts inside it",
                     c->instance_id);
    }
    if (c->patch_ids.count(0) != 0) {
      return Outcome(GraspOutcome::kCollision,
                     std::string("the ") + name + " finger closes onto " + What(scene, 0) +
                         " after " + Mm(c->travel_m),
                     0);
    }
  }
  std::set<int> ids = left.patch_ids;
  ids.insert(right.patch_ids.begin(), right.patch_ids.end());
  if (ids.size() > 1) {
    std::string list;
    for (int id : ids) list += (list.empty() ? "" : ", ") + std::to_string(id);
    return Outcome(GraspOutcome::kMultipleObjects,
                   "the fingers touch different objects (" + list + ")", left.instance_id);
  }
  return std::nullopt;
}

/// Angle between a contact's outward normal and the direction the finger pushes against it.
double ConeAngleRad(const Contact& c, const Eigen::Vector3d& push_w) {
  return std::acos(std::clamp(c.normal_w.dot(-push_w), -1.0, 1.0));
}

}  // namespace

double ContactSpringRateNPerMm(float stiffness) {
  // Clamp in float so the level scores (0.1f, 1.0f) land exactly on the anchors.
  const float s =
      std::isnan(stiffness) ? kMinStiffness : std::clamp(stiffness, kMinStiffness, kMaxStiffness);
  const double t = (static_cast<double>(s) - kMinStiffness) /
                   (static_cast<double>(kMaxStiffness) - kMinStiffness);
  return kSoftestRateNPerMm * std::pow(kRigidRateNPerMm / kSoftestRateNPerMm, t);
}

const char* GraspOutcomeName(GraspOutcome outcome) {
  switch (outcome) {
    case GraspOutcome::kSucceeded:
      return "succeeded";
    case GraspOutcome::kCollision:
      return "collision";
    case GraspOutcome::kEmpty:
      return "empty";
    case GraspOutcome::kTooWide:
      return "too_wide";
    case GraspOutcome::kMultipleObjects:
      return "multiple_objects";
    case GraspOutcome::kSlipped:
      return "slipped";
  }
  return "unknown";
}

SimGrasp SimGraspFromCamera(const core::Grasp& grasp, const Eigen::Isometry3d& world_from_camera) {
  const Eigen::Vector3d p_CG(grasp.p_CG_m[0], grasp.p_CG_m[1], grasp.p_CG_m[2]);
  const Eigen::Quaterniond q_CG(grasp.q_CG_wxyz[0], grasp.q_CG_wxyz[1], grasp.q_CG_wxyz[2],
                                grasp.q_CG_wxyz[3]);
  const Eigen::Vector3d p_WG = world_from_camera * p_CG;
  const Eigen::Vector3d closing_w =
      world_from_camera.linear() * (q_CG.normalized() * Eigen::Vector3d::UnitX());
  // The fingers are symmetric, so the closing axis is a line: report its angle in [0, pi).
  double angle = std::atan2(closing_w.y(), closing_w.x());
  if (angle < 0.0) angle += kPi;
  if (angle >= kPi) angle -= kPi;
  SimGrasp out;
  out.center_x_m = p_WG.x();
  out.center_y_m = p_WG.y();
  out.fingertip_height_m = p_WG.z();
  out.angle_rad = angle;
  out.opening_m = grasp.opening_m;
  return out;
}

core::Result<GraspExecution> ExecuteGrasp(const SimScene& scene, const SceneRaycaster& raycaster,
                                          const SimGrasp& grasp, const core::Gripper& gripper) {
  if (auto error = Validate(grasp, gripper)) return *error;
  const GraspFrame frame(grasp);
  const ZRange scene_z = SceneZRange(scene);

  // 1. Descent: from the highest surface met down, each is pressed aside (a neighbour soft
  // enough to yield to the fingertip height under max_press_force_n, by at most
  // kMaxPressFraction of its height) or ends the descent.
  std::vector<PressedNeighbour> pressed;
  const std::vector<DescentHit> hits = Descend(raycaster, frame, grasp, gripper, scene_z);
  std::set<int> between;
  if (!hits.empty()) between = IdsBetweenFingers(raycaster, frame, grasp, gripper, scene_z);
  for (const DescentHit& d : hits) {
    const int id = d.hit.instance_id;
    const std::string where = " at z = " + Mm(d.hit.point_w.z()) +
                              " on the way down to the fingertip height " +
                              Mm(grasp.fingertip_height_m);
    // Landing on the very object that fills the gap means the opening was too small for it.
    if (id != 0 && between.count(id) != 0) {
      return Outcome(GraspOutcome::kTooWide,
                     What(scene, id) + " is wider than the " + Mm(grasp.opening_m) +
                         " opening: the " + d.finger + " finger lands on it" + where,
                     id);
    }
    const PlacedObject* neighbour = id != 0 ? scene.Find(id) : nullptr;
    std::string why;
    if (neighbour != nullptr && neighbour->object && gripper.max_press_force_n > 0.0) {
      const double depth_m = std::max(0.0, d.hit.point_w.z() - grasp.fingertip_height_m);
      // The surface met first sets the spring rate (a sponge's pad, a brush's bristles).
      const double force_n = ContactSpringRateNPerMm(d.hit.stiffness) * depth_m * 1000.0;
      const double height_m = ObjectHeightM(*neighbour);
      if (force_n <= gripper.max_press_force_n && depth_m <= kMaxPressFraction * height_m) {
        pressed.push_back({id, depth_m, force_n, height_m > 0.0 ? depth_m / height_m : 0.0});
        continue;
      }
      why = force_n > gripper.max_press_force_n
                ? " (pressing it " + Mm(depth_m) + " takes " + Num(force_n, " N") + " > " +
                      Num(gripper.max_press_force_n, " N") + ")"
                : " (pressing it " + Mm(depth_m) + " is more than half its height)";
    }
    return Outcome(GraspOutcome::kCollision,
                   std::string("the ") + d.finger + " finger hits " + What(scene, id) + where + why,
                   id);
  }
  std::sort(pressed.begin(), pressed.end(),
            [](const auto& a, const auto& b) { return a.instance_id < b.instance_id; });

  // 2. Closing. Pressed neighbours are pushed aside: the fingers close without them.
  std::optional<SceneRaycaster> without_pressed;
  if (!pressed.empty()) {
    SimScene rest = scene;
    for (const PressedNeighbour& p : pressed) rest.Remove(p.instance_id);
    auto built = SceneRaycaster::Build(rest);
    if (!built.ok()) return built.error();
    without_pressed.emplace(std::move(built).value());
  }
  const SceneRaycaster& closing = without_pressed ? *without_pressed : raycaster;
  const Contact left = Close(closing, frame, grasp, gripper, kLeft);
  const Contact right = Close(closing, frame, grasp, gripper, kRight);
  if (auto judged = JudgeContacts(scene, grasp, left, right)) {
    judged->pressed = pressed;
    return *std::move(judged);
  }

  GraspExecution e;
  e.pressed = pressed;
  e.instance_id = left.instance_id;
  e.stiffness_left = left.stiffness;
  e.stiffness_right = right.stiffness;
  e.contact_width_m = std::max(0.0, grasp.opening_m - left.travel_m - right.travel_m);

  // 3. Squeeze: one Hooke-law spring per finger, each pushed with the full closing force.
  const double max_dent_m = e.contact_width_m * (1.0 - kMinSqueezedFraction) / 2.0;
  const double force = gripper.closing_force_n;
  const double dent_left_m =
      std::min(force / (1000.0 * ContactSpringRateNPerMm(left.stiffness)), max_dent_m);
  const double dent_right_m =
      std::min(force / (1000.0 * ContactSpringRateNPerMm(right.stiffness)), max_dent_m);
  e.grasped_width_m = e.contact_width_m - dent_left_m - dent_right_m;
  e.deformation_rate =
      e.contact_width_m > 0.0 ? (e.contact_width_m - e.grasped_width_m) / e.contact_width_m : 0.0;
  e.damaged = e.deformation_rate > kDamageRate;
  const std::string widths = "l_c = " + Mm(e.contact_width_m) + ", l_g = " + Mm(e.grasped_width_m) +
                             ", deformation " + Num(100.0 * e.deformation_rate, " %");

  // 4. Lift.
  const double cone_rad = std::atan(gripper.friction_coefficient);
  for (const auto& [name, c, push] :
       {std::tuple<const char*, const Contact*, Eigen::Vector3d>{"left", &left, frame.closing_w},
        std::tuple<const char*, const Contact*, Eigen::Vector3d>{"right", &right,
                                                                 -frame.closing_w}}) {
    const double angle = ConeAngleRad(*c, push);
    if (angle > cone_rad) {
      e.outcome = GraspOutcome::kSlipped;
      e.reason = std::string("the ") + name + " contact normal is " + Deg(angle) +
                 " off the closing axis, outside the friction cone of " + Deg(cone_rad) +
                 " (mu = " + Num(gripper.friction_coefficient, "") + "); " + widths;
      return e;
    }
  }
  const PlacedObject* held = scene.Find(e.instance_id);
  const double mass_kg = held && held->object ? held->object->mass_kg : 0.0;
  const double weight_n = mass_kg * kGravityMPerS2;
  const double friction_n = 2.0 * gripper.friction_coefficient * force;
  if (friction_n < weight_n) {
    e.outcome = GraspOutcome::kSlipped;
    e.reason = "friction 2*mu*F = " + Num(friction_n, " N") +
               " cannot hold the weight m*g = " + Num(weight_n, " N") + " of " +
               What(scene, e.instance_id) + " (" + Num(mass_kg, " kg") + "); " + widths;
    return e;
  }
  e.outcome = GraspOutcome::kSucceeded;
  e.reason = "held " + What(scene, e.instance_id) + ": " + widths +
             (e.damaged ? " (damaged: above 20 %)" : "");
  for (const PressedNeighbour& p : pressed) {
    e.reason += "; pressed " + What(scene, p.instance_id) + " by " + Mm(p.press_depth_m) + " (" +
                Num(p.force_n, " N") + ")";
  }
  return e;
}

core::Result<GraspExecution> ExecuteAndRemove(SimScene* scene, const SimGrasp& grasp,
                                              const core::Gripper& gripper) {
  if (scene == nullptr) {
    return MakeError(ErrorCode::kInvalidArgument, "scene is null", "scene");
  }
  // Validate before paying for a BVH build.
  if (auto error = Validate(grasp, gripper)) return *error;
  auto raycaster = SceneRaycaster::Build(*scene);
  if (!raycaster.ok()) return raycaster.error();
  auto execution = ExecuteGrasp(*scene, raycaster.value(), grasp, gripper);
  if (execution.ok() && execution.value().succeeded()) {
    scene->Remove(execution.value().instance_id);
  }
  return execution;
}

}  // namespace softgrasp::sim
