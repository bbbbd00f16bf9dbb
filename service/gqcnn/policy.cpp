#include "service/gqcnn/policy.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "service/gqcnn/clearance.h"
#include "service/gqcnn/dataset_format.h"

namespace softgrasp::gqcnn {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Grasp centres stay this fraction of the crop away from the image border (Dex-Net: 45 of 96).
constexpr double kBoundaryFractionOfCrop = 45.0 / 96.0;
// The grasp centre stays this far above the floor along its pixel's ray: below it the jaws are
// in the table.
constexpr double kFloorClearanceM = 0.002;
// Seed pairs tried per seed candidate wanted, at most (the rest fail the clearance check).
constexpr std::size_t kMaxPairDrawsPerSeed = 20;
// Two grasps closer than this fraction of the opening and this angle are one (suppression).
constexpr double kDuplicateDistanceFraction = 0.2;
constexpr double kDuplicateAngleRad = 15.0 * kPi / 180.0;

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Portable draws from a fixed generator: the same seed plans the same grasps everywhere.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  std::size_t Index(std::size_t n) {
    return std::min(n - 1, static_cast<std::size_t>(Uniform() * static_cast<double>(n)));
  }
  double Normal() {  // Box-Muller
    const double u1 = std::max(Uniform(), 1e-300);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * Uniform());
  }

 private:
  std::mt19937_64 engine_;
};

struct EdgePixel {
  int u = 0;
  int v = 0;
  double nx = 0.0;  // unit depth gradient: points away from the nearer surface
  double ny = 0.0;
};

struct Candidate {
  GraspImagePose pose;
  double surface_depth_m = 0.0;  // highest surface between the contacts
  float quality = 0.0F;
  core::ContactHold contacts = core::ContactHold::kFirm;
  GripperClearance clearance;  // at `pose`, measured by Reachable
};

// Firm contacts first (all candidates are firm when the check is off), then the network's
// quality.
bool Better(const Candidate& a, const Candidate& b) {
  if (a.contacts != b.contacts) return a.contacts > b.contacts;
  return a.quality > b.quality;
}

double WrapAngle(double angle_rad) {
  angle_rad = std::fmod(angle_rad, kPi);
  if (angle_rad < 0.0) angle_rad += kPi;
  return angle_rad;
}

double AngleDistance(double a_rad, double b_rad) {
  const double d = std::fabs(WrapAngle(a_rad) - WrapAngle(b_rad));
  return std::min(d, kPi - d);
}

// z where pixel (u, v)'s ray meets the floor plane; +inf when it never does in front.
double FloorDepthAt(const core::Plane& floor, const core::Camera& camera, double u, double v) {
  const double rx = (u - camera.cx) / camera.fx;
  const double ry = (v - camera.cy) / camera.fy;
  const double denom = floor.n[0] * rx + floor.n[1] * ry + floor.n[2];
  if (std::fabs(denom) < 1e-9) return std::numeric_limits<double>::infinity();
  const double z = -floor.d / denom;
  return z > 0.0 ? z : std::numeric_limits<double>::infinity();
}

double HeightAbove(const core::Plane& floor, const core::Camera& camera, double u, double v,
                   double z) {
  const double x = (u - camera.cx) / camera.fx * z;
  const double y = (v - camera.cy) / camera.fy * z;
  return floor.n[0] * x + floor.n[1] * y + floor.n[2] * z + floor.d;
}

class Planner {
 public:
  Planner(const core::Scene& scene, const core::Camera& camera, const core::Gripper& gripper,
          const PolicyParams& params)
      : scene_(scene),
        camera_(camera),
        gripper_(gripper),
        params_(params),
        rng_(params.seed),
        crop_px_(std::max(8, static_cast<int>(std::lround(params.source_crop_px * camera.fx /
                                                          params.training_fx_px)))),
        margin_px_(kBoundaryFractionOfCrop * crop_px_) {}

  int CropPx() const { return crop_px_; }

