// Depth preprocessing: missing-pixel filling, floor plane fit, heights above the floor.
// Formulas and parameters: docs/fge.md, section "Preprocessing".
#include "service/core/preprocess.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace softgrasp::core {
namespace {

constexpr double kMinValidFraction = 0.01;  // fewer valid pixels than this: kUnprocessable
constexpr int kMinValidPixels = 16;
constexpr int kFillTargetRows = 120;  // inpainting runs at about this many rows
constexpr int kMaxFillDownscale = 4;
constexpr float kInpaintUnitsPerM = 1e4f;   // Telea is tuned for large values: use 0.1 mm units
constexpr int kSampleTargetRows = 120;      // floor fit samples about this many rows of pixels
constexpr double kBelowFloorWeight = 10.0;  // RANSAC score = inliers - 10 * points below the plane
// A best plane with at least this many scored points behind it (and this fraction of them) is
// searched past: new hypotheses are drawn among the points behind it, at most this many rounds.
constexpr int kMinBelowToSearchDeeper = 10;
constexpr double kMinBelowFractionToSearchDeeper = 0.002;
constexpr int kMaxDeeperRounds = 4;
constexpr double kMinCameraToFloorM = 0.01;  // a "floor" through the camera is degenerate
constexpr double kMinFloorNormalZ = 0.5;     // floors seen at > 60 deg from the optical axis: no
constexpr int kRefineRounds = 2;
constexpr std::size_t kMaxScoringPoints = 5000;  // RANSAC scores hypotheses on this many points
// A surface nearer than min_depth_m excludes what is joined to it: neighbours whose heights
// differ by at most this (FgeParams::seam_step_m's default) and that stand this high above the
// floor (PclParams::min_height_m's default), so the table it rests on is not joined.
constexpr float kJoinedStepM = 0.010f;
constexpr float kJoinedAboveFloorM = 0.006f;

// 255 where the depth is NaN, infinite or not positive.
cv::Mat1b MissingMask(const cv::Mat1f& depth_m) {
  const cv::Mat1b valid = (depth_m > 0.0f) & (depth_m < std::numeric_limits<float>::max());
  return valid == 0;
}

int FillDownscale(const cv::Size& size) {
  return std::clamp(std::min(size.width, size.height) / kFillTargetRows, 1, kMaxFillDownscale);
}

// Block sums of the valid depths of one image row (blocks of k pixels) and their counts.
void AccumulateValid(const float* __restrict z, const std::uint8_t* __restrict missing, int n,
                     int k, float* __restrict sum, float* __restrict count) {
  for (int u = 0; u < n; ++u) {
    sum[u / k] += missing[u] ? 0.0f : z[u];  // z may be NaN where missing
    count[u / k] += missing[u] ? 0.0f : 1.0f;
  }
}

// Missing pixels get the value of a Telea inpainting computed at 1/k resolution (k from
// FillDownscale) and upsampled bilinearly. Valid pixels keep their measured depth.
cv::Mat1f FillMissing(const cv::Mat1f& depth_m, const cv::Mat1b& missing,
                      double inpaint_radius_px) {
  cv::Mat1f filled = depth_m.clone();
  if (cv::countNonZero(missing) == 0) return filled;

  const int k = FillDownscale(depth_m.size());
  const cv::Size small_size((depth_m.cols + k - 1) / k, (depth_m.rows + k - 1) / k);
  // Mean of the valid depths of each k x k block (in inpainting units).
  cv::Mat1f depth_sum = cv::Mat1f::zeros(small_size), valid_count = cv::Mat1f::zeros(small_size);
  for (int v = 0; v < depth_m.rows; ++v) {
    AccumulateValid(depth_m.ptr<float>(v), missing.ptr<std::uint8_t>(v), depth_m.cols, k,
                    depth_sum.ptr<float>(v / k), valid_count.ptr<float>(v / k));
  }
  cv::Mat1b missing_small = valid_count == 0.0f;
  cv::Mat1f depth_small;
  cv::divide(depth_sum, cv::max(valid_count, 1.0f), depth_small, kInpaintUnitsPerM);

  cv::Mat1f inpainted_small;
  const double radius_small = std::max(1.0, inpaint_radius_px / k);
  cv::inpaint(depth_small, missing_small, inpainted_small, radius_small, cv::INPAINT_TELEA);
  inpainted_small *= 1.0f / kInpaintUnitsPerM;
  cv::Mat1f inpainted;
  cv::resize(inpainted_small, inpainted, cv::Size(small_size.width * k, small_size.height * k), 0,
             0, cv::INTER_LINEAR);
  inpainted(cv::Rect(0, 0, depth_m.cols, depth_m.rows)).copyTo(filled, missing);
  return filled;
}

// Valid pixels on a regular grid, back-projected (structure of arrays: vectorisable scoring).
struct SampledPoints {
  std::vector<float> x, y, z;
  std::vector<int> deeper_half;  // indices with depth >= median: where floor samples come from
  std::vector<int> deepest;      // indices with depth >= the 95th percentile
  std::size_t size() const { return z.size(); }
  Eigen::Vector3d Point(std::size_t i) const { return {x[i], y[i], z[i]}; }
};

SampledPoints SamplePoints(const cv::Mat1f& depth_m, const cv::Mat1b& missing,
                           const Camera& camera) {
  const int stride = std::max(1, std::min(depth_m.rows, depth_m.cols) / kSampleTargetRows);
  SampledPoints out;
  for (int v = stride / 2; v < depth_m.rows; v += stride) {
    const auto ry = static_cast<float>((v - camera.cy) / camera.fy);
    for (int u = stride / 2; u < depth_m.cols; u += stride) {
      if (missing(v, u) != 0) continue;
      const float z = depth_m(v, u);
      out.x.push_back(static_cast<float>((u - camera.cx) / camera.fx) * z);
      out.y.push_back(ry * z);
      out.z.push_back(z);
    }
  }
  if (out.z.empty()) return out;
  std::vector<float> sorted = out.z;
  auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), mid, sorted.end());
  for (std::size_t i = 0; i < out.z.size(); ++i) {
    if (out.z[i] >= *mid) out.deeper_half.push_back(static_cast<int>(i));
  }
  auto p95 = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() * 19 / 20);
  std::nth_element(sorted.begin(), p95, sorted.end());
  for (std::size_t i = 0; i < out.z.size(); ++i) {
    if (out.z[i] >= *p95) out.deepest.push_back(static_cast<int>(i));
  }
  return out;
}

// Every step-th point, for scoring hypotheses quickly.
SampledPoints Thin(const SampledPoints& points, std::size_t max_points) {
  const std::size_t step = std::max<std::size_t>(1, (points.size() + max_points - 1) / max_points);
  SampledPoints out;
  for (std::size_t i = 0; i < points.size(); i += step) {
    out.x.push_back(points.x[i]);
    out.y.push_back(points.y[i]);
    out.z.push_back(points.z[i]);
  }
  return out;
}

// Orients n towards the camera (camera origin on the positive side: d > 0).
std::optional<Plane> MakePlane(const Eigen::Vector3d& normal, const Eigen::Vector3d& point) {
  const double norm = normal.norm();
  if (!(norm > 1e-12)) return std::nullopt;
  Eigen::Vector3d n = normal / norm;
  double d = -n.dot(point);
  if (d < 0) {
    n = -n;
    d = -d;
  }
  if (d < kMinCameraToFloorM || std::abs(n.z()) < kMinFloorNormalZ) return std::nullopt;
  return Plane{{n.x(), n.y(), n.z()}, d};
}

struct PlaneScore {
  int inliers = 0;
  int below = 0;  // points farther from the camera than the plane (beyond the inlier band)
  double value() const { return inliers - kBelowFloorWeight * below; }
};