  std::vector<EdgePixel> FindEdges(int* total) {
    cv::Mat1f smooth;
    cv::GaussianBlur(scene_.depth_filled_m, smooth, cv::Size(0, 0), 1.0);
    cv::Mat1f gx;
    cv::Mat1f gy;
    cv::Sobel(smooth, gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
    cv::Sobel(smooth, gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
    std::vector<EdgePixel> edges;
    // Squared magnitudes are compared: this runs on every pixel, and std::hypot is slow.
    const double threshold = params_.depth_gradient_threshold_m;
    const double threshold_squared = threshold * threshold;
    for (int v = 1; v + 1 < smooth.rows; ++v) {
      for (int u = 1; u + 1 < smooth.cols; ++u) {
        const double dx = gx(v, u);
        const double dy = gy(v, u);
        const double squared = dx * dx + dy * dy;
        if (!(squared > threshold_squared)) continue;
        if (!ContactAllowed(u, v)) continue;
        const double magnitude = std::sqrt(squared);
        edges.push_back({u, v, dx / magnitude, dy / magnitude});
      }
    }
    *total = static_cast<int>(edges.size());
    // A seeded partial shuffle keeps a uniform random subset.
    const std::size_t keep =
        std::min(edges.size(), static_cast<std::size_t>(params_.max_edge_pixels));
    for (std::size_t i = 0; i < keep; ++i) {
      std::swap(edges[i], edges[i + rng_.Index(edges.size() - i)]);
    }
    edges.resize(keep);
    return edges;
  }

  std::vector<std::pair<int, int>> AntipodalPairs(const std::vector<EdgePixel>& edges) const {
    const double cos_cone = std::cos(std::atan(params_.friction_coefficient));
    std::vector<std::pair<int, int>> pairs;
    for (std::size_t i = 0; i < edges.size(); ++i) {
      for (std::size_t j = i + 1; j < edges.size(); ++j) {
        const double du = edges[j].u - edges[i].u;
        const double dv = edges[j].v - edges[i].v;
        const double squared_px = du * du + dv * dv;  // integer pixel offsets: exact
        if (squared_px < 4.0) continue;
        const double length_px = std::sqrt(squared_px);
        const double ax = du / length_px;
        const double ay = dv / length_px;
        // The jaw at i pushes along +axis into the object, i.e. against i's outward gradient;
        // the jaw at j pushes along -axis.
        if (-(ax * edges[i].nx + ay * edges[i].ny) < cos_cone) continue;
        if (ax * edges[j].nx + ay * edges[j].ny < cos_cone) continue;
        const double z = std::min(Depth(edges[i].u, edges[i].v), Depth(edges[j].u, edges[j].v));
        const double width_m = length_px * z / camera_.fx;
        if (width_m > gripper_.opening_stroke_m || width_m < params_.min_contact_distance_m) {
          continue;
        }
        const double cu = 0.5 * (edges[i].u + edges[j].u);
        const double cv = 0.5 * (edges[i].v + edges[j].v);
        if (!InsideMargin(cu, cv)) continue;
        pairs.emplace_back(static_cast<int>(i), static_cast<int>(j));
      }
    }
    return pairs;
  }

  // A candidate from a pair, with a random depth offset; false when the grasp would be in the
  // floor.
  bool FromPair(const EdgePixel& a, const EdgePixel& b, Candidate* out) {
    const double cu = 0.5 * (a.u + b.u);
    const double cv = 0.5 * (a.v + b.v);
    const double length_px = std::hypot(b.u - a.u, b.v - a.v);
    // The highest surface between the contacts is what the jaws close on: it must be allowed
    // contact too, or two allowed edge pixels beside an excluded surface (a segmask's outside,
    // the gripper's own finger nearer than min_depth_m) would grasp that surface.
    double surface = std::numeric_limits<double>::infinity();
    int surface_u = a.u, surface_v = a.v;
    const int steps = std::max(2, static_cast<int>(std::ceil(length_px)));
    for (int s = 0; s <= steps; ++s) {
      const double t = static_cast<double>(s) / steps;
      const int u = static_cast<int>(std::lround(a.u + t * (b.u - a.u)));
      const int v = static_cast<int>(std::lround(a.v + t * (b.v - a.v)));
      const double depth = Depth(u, v);
      if (depth < surface) {
        surface = depth;
        surface_u = u;
        surface_v = v;
      }
    }
    if (!std::isfinite(surface) || surface <= 0.0) return false;
    if (!ContactAllowed(surface_u, surface_v)) return false;
    out->surface_depth_m = surface;
    out->pose.center_u_px = cu;
    out->pose.center_v_px = cv;
    out->pose.angle_rad = WrapAngle(std::atan2(b.v - a.v, b.u - a.u));
    out->pose.width_px = gripper_.opening_stroke_m * camera_.fx / surface;
    return SampleDepth(out) && Reachable(out);
  }

  // Whether the gripper can take the candidate: it reaches the grasp depth (the clearance check
  // the dataset's records carry, clearance.h, on the inpainted depth and the fitted floor's
  // heights; the clearance is kept for the quality function), and there its fingers meet faces
  // that hold, in the image plane (CheckContacts, which sets the candidate's contacts) and in
  // height (ContactFacesSteep). The contacts are checked first: they reject more candidates than
  // the clearance, and faster (the clearance reads every pixel under the fingers and the gap).
  bool Reachable(Candidate* c) const {
    if (params_.check_contacts && !ContactsHold(c)) return false;
    c->clearance = MeasureClearance(scene_.depth_filled_m, scene_.height_m, c->pose, camera_.fx,
                                    gripper_, ClearanceRule{}.min_height_m);
    return !params_.check_clearance || ClearanceRule{}.Admits(c->clearance, gripper_);
  }

  // The in-plane and the height checks of the fingers' contacts; sets the candidate's contacts.
  bool ContactsHold(Candidate* c) const {
    const double px_per_m = camera_.fx / c->pose.depth_m;
    const core::GripperPx fingers{gripper_.opening_stroke_m * px_per_m,
                                  gripper_.finger_width_m * px_per_m,
                                  gripper_.finger_thickness_m * px_per_m};
    const double tip_height_m = HeightAbove(scene_.floor, camera_, c->pose.center_u_px,
                                            c->pose.center_v_px, c->pose.depth_m);
    c->contacts = core::CheckContacts(scene_.height_m, c->pose.center_u_px, c->pose.center_v_px,
                                      c->pose.angle_rad, fingers, px_per_m, tip_height_m);
    return c->contacts != core::ContactHold::kNone &&
           core::ContactFacesSteep(scene_.height_m, c->pose.center_u_px, c->pose.center_v_px,
                                   c->pose.angle_rad, fingers, px_per_m, tip_height_m,
                                   gripper_.friction_coefficient);
  }

  // Draws the grasp depth below the surface, kept above the floor.
  bool SampleDepth(Candidate* c) {
    const double floor_z =
        FloorDepthAt(scene_.floor, camera_, c->pose.center_u_px, c->pose.center_v_px);
    const double deepest =
        std::min(c->surface_depth_m + params_.max_depth_offset_m, floor_z - kFloorClearanceM);
    const double shallowest = c->surface_depth_m + params_.min_depth_offset_m;
    if (deepest <= c->surface_depth_m) return false;  // no room above the floor
    c->pose.depth_m = deepest > shallowest ? rng_.Uniform(shallowest, deepest)
                                           : 0.5 * (c->surface_depth_m + deepest);
    return true;
  }

  core::Result<int> Evaluate(std::vector<Candidate>& candidates, std::size_t first,
                             const QualityFunction& quality) {
    const std::size_t n = candidates.size() - first;
    if (n == 0) return 0;
    std::vector<float> crops(n * kCropPixels);
    std::vector<float> depths(n);
    std::vector<float> clearances(n * 3);
    const core::DepthImage filled{scene_.depth_filled_m};
    for (std::size_t i = 0; i < n; ++i) {
      const Candidate& c = candidates[first + i];
      CropGrasp(filled, c.pose, crops.data() + i * kCropPixels, crop_px_);
      depths[i] = static_cast<float>(c.pose.depth_m);
      clearances[i * 3] = static_cast<float>(c.clearance.jaws_m);
      clearances[i * 3 + 1] = static_cast<float>(c.clearance.palm_m);
      clearances[i * 3 + 2] = static_cast<float>(c.clearance.floor_m);
    }
    const std::vector<float> scores = quality(crops, depths, clearances);
    if (scores.size() != n) {
      return core::MakeError(core::ErrorCode::kInternal, "the grasp quality function returned " +
                                                             std::to_string(scores.size()) +
                                                             " scores for " + std::to_string(n) +
                                                             " crops");
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (!(scores[i] >= 0.0F && scores[i] <= 1.0F)) {
        return core::MakeError(core::ErrorCode::kInternal, "the grasp quality function returned " +
                                                               std::to_string(scores[i]) +
                                                               ", not a probability");
      }
      candidates[first + i].quality = scores[i];
    }
    return static_cast<int>(n);
  }

  // One cross-entropy round: new samples around the best of `population` (a Gaussian mixture
  // with one component per elite grasp and a shared bandwidth).
  std::vector<Candidate> Refine(std::vector<Candidate> population) {
    std::stable_sort(population.begin(), population.end(), Better);
    const std::size_t elites = std::clamp<std::size_t>(
        static_cast<std::size_t>(std::ceil(params_.cem_elite_fraction * population.size())), 1,
        population.size());
    // Per-feature spreads of the elite set; angles on the doubled circle (axes are lines).
    double mean_u = 0, mean_v = 0, mean_depth = 0, c2 = 0, s2 = 0;
    for (std::size_t i = 0; i < elites; ++i) {
      mean_u += population[i].pose.center_u_px;
      mean_v += population[i].pose.center_v_px;
      mean_depth += population[i].pose.depth_m - population[i].surface_depth_m;
      c2 += std::cos(2.0 * population[i].pose.angle_rad);
      s2 += std::sin(2.0 * population[i].pose.angle_rad);
    }
    const double n = static_cast<double>(elites);
    mean_u /= n;
    mean_v /= n;
    mean_depth /= n;
    double var_u = 0, var_v = 0, var_depth = 0;
    for (std::size_t i = 0; i < elites; ++i) {
      var_u += std::pow(population[i].pose.center_u_px - mean_u, 2);
      var_v += std::pow(population[i].pose.center_v_px - mean_v, 2);
      var_depth +=
          std::pow(population[i].pose.depth_m - population[i].surface_depth_m - mean_depth, 2);
    }
    // Silverman's rule for 4 features; floors keep a converged set exploring a little.
    const double bandwidth = std::pow(n, -1.0 / 8.0);
    const double sigma_u = std::max(1.0, bandwidth * std::sqrt(var_u / n));
    const double sigma_v = std::max(1.0, bandwidth * std::sqrt(var_v / n));
    const double sigma_offset = std::max(0.001, bandwidth * std::sqrt(var_depth / n));
    const double resultant = std::min(1.0, std::hypot(c2, s2) / n);
    const double sigma_angle = std::max(
        2.0 * kPi / 180.0,
        bandwidth * 0.5 * std::sqrt(std::max(0.0, -2.0 * std::log(std::max(resultant, 1e-12)))));
    std::vector<Candidate> out;
    for (int attempt = 0;
         attempt < 10 * params_.cem_samples && static_cast<int>(out.size()) < params_.cem_samples;
         ++attempt) {
      const Candidate& parent = population[rng_.Index(elites)];
      Candidate c = parent;
      c.pose.center_u_px += sigma_u * rng_.Normal();
      c.pose.center_v_px += sigma_v * rng_.Normal();
      c.pose.angle_rad = WrapAngle(c.pose.angle_rad + sigma_angle * rng_.Normal());
      if (!InsideMargin(c.pose.center_u_px, c.pose.center_v_px)) continue;
      const int u = static_cast<int>(std::lround(c.pose.center_u_px));
      const int v = static_cast<int>(std::lround(c.pose.center_v_px));
      if (!ContactAllowed(u, v)) continue;
      const double offset =
          parent.pose.depth_m - parent.surface_depth_m + sigma_offset * rng_.Normal();
      c.surface_depth_m = Depth(u, v);
      if (!std::isfinite(c.surface_depth_m) || c.surface_depth_m <= 0.0) continue;
      const double floor_z =
          FloorDepthAt(scene_.floor, camera_, c.pose.center_u_px, c.pose.center_v_px);
      c.pose.depth_m = std::clamp(c.surface_depth_m + offset,
                                  c.surface_depth_m + 0.25 * params_.min_depth_offset_m,
                                  std::max(c.surface_depth_m + 0.25 * params_.min_depth_offset_m,
                                           floor_z - kFloorClearanceM));
      c.pose.width_px = gripper_.opening_stroke_m * camera_.fx / c.surface_depth_m;
      if (!Reachable(&c)) continue;
      c.quality = 0.0F;
      out.push_back(c);
    }
    return out;
  }

  core::Grasp ToGrasp(const Candidate& c) const {
    core::Grasp g;
    g.center_u_px = c.pose.center_u_px;
    g.center_v_px = c.pose.center_v_px;
    g.angle_rad = WrapAngle(c.pose.angle_rad);
    const double px_per_m = camera_.fx / c.surface_depth_m;
    g.opening_px = gripper_.opening_stroke_m * px_per_m;
    g.opening_m = gripper_.opening_stroke_m;
    g.finger_width_px = gripper_.finger_width_m * px_per_m;
    g.finger_thickness_px = gripper_.finger_thickness_m * px_per_m;
    g.contact_height_m =
        HeightAbove(scene_.floor, camera_, g.center_u_px, g.center_v_px, c.surface_depth_m);
    g.grasp_height_m =
        HeightAbove(scene_.floor, camera_, g.center_u_px, g.center_v_px, c.pose.depth_m);
    g.score = c.quality;
    g.height_step = 0;
    const double z = c.pose.depth_m;
    g.p_CG_m = {(g.center_u_px - camera_.cx) / camera_.fx * z,
                (g.center_v_px - camera_.cy) / camera_.fy * z, z};
    g.q_CG_wxyz = {std::cos(0.5 * g.angle_rad), 0.0, 0.0, std::sin(0.5 * g.angle_rad)};
    return g;
  }

 private:
  double Depth(int u, int v) const {
    if (u < 0 || v < 0 || u >= scene_.depth_filled_m.cols || v >= scene_.depth_filled_m.rows) {
      return std::numeric_limits<double>::infinity();
    }
    return scene_.depth_filled_m(v, u);
  }
  bool ContactAllowed(int u, int v) const {
    return scene_.contact_allowed.empty() || scene_.contact_allowed(v, u) != 0;
  }
  bool InsideMargin(double u, double v) const {
    return u >= margin_px_ && v >= margin_px_ && u <= scene_.depth_filled_m.cols - 1 - margin_px_ &&
           v <= scene_.depth_filled_m.rows - 1 - margin_px_;
  }

  const core::Scene& scene_;
  const core::Camera& camera_;
  const core::Gripper& gripper_;
  const PolicyParams& params_;
  Rng rng_;
  int crop_px_;
  double margin_px_;
};

core::Error Invalid(std::string field, std::string message) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, std::move(message), std::move(field));
}

}  // namespace