PlaneScore ScorePlane(const Plane& plane, const SampledPoints& p, float inlier_m) {
  const auto nx = static_cast<float>(plane.n[0]), ny = static_cast<float>(plane.n[1]);
  const auto nz = static_cast<float>(plane.n[2]), d = static_cast<float>(plane.d);
  const float* __restrict x = p.x.data();
  const float* __restrict y = p.y.data();
  const float* __restrict z = p.z.data();
  const int n = static_cast<int>(p.size());
  int inliers = 0, below = 0;
  for (int i = 0; i < n; ++i) {
    const float dist = nx * x[i] + ny * y[i] + nz * z[i] + d;
    inliers += (dist <= inlier_m) & (dist >= -inlier_m);
    below += dist < -inlier_m;
  }
  return {inliers, below};
}

std::optional<Plane> PlaneThrough(const SampledPoints& p, int i, int j, int k) {
  const Eigen::Vector3d a = p.Point(static_cast<std::size_t>(i));
  const Eigen::Vector3d b = p.Point(static_cast<std::size_t>(j));
  const Eigen::Vector3d c = p.Point(static_cast<std::size_t>(k));
  return MakePlane((b - a).cross(c - a), a);
}

// Indices of `points` farther than `inlier_m` behind `plane`.
std::vector<int> PointsBehind(const Plane& plane, const SampledPoints& points, double inlier_m) {
  const Eigen::Vector3d n(plane.n[0], plane.n[1], plane.n[2]);
  std::vector<int> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (n.dot(points.Point(i)) + plane.d < -inlier_m) out.push_back(static_cast<int>(i));
  }
  return out;
}

// Hypotheses from the deeper half, then from the deepest 5 %, scored on at most
// kMaxScoringPoints of all points. In a dense bin the floor shows in a few small patches: three
// points drawn from the deeper half rarely all lie on it, while a plane tilted through the pile
// collects many inliers. The deepest points are mostly floor. When the best plane still has points
// behind it, up to kMaxDeeperRounds more rounds draw hypotheses among those points.
std::optional<Plane> RansacFloor(const SampledPoints& points, const PreprocessParams& params) {
  if (points.deeper_half.size() < 3) return std::nullopt;
  const SampledPoints scoring = Thin(points, kMaxScoringPoints);
  std::mt19937 rng(params.ransac_seed);
  const auto inlier_m = static_cast<float>(params.floor_inlier_m);
  std::optional<Plane> best;
  PlaneScore best_score;
  const auto draw_from = [&](const std::vector<int>& pool) {
    std::uniform_int_distribution<std::size_t> pick(0, pool.size() - 1);
    for (int it = 0; it < params.ransac_iterations; ++it) {
      const std::size_t a = pick(rng), b = pick(rng), c = pick(rng);
      if (a == b || b == c || a == c) continue;
      const auto plane = PlaneThrough(points, pool[a], pool[b], pool[c]);
      if (!plane) continue;
      const PlaneScore score = ScorePlane(*plane, scoring, inlier_m);
      if (!best || score.value() > best_score.value() ||
          (score.value() == best_score.value() && score.inliers > best_score.inliers)) {
        best = plane;
        best_score = score;
      }
    }
  };
  draw_from(points.deeper_half);
  if (points.deepest.size() >= 3) draw_from(points.deepest);
  const auto min_below =
      std::max<double>(kMinBelowToSearchDeeper, kMinBelowFractionToSearchDeeper * scoring.size());
  for (int round = 0; round < kMaxDeeperRounds && best && best_score.below >= min_below; ++round) {
    const std::vector<int> behind = PointsBehind(*best, points, inlier_m);
    if (behind.size() < 3) break;
    const PlaneScore before = best_score;
    draw_from(behind);
    if (best_score.value() <= before.value()) break;  // nothing better behind it
  }
  if (!best || best_score.inliers < 3) return std::nullopt;
  return best;
}