std::optional<core::Error> ValidatePolicyParams(const PolicyParams& p) {
  if (p.seed_samples < 1 || p.seed_samples > 10000) {
    return Invalid("seed_samples", "must be in [1, 10000]");
  }
  if (p.cem_iterations < 0 || p.cem_iterations > 20) {
    return Invalid("cem_iterations", "must be in [0, 20]");
  }
  if (p.cem_samples < 1 || p.cem_samples > 10000) {
    return Invalid("cem_samples", "must be in [1, 10000]");
  }
  if (!(p.cem_elite_fraction > 0.0 && p.cem_elite_fraction <= 1.0)) {
    return Invalid("cem_elite_fraction", "must be in (0, 1]");
  }
  if (!(p.friction_coefficient > 0.0 && p.friction_coefficient <= 10.0)) {
    return Invalid("friction_coefficient", "must be in (0, 10]");
  }
  if (!(p.depth_gradient_threshold_m > 0.0 && p.depth_gradient_threshold_m < 1.0)) {
    return Invalid("depth_gradient_threshold_m", "must be in (0, 1) m per pixel");
  }
  if (!(p.min_depth_offset_m >= 0.0 && p.max_depth_offset_m >= p.min_depth_offset_m &&
        p.max_depth_offset_m <= 0.2)) {
    return Invalid("max_depth_offset_m",
                   "need 0 <= min_depth_offset_m <= max_depth_offset_m <= 0.2");
  }
  if (!(p.min_contact_distance_m >= 0.0 && p.min_contact_distance_m < 1.0)) {
    return Invalid("min_contact_distance_m", "must be in [0, 1) m");
  }
  if (p.max_edge_pixels < 2 || p.max_edge_pixels > 20000) {
    return Invalid("max_edge_pixels", "must be in [2, 20000]");
  }
  if (!(p.training_fx_px > 0.0 && std::isfinite(p.training_fx_px))) {
    return Invalid("training_fx_px", "must be a finite number > 0");
  }
  if (p.source_crop_px < 8 || p.source_crop_px > 1024) {
    return Invalid("source_crop_px", "must be in [8, 1024]");
  }
  if (p.num_grasps < 1 || p.num_grasps > 1000) {
    return Invalid("num_grasps", "must be in [1, 1000]");
  }
  return std::nullopt;
}

core::Result<PolicyPlan> PlanGqcnnGrasps(const core::Scene& scene, const core::Camera& camera,
                                         const core::Gripper& gripper, const PolicyParams& params,
                                         const QualityFunction& quality) {
  if (auto error = ValidatePolicyParams(params)) return *error;
  if (scene.depth_filled_m.empty()) {
    return Invalid("depth", "the scene has no depth image");
  }
  const auto start = Clock::now();
  PolicyPlan plan;
  Planner planner(scene, camera, gripper, params);
  const std::vector<EdgePixel> edges = planner.FindEdges(&plan.edge_pixels);
  const std::vector<std::pair<int, int>> pairs = planner.AntipodalPairs(edges);
  plan.antipodal_pairs = static_cast<int>(pairs.size());

  // Seed candidates: distinct pairs drawn at random until seed_samples of them make a grasp the
  // gripper can take (Reachable), trying at most kMaxPairDrawsPerSeed times as many pairs (all of
  // them when there are few): a scene where almost nothing fits the jaws does not walk every pair.
  std::vector<std::size_t> order(pairs.size());
  std::iota(order.begin(), order.end(), 0);
  Rng draw(params.seed ^ 0x9e3779b97f4a7c15ULL);
  const std::size_t seeds = static_cast<std::size_t>(params.seed_samples);
  const std::size_t draws = std::min(order.size(), kMaxPairDrawsPerSeed * seeds);
  std::vector<Candidate> all;
  for (std::size_t i = 0; i < draws && all.size() < seeds; ++i) {
    std::swap(order[i], order[i + draw.Index(order.size() - i)]);
    Candidate c;
    if (planner.FromPair(edges[pairs[order[i]].first], edges[pairs[order[i]].second], &c)) {
      all.push_back(c);
    }
  }
  plan.timing.sample_ms = MsSince(start);
  if (all.empty()) {
    plan.timing.total_ms = MsSince(start);
    return plan;
  }

  const auto evaluate_start = Clock::now();
  auto evaluated = planner.Evaluate(all, 0, quality);
  if (!evaluated.ok()) return evaluated.error();
  std::vector<Candidate> population = all;
  for (int round = 0; round < params.cem_iterations; ++round) {
    std::vector<Candidate> next = planner.Refine(population);
    if (next.empty()) break;
    const std::size_t first = all.size();
    all.insert(all.end(), next.begin(), next.end());
    evaluated = planner.Evaluate(all, first, quality);
    if (!evaluated.ok()) return evaluated.error();
    population.assign(all.begin() + static_cast<std::ptrdiff_t>(first), all.end());
  }
  plan.evaluated = static_cast<int>(all.size());
  plan.timing.evaluate_ms = MsSince(evaluate_start);

  std::vector<std::size_t> ranked(all.size());
  std::iota(ranked.begin(), ranked.end(), 0);
  std::stable_sort(ranked.begin(), ranked.end(),
                   [&](std::size_t a, std::size_t b) { return Better(all[a], all[b]); });
  for (std::size_t index : ranked) {
    if (static_cast<int>(plan.grasps.size()) >= params.num_grasps) break;
    const Candidate& c = all[index];
    const core::Grasp grasp = planner.ToGrasp(c);
    const bool duplicate =
        std::any_of(plan.grasps.begin(), plan.grasps.end(), [&](const PolicyGrasp& k) {
          return std::hypot(k.grasp.center_u_px - grasp.center_u_px,
                            k.grasp.center_v_px - grasp.center_v_px) <
                     kDuplicateDistanceFraction * grasp.opening_px &&
                 AngleDistance(k.grasp.angle_rad, grasp.angle_rad) < kDuplicateAngleRad;
        });
    if (duplicate) continue;
    plan.grasps.push_back({grasp, c.pose, c.quality, c.contacts});
  }
  plan.timing.total_ms = MsSince(start);
  return plan;
}

}  // namespace softgrasp::gqcnn