// Least-squares plane (centroid + smallest principal axis) over the inliers of `plane`.
std::optional<Plane> RefineFloor(const Plane& plane, const SampledPoints& points, double inlier_m) {
  const Eigen::Vector3d n(plane.n[0], plane.n[1], plane.n[2]);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  int count = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = points.Point(i);
    if (std::abs(n.dot(p) + plane.d) > inlier_m) continue;
    sum += p;
    outer += p * p.transpose();
    ++count;
  }
  if (count < 3) return std::nullopt;
  const Eigen::Vector3d centroid = sum / count;
  const Eigen::Matrix3d covariance = outer / count - centroid * centroid.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  if (solver.info() != Eigen::Success) return std::nullopt;
  return MakePlane(solver.eigenvectors().col(0), centroid);  // eigenvalues ascend
}

std::optional<Plane> FitFloor(const cv::Mat1f& depth_m, const cv::Mat1b& missing,
                              const Camera& camera, const PreprocessParams& params) {
  const SampledPoints points = SamplePoints(depth_m, missing, camera);
  std::optional<Plane> floor = RansacFloor(points, params);
  for (int round = 0; floor && round < kRefineRounds; ++round) {
    const auto refined = RefineFloor(*floor, points, params.floor_inlier_m);
    if (!refined) break;
    floor = refined;
  }
  return floor;
}

void HeightRow(const float* __restrict z, const float* __restrict column_term, float row_term,
               float d, int n, float* __restrict height) {
  for (int u = 0; u < n; ++u) height[u] = z[u] * (column_term[u] + row_term) + d;
}

// height = n . p + d with p = z * ((u - cx) / fx, (v - cy) / fy, 1).
cv::Mat1f HeightAboveFloor(const cv::Mat1f& depth_m, const Camera& camera, const Plane& floor) {
  std::vector<float> column_term(static_cast<std::size_t>(depth_m.cols));
  for (int u = 0; u < depth_m.cols; ++u) {
    column_term[static_cast<std::size_t>(u)] =
        static_cast<float>(floor.n[0] * (u - camera.cx) / camera.fx);
  }
  cv::Mat1f height(depth_m.size());
  const auto d = static_cast<float>(floor.d);
  for (int v = 0; v < depth_m.rows; ++v) {
    const auto row_term = static_cast<float>(floor.n[1] * (v - camera.cy) / camera.fy + floor.n[2]);
    HeightRow(depth_m.ptr<float>(v), column_term.data(), row_term, d, depth_m.cols,
              height.ptr<float>(v));
  }
  return height;
}

std::optional<Error> CheckInputs(const DepthImage& depth, const Camera& camera,
                                 const PreprocessParams& params) {
  if (depth.empty()) return MakeError(ErrorCode::kInvalidArgument, "depth image is empty", "depth");
  const bool camera_ok = std::isfinite(camera.fx) && std::isfinite(camera.fy) && camera.fx > 0 &&
                         camera.fy > 0 && std::isfinite(camera.cx) && std::isfinite(camera.cy);
  if (!camera_ok) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "camera intrinsics must be finite with fx > 0 and fy > 0", "camera");
  }
  if (params.ransac_iterations < 1) {
    return MakeError(ErrorCode::kInvalidArgument, "ransac_iterations must be >= 1",
                     "ransac_iterations");
  }
  if (!(params.floor_inlier_m > 0)) {
    return MakeError(ErrorCode::kInvalidArgument, "floor_inlier_m must be > 0", "floor_inlier_m");
  }
  if (!(params.inpaint_radius_px >= 0)) {
    return MakeError(ErrorCode::kInvalidArgument, "inpaint_radius_px must be >= 0",
                     "inpaint_radius_px");
  }
  return std::nullopt;
}

// Surfaces nearer than min_depth_m, and every surface above the floor joined to them without a
// height step of kJoinedStepM: a wrist camera's fingers reach down towards the table, so their
// tips (and the mixed pixels along their outline) lie deeper than the depth that cuts their base.
cv::Mat1b NearAndJoined(const Scene& scene, double min_depth_m) {
  const cv::Mat1b near = scene.depth_filled_m < static_cast<float>(min_depth_m);
  const cv::Mat1b above_floor = scene.height_m > kJoinedAboveFloorM;
  // floodFill's mask is 1 pixel larger on each side; non-zero stops the fill.
  constexpr unsigned char kBlocked = 1, kJoined = 2;
  cv::Mat1b fill(near.rows + 2, near.cols + 2, kBlocked);
  fill(cv::Rect(1, 1, near.cols, near.rows)).setTo(0, above_floor);
  cv::Mat heights = scene.height_m;  // only read: FLOODFILL_MASK_ONLY
  for (int v = 0; v < near.rows; ++v) {
    const unsigned char* near_row = near.ptr<unsigned char>(v);
    const unsigned char* fill_row = fill.ptr<unsigned char>(v + 1) + 1;
    for (int u = 0; u < near.cols; ++u) {
      if (near_row[u] == 0 || fill_row[u] != 0) continue;  // not near, table, or filled already
      cv::floodFill(heights, fill, cv::Point(u, v), cv::Scalar(), nullptr, cv::Scalar(kJoinedStepM),
                    cv::Scalar(kJoinedStepM), 4 | cv::FLOODFILL_MASK_ONLY | (kJoined << 8));
    }
  }
  return near | (fill(cv::Rect(1, 1, near.cols, near.rows)) == kJoined);
}

}  // namespace

Result<Scene> Preprocess(const DepthImage& depth, const Camera& camera,
                         const PreprocessParams& params) {
  if (auto error = CheckInputs(depth, camera, params)) return *error;

  Scene scene;
  scene.missing_mask = MissingMask(depth.depth_m);
  const int total = depth.width() * depth.height();
  const int valid = total - cv::countNonZero(scene.missing_mask);
  scene.missing_fraction = 1.0 - static_cast<double>(valid) / total;
  if (valid < std::max(kMinValidPixels, static_cast<int>(kMinValidFraction * total))) {
    return MakeError(ErrorCode::kUnprocessable,
                     "only " + std::to_string(valid) + " of " + std::to_string(total) +
                         " depth pixels are valid; need at least 1 %",
                     "depth");
  }
  const auto floor = FitFloor(depth.depth_m, scene.missing_mask, camera, params);
  if (!floor) {
    return MakeError(ErrorCode::kUnprocessable,
                     "no floor plane found (need a table or bin bottom facing the camera)",
                     "depth");
  }
  scene.floor = *floor;
  scene.depth_filled_m = FillMissing(depth.depth_m, scene.missing_mask, params.inpaint_radius_px);
  scene.height_m = HeightAboveFloor(scene.depth_filled_m, camera, scene.floor);
  return scene;
}

void RestrictContact(Scene& scene, const cv::Mat1b& region_of_interest, double min_depth_m) {
  const cv::Size size = scene.depth_filled_m.size();
  if (!region_of_interest.empty() && region_of_interest.size() != size) {
    throw std::invalid_argument("RestrictContact: the region of interest is " +
                                std::to_string(region_of_interest.cols) + "x" +
                                std::to_string(region_of_interest.rows) + ", the scene " +
                                std::to_string(size.width) + "x" + std::to_string(size.height));
  }
  if (!(std::isfinite(min_depth_m) && min_depth_m >= 0)) {
    throw std::invalid_argument("RestrictContact: min_depth_m must be finite and >= 0");
  }
  cv::Mat1b allowed(size, 255);
  if (!region_of_interest.empty()) allowed.setTo(0, region_of_interest == 0);
  if (min_depth_m > 0) allowed.setTo(0, NearAndJoined(scene, min_depth_m));
  if (!scene.contact_allowed.empty()) allowed &= scene.contact_allowed;
  scene.contact_allowed = allowed;
}

}  // namespace softgrasp::core
