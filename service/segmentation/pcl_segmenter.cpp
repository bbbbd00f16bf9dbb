#include "service/segmentation/pcl_segmenter.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace softgrasp::segmentation {
namespace {

constexpr double kReferenceAreaPx = 640.0 * 480.0;

double DegToRad(double deg) { return deg * std::numbers::pi / 180.0; }

// Pixel counts are given at 640 x 480; this scales them to the image at hand (at least 1).
int ScalePx(int px_at_vga, double area_scale) {
  return std::max(1, static_cast<int>(std::lround(px_at_vga * area_scale)));
}

// Camera-frame point of pixel (u, v) at depth z.
Eigen::Vector3f BackProject(const core::Camera& camera, int u, int v, float z_m) {
  return {static_cast<float>((u - camera.cx) * z_m / camera.fx),
          static_cast<float>((v - camera.cy) * z_m / camera.fy), z_m};
}

// A plane n · p + d = 0 in C with |n| = 1.
struct PlaneC {
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
  float d = 0;
  float Distance(const Eigen::Vector3f& p) const { return normal.dot(p) + d; }
};

// The candidates' samples: a point cloud in C and, per point, the pixel it came from and whether
// its surface is steep (normal more than wall_steep_deg from the floor normal).
struct Samples {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
  std::vector<cv::Point> pixel;
  std::vector<bool> steep;
  std::size_t size() const { return pixel.size(); }
  Eigen::Vector3f At(std::size_t i) const { return (*cloud)[i].getVector3fMap(); }
};

Eigen::Vector3f FloorNormal(const core::Scene& scene) {
  return Eigen::Vector3f(static_cast<float>(scene.floor.n[0]), static_cast<float>(scene.floor.n[1]),
                         static_cast<float>(scene.floor.n[2]))
      .normalized();
}

// Marks the steep samples: surface normal from central differences of the filled depth.
void MarkSteep(const core::Scene& scene, const core::Camera& camera, const PclParams& params,
               Samples& samples) {
  const Eigen::Vector3f up = FloorNormal(scene);
  const cv::Mat1f& z = scene.depth_filled_m;
  const int w = z.cols, h = z.rows;
  const double cos_steep = std::cos(DegToRad(params.wall_steep_deg));
  constexpr int kNormalStepPx = 2;
  samples.steep.assign(samples.size(), false);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const cv::Point p = samples.pixel[i];
    const int u0 = std::max(0, p.x - kNormalStepPx), u1 = std::min(w - 1, p.x + kNormalStepPx);
    const int v0 = std::max(0, p.y - kNormalStepPx), v1 = std::min(h - 1, p.y + kNormalStepPx);
    const Eigen::Vector3f du =
        BackProject(camera, u1, p.y, z(p.y, u1)) - BackProject(camera, u0, p.y, z(p.y, u0));
    const Eigen::Vector3f dv =
        BackProject(camera, p.x, v1, z(v1, p.x)) - BackProject(camera, p.x, v0, z(v0, p.x));
    const Eigen::Vector3f normal = du.cross(dv);
    const float norm = normal.norm();
    samples.steep[i] = norm > 0 && std::abs(normal.dot(up)) / norm < cos_steep;
  }
}

// RANSAC (pcl::SACSegmentation, fixed seed) for one plane of `model` about `axis` among the
// samples `pool` (indices into samples.cloud). Returns the plane and its inliers, or nothing.
std::optional<std::pair<PlaneC, pcl::Indices>> FitPlane(
    const Samples& samples, const pcl::IndicesPtr& pool, pcl::SacModel model,
    const Eigen::Vector3f& axis, const PclParams& params, double inlier_m, int min_inliers) {
  if (static_cast<int>(pool->size()) < std::max(3, min_inliers)) return std::nullopt;
  pcl::SACSegmentation<pcl::PointXYZ> sac;  // not `random`: a fixed RNG seed, deterministic
  sac.setOptimizeCoefficients(true);
  sac.setModelType(model);
  sac.setMethodType(pcl::SAC_RANSAC);
  sac.setAxis(axis);
  sac.setEpsAngle(DegToRad(params.wall_angle_tolerance_deg));
  sac.setDistanceThreshold(inlier_m);
  sac.setMaxIterations(params.ransac_iterations);
  sac.setInputCloud(samples.cloud);
  sac.setIndices(pool);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coefficients;
  sac.segment(inliers, coefficients);
  if (static_cast<int>(inliers.indices.size()) < min_inliers || coefficients.values.size() != 4) {
    return std::nullopt;
  }
  PlaneC plane;
  plane.normal = {coefficients.values[0], coefficients.values[1], coefficients.values[2]};
  const float norm = plane.normal.norm();
  if (!(norm > 0)) return std::nullopt;
  plane.normal /= norm;
  plane.d = coefficients.values[3] / norm;
  return std::make_pair(plane, std::move(inliers.indices));
}

// A wall's inner face, oriented so that the inside of the support is in front (distance > 0),
// and the extent of its inliers: along the wall (horizontal) and along the floor normal.
struct Wall {
  PlaneC face;
  Eigen::Vector3f along = Eigen::Vector3f::UnitX();
  Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  float along_lo = 0, along_hi = 0, up_lo = 0, up_hi = 0;
  // Whether p is on the wall, its thickness or its rim (step 2b of the header): near the face and
  // within the inliers' extent grown by the outer band.
  bool Covers(const Eigen::Vector3f& p, const PclParams& params) const {
    const float s = face.Distance(p);
    if (s > params.wall_inlier_m || s < -params.wall_outer_band_m) return false;
    const auto m = static_cast<float>(params.wall_outer_band_m);
    const float t = along.dot(p), h = up.dot(p);
    return t >= along_lo - m && t <= along_hi + m && h >= up_lo - m && h <= up_hi + m;
  }
};

// Step 2b: the bin's walls among the steep samples; `inside` is a point inside the support (the
// centroid of its floor).
std::vector<Wall> FindWalls(const core::Scene& scene, const PclParams& params, double area_scale,
                            const Samples& samples, const Eigen::Vector3f& inside) {
  std::vector<Wall> walls;
  if (!params.remove_support) return walls;
  const Eigen::Vector3f up = FloorNormal(scene);
  const int stride2 = params.stride_px * params.stride_px;
  const int min_inliers = ScalePx(params.wall_min_px, area_scale) / stride2;
  std::vector<bool> used(samples.size(), false);
  for (int attempt = 0; attempt < params.max_walls; ++attempt) {
    pcl::IndicesPtr pool(new pcl::Indices);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (samples.steep[i] && !used[i]) pool->push_back(static_cast<pcl::index_t>(i));
    }
    auto fit = FitPlane(samples, pool, pcl::SACMODEL_PARALLEL_PLANE, up, params,
                        params.wall_inlier_m, min_inliers);
    if (!fit) break;
    Wall wall{fit->first};
    if (wall.face.Distance(inside) < 0) {
      wall.face.normal = -wall.face.normal;
      wall.face.d = -wall.face.d;
    }
    // Extent of the inliers.
    wall.along = up.cross(wall.face.normal).normalized();
    wall.up = up;
    wall.along_lo = wall.up_lo = std::numeric_limits<float>::max();
    wall.along_hi = wall.up_hi = -std::numeric_limits<float>::max();
    for (const auto idx : fit->second) {
      const Eigen::Vector3f p = samples.At(static_cast<std::size_t>(idx));
      const float t = wall.along.dot(p), height = up.dot(p);
      wall.along_lo = std::min(wall.along_lo, t);
      wall.along_hi = std::max(wall.along_hi, t);
      wall.up_lo = std::min(wall.up_lo, height);
      wall.up_hi = std::max(wall.up_hi, height);
      used[static_cast<std::size_t>(idx)] = true;
    }
    if (wall.along_hi - wall.along_lo < params.wall_min_length_m) continue;  // an object's side
    // A wall has nothing behind it but its own thickness and rim (the table outside the bin is
    // not a candidate); an object's long side has the object's top behind it.
    int behind = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Eigen::Vector3f p = samples.At(i);
      const float t = wall.along.dot(p), height = up.dot(p);
      if (wall.face.Distance(p) < -params.wall_outer_band_m && t >= wall.along_lo &&
          t <= wall.along_hi && height >= wall.up_lo && height <= wall.up_hi) {
        ++behind;
      }
    }
    if (behind > params.wall_max_behind_fraction * static_cast<double>(fit->second.size()))
      continue;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (wall.Covers(samples.At(i), params)) used[i] = true;
    }
    walls.push_back(wall);
  }
  return walls;
}

// Step 2c: a raised floor (a bin's bottom above the table that core::Preprocess fitted): when
// walls were found and their lowest inliers stand between min_height_m and support_max_height_m
// above the fitted floor, the floor is the most common height (1 mm bins) of the upward-facing
// candidates up to there, if support_min_px of them share it. Height above the fitted floor.
std::optional<double> RaisedFloorHeight(const core::Scene& scene, const PclParams& params,
                                        double area_scale, const Samples& samples,
                                        const std::vector<Wall>& walls) {
  if (walls.empty()) return std::nullopt;
  float bottom_up = std::numeric_limits<float>::max();
  for (const Wall& wall : walls) bottom_up = std::min(bottom_up, wall.up_lo);
  const double bottom_m = bottom_up + scene.floor.d;  // height = n · p + d
  if (bottom_m <= params.min_height_m || bottom_m > params.support_max_height_m) {
    return std::nullopt;
  }
  constexpr double kBinM = 0.001;
  const double top_m = bottom_m + params.min_height_m;
  std::vector<int> histogram(static_cast<std::size_t>(std::ceil(top_m / kBinM)) + 1, 0);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double height = scene.height_m(samples.pixel[i]);
    if (samples.steep[i] || height < 0 || height > top_m) continue;
    ++histogram[static_cast<std::size_t>(height / kBinM)];
  }
  const auto peak = std::max_element(histogram.begin(), histogram.end());
  const int stride2 = params.stride_px * params.stride_px;
  if (*peak < ScalePx(params.support_min_px, area_scale) / stride2) return std::nullopt;
  return (static_cast<double>(peak - histogram.begin()) + 0.5) * kBinM;
}

// solidity × size; see the header.
double InstanceScore(const std::vector<cv::Point>& pixels, double min_cluster_px_scaled) {
  if (pixels.empty()) return 0.0;
  const double area = static_cast<double>(pixels.size());
  std::vector<cv::Point> hull;
  cv::convexHull(pixels, hull);
  // Pixel centres: a hull of pixel centres misses half a pixel all round; add the perimeter / 2
  // + 1 so that a filled rectangle scores 1.
  const double hull_area = cv::contourArea(hull) + 0.5 * cv::arcLength(hull, true) + 1.0;
  const double solidity = std::clamp(area / hull_area, 0.0, 1.0);
  const double size = 1.0 - std::exp(-area / (3.0 * min_cluster_px_scaled));
  return solidity * size;
}

core::Error InvalidArgument(std::string message) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, std::move(message));
}

/// Refuses a scene whose images are not the camera's size, and parameters out of range.
std::optional<core::Error> CheckInputs(const core::Scene& scene, const core::Camera& camera,
                                       const PclParams& requested) {
  const cv::Size size(camera.width, camera.height);
  if (scene.depth_filled_m.size() != size || scene.height_m.size() != size ||
      (!scene.missing_mask.empty() && scene.missing_mask.size() != size)) {
    return InvalidArgument("SegmentPcl: the scene is " + std::to_string(scene.height_m.cols) + "x" +
                           std::to_string(scene.height_m.rows) + " but the camera " +
                           std::to_string(camera.width) + "x" + std::to_string(camera.height));
  }
  if (requested.stride_px < 1 || requested.stride_px > 16 || !(requested.cluster_tolerance_m > 0) ||
      requested.min_cluster_px < 1 || requested.max_cluster_px < requested.min_cluster_px ||
      !(requested.min_height_m > 0) || !(requested.min_height_lowest_m > 0) ||
      requested.min_height_lowest_m > requested.min_height_m ||
      !(requested.floor_noise_sigmas >= 0)) {
    return InvalidArgument(
        "SegmentPcl: stride_px must be 1..16, cluster_tolerance_m > 0, "
        "1 <= min_cluster_px <= max_cluster_px, "
        "0 < min_height_lowest_m <= min_height_m, floor_noise_sigmas >= 0");
  }
  return std::nullopt;
}

/// Step 1: the candidates (255 in `candidate`: measured pixels at least min_height_m above the
/// fitted floor), sampled every `stride_px` pixels.
Samples SampleCandidates(const core::Scene& scene, const core::Camera& camera,
                         const PclParams& params, cv::Mat1b& candidate) {
  const int w = candidate.cols, h = candidate.rows;
  const int stride = params.stride_px;
  Samples samples;
  for (int v = 0; v < h; ++v) {
    const float* z = scene.depth_filled_m[v];
    const float* height = scene.height_m[v];
    const std::uint8_t* missing = scene.missing_mask.empty() ? nullptr : scene.missing_mask[v];
    for (int u = 0; u < w; ++u) {
      if ((missing && missing[u]) || !std::isfinite(z[u]) || !(z[u] > 0) ||
          !(height[u] >= params.min_height_m)) {
        continue;
      }
      candidate(v, u) = 255;
      if (v % stride == 0 && u % stride == 0) {
        const Eigen::Vector3f p = BackProject(camera, u, v, z[u]);
        samples.cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
        samples.pixel.emplace_back(u, v);
      }
    }
  }
  return samples;
}

/// A point inside the support, to orient the walls: the centroid of the fitted floor's pixels
/// (every fourth row and column). Nothing when no pixel is on the floor.
std::optional<Eigen::Vector3f> PointInsideSupport(const core::Scene& scene,
                                                  const core::Camera& camera,
                                                  const PclParams& params) {
  Eigen::Vector3d inside = Eigen::Vector3d::Zero();
  int inside_count = 0;
  for (int v = 0; v < scene.height_m.rows; v += 4) {
    for (int u = 0; u < scene.height_m.cols; u += 4) {
      if (std::abs(scene.height_m(v, u)) < params.min_height_m) {
        inside += BackProject(camera, u, v, scene.depth_filled_m(v, u)).cast<double>();
        ++inside_count;
      }
    }
  }
  if (inside_count == 0) return std::nullopt;
  return (inside / inside_count).cast<float>();
}

/// Clears from `candidate` the support: pixels below the (raised) floor's margin and pixels the
/// walls cover. Returns the support's floor as measured: the pixels within the margin of
/// `floor_height_m`.
cv::Mat1b RemoveSupport(const core::Scene& scene, const core::Camera& camera,
                        const PclParams& params, const std::vector<Wall>& walls,
                        double floor_height_m, cv::Mat1b& candidate) {
  cv::Mat1b floor_px(candidate.size(), static_cast<std::uint8_t>(0));
  for (int v = 0; v < candidate.rows; ++v) {
    for (int u = 0; u < candidate.cols; ++u) {
      const float height = scene.height_m(v, u);
      const bool missing = !scene.missing_mask.empty() && scene.missing_mask(v, u);
      if (!missing && std::abs(height - floor_height_m) < params.min_height_m) floor_px(v, u) = 255;
      if (!candidate(v, u)) continue;
      bool support = height < floor_height_m + params.min_height_m;
      if (!support && !walls.empty()) {
        const Eigen::Vector3f p = BackProject(camera, u, v, scene.depth_filled_m(v, u));
        for (std::size_t k = 0; k < walls.size() && !support; ++k) {
          support = walls[k].Covers(p, params);
        }
      }
      if (support) candidate(v, u) = 0;
    }
  }
  return floor_px;
}

/// Where the floor spans in the image (the convex hull of its opened pixels): objects stand on
/// it, walls outside.
cv::Mat1b FloorHull(const cv::Mat1b& floor_px) {
  cv::Mat1b floor_hull(floor_px.size(), static_cast<std::uint8_t>(0));
  cv::Mat1b opened;
  cv::morphologyEx(floor_px, opened, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
  std::vector<cv::Point> points, hull;
  cv::findNonZero(opened, points);
  if (points.size() >= 3) {
    cv::convexHull(points, hull);
    cv::fillConvexPoly(floor_hull, hull, cv::Scalar(255));
  }
  return floor_hull;
}

/// Step 3: Euclidean clusters of the samples whose pixels are still candidates, each sample
/// labelled in `labels` with its cluster (1-based; at most 65535 clusters). Returns how many.
int ClusterSamples(const Samples& samples, const cv::Mat1b& candidate, const PclParams& params,
                   int min_px, int max_px, cv::Mat1w& labels) {
  const int stride2 = params.stride_px * params.stride_px;
  pcl::IndicesPtr kept(new pcl::Indices);
  for (std::size_t i = 0; i < samples.pixel.size(); ++i) {
    if (candidate(samples.pixel[i])) kept->push_back(static_cast<pcl::index_t>(i));
  }
  std::vector<pcl::PointIndices> clusters;
  if (!kept->empty()) {
    pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
    tree->setInputCloud(samples.cloud, kept);
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
    ec.setClusterTolerance(params.cluster_tolerance_m);
    // Loose bounds here; the pixel counts are checked after spreading.
    ec.setMinClusterSize(std::max(1, min_px / stride2 / 2));
    ec.setMaxClusterSize(std::max(1, max_px / stride2 * 2));
    ec.setSearchMethod(tree);
    ec.setInputCloud(samples.cloud);
    ec.setIndices(kept);
    ec.extract(clusters);
  }
  const int cluster_count =
      std::min<int>(static_cast<int>(clusters.size()), std::numeric_limits<std::uint16_t>::max());
  for (int c = 0; c < cluster_count; ++c) {
    for (const auto idx : clusters[static_cast<std::size_t>(c)].indices) {
      labels(samples.pixel[static_cast<std::size_t>(idx)]) = static_cast<std::uint16_t>(c + 1);
    }
  }
  return cluster_count;
}

/// Spread labels from the samples to the skipped candidate pixels: the nearest (in C) labelled
/// sample among the four grid corners around the pixel, within the cluster tolerance.
void SpreadLabels(const core::Scene& scene, const core::Camera& camera, const PclParams& params,
                  const cv::Mat1b& candidate, cv::Mat1w& labels) {
  const int w = labels.cols, h = labels.rows;
  const int stride = params.stride_px;
  if (stride <= 1) return;
  const int stride2 = stride * stride;
  const cv::Mat1w sampled = labels.clone();
  const float tol2 = static_cast<float>(params.cluster_tolerance_m * params.cluster_tolerance_m) *
                     static_cast<float>(stride2);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (!candidate(v, u) || (v % stride == 0 && u % stride == 0)) continue;
      const Eigen::Vector3f p = BackProject(camera, u, v, scene.depth_filled_m(v, u));
      const int gv = v - v % stride, gu = u - u % stride;
      float best = tol2;
      std::uint16_t best_label = 0;
      for (int dv = 0; dv <= stride; dv += stride) {
        for (int du = 0; du <= stride; du += stride) {
          const int sv = gv + dv, su = gu + du;
          if (sv >= h || su >= w || sampled(sv, su) == 0) continue;
          const float d2 =
              (BackProject(camera, su, sv, scene.depth_filled_m(sv, su)) - p).squaredNorm();
          if (d2 < best) {
            best = d2;
            best_label = sampled(sv, su);
          }
        }
      }
      labels(v, u) = best_label;
    }
  }
}

/// Clusters too small to keep become leftovers; clusters cut by the image border (the robot,
/// a shelf, a bin wall that was not found) and clusters mostly beside the floor (sloped bin
/// walls) become support.
void DropClusters(const PclParams& params, double area_scale, int min_px, int cluster_count,
                  const cv::Mat1b& floor_hull, cv::Mat1b& candidate, cv::Mat1w& labels) {
  const int w = labels.cols, h = labels.rows;
  std::vector<int> area(static_cast<std::size_t>(cluster_count) + 1, 0);
  std::vector<int> border(static_cast<std::size_t>(cluster_count) + 1, 0);
  std::vector<int> on_floor(static_cast<std::size_t>(cluster_count) + 1, 0);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      ++area[labels(v, u)];
      if (u == 0 || v == 0 || u == w - 1 || v == h - 1) ++border[labels(v, u)];
      if (floor_hull(v, u)) ++on_floor[labels(v, u)];
    }
  }
  const int border_px =
      std::max(1, static_cast<int>(std::lround(params.border_touch_px * std::sqrt(area_scale))));
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::uint16_t id = labels(v, u);
      if (!id) continue;
      if ((params.border_touch_px > 0 && border[id] >= border_px) ||
          on_floor[id] < params.min_over_floor_fraction * area[id]) {
        labels(v, u) = 0;
        candidate(v, u) = 0;
      } else if (area[id] < min_px) {
        labels(v, u) = 0;
      }
    }
  }
}

/// Step 4: leftovers: steep sides (whose pixels lie further apart than the tolerance), clusters
/// too small to keep and unspread pixels join the adjacent instance they slope down from.
void AttachLeftovers(const core::Scene& scene, const PclParams& params, double area_scale,
                     const cv::Mat1b& candidate, cv::Mat1w& labels) {
  const int w = labels.cols, h = labels.rows;
  const int attach_px = std::max(
      0, static_cast<int>(std::lround(params.attach_leftovers_px * std::sqrt(area_scale))));
  if (attach_px <= 0) return;
  std::vector<cv::Point> frontier, next;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (labels(v, u)) frontier.emplace_back(u, v);
    }
  }
  const std::array<cv::Point, 4> kSteps{cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1),
                                        cv::Point(0, -1)};
  const float climb_m = static_cast<float>(params.cluster_tolerance_m);
  for (int ring = 0; ring < attach_px && !frontier.empty(); ++ring) {
    next.clear();
    for (const cv::Point& p : frontier) {
      for (const cv::Point& step : kSteps) {
        const cv::Point q = p + step;
        if (q.x < 0 || q.y < 0 || q.x >= w || q.y >= h || !candidate(q) || labels(q)) continue;
        if (scene.height_m(q) > scene.height_m(p) + climb_m) continue;
        labels(q) = labels(p);
        next.push_back(q);
      }
    }
    frontier.swap(next);
  }
}

/// Each cluster's InstanceScore, by label; clusters above max_px pixels are dropped from
/// `labels` (and score 0).
std::vector<double> ScoreClusters(int cluster_count, int min_px, int max_px, cv::Mat1w& labels) {
  std::vector<std::vector<cv::Point>> pixels(static_cast<std::size_t>(cluster_count) + 1);
  for (int v = 0; v < labels.rows; ++v) {
    for (int u = 0; u < labels.cols; ++u) {
      if (labels(v, u)) pixels[labels(v, u)].emplace_back(u, v);
    }
  }
  std::vector<double> score(pixels.size(), 0.0);
  for (std::size_t id = 1; id < pixels.size(); ++id) {
    if (static_cast<int>(pixels[id].size()) > max_px) {
      for (const cv::Point& p : pixels[id]) labels(p) = 0;
      continue;
    }
    score[id] = InstanceScore(pixels[id], min_px);
  }
  return score;
}

}  // namespace

double FloorMarginM(const core::Scene& scene, const PclParams& params) {
  if (!(params.floor_noise_sigmas > 0)) return params.min_height_m;
  constexpr float kFloorBandM = 0.004f;  // core::PreprocessParams::floor_inlier_m
  constexpr std::size_t kMinFloorPx = 1000;
  std::vector<float> abs_height_m;
  for (int v = 0; v < scene.height_m.rows; v += 2) {
    const float* height = scene.height_m[v];
    const std::uint8_t* missing = scene.missing_mask.empty() ? nullptr : scene.missing_mask[v];
    for (int u = 0; u < scene.height_m.cols; u += 2) {
      if ((missing && missing[u]) || !(std::abs(height[u]) < kFloorBandM)) continue;
      abs_height_m.push_back(std::abs(height[u]));
    }
  }
  if (abs_height_m.size() < kMinFloorPx) return params.min_height_m;
  const auto middle = abs_height_m.begin() + static_cast<std::ptrdiff_t>(abs_height_m.size() / 2);
  std::nth_element(abs_height_m.begin(), middle, abs_height_m.end());
  const double noise_m = 1.4826 * *middle;  // sigma of a normal distribution from its MAD
  return std::clamp(params.floor_noise_sigmas * noise_m, params.min_height_lowest_m,
                    params.min_height_m);
}

core::Result<InstanceMasks> SegmentPcl(const core::Scene& scene, const core::Camera& camera,
                                       const PclParams& requested) {
  // RANSAC finding no plane is an expected outcome here (a scene without walls), not an error
  // for the service's log: PCL's console stays quiet.
  static const bool quiet = [] {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
    return true;
  }();
  (void)quiet;
  if (auto e = CheckInputs(scene, camera, requested)) return *e;
  // From here on min_height_m is this frame's floor margin.
  PclParams params = requested;
  params.min_height_m = FloorMarginM(scene, requested);
  const cv::Size size(camera.width, camera.height);
  const double area_scale = static_cast<double>(size.width) * size.height / kReferenceAreaPx;
  const int min_px = ScalePx(params.min_cluster_px, area_scale);
  const int max_px = ScalePx(params.max_cluster_px, area_scale);

  // 1. Candidates, sampled every `stride` pixels.
  cv::Mat1b candidate(size, static_cast<std::uint8_t>(0));
  Samples samples = SampleCandidates(scene, camera, params, candidate);

  // 2. Support beyond the fitted floor: walls and rim, then a raised floor (a bin's bottom).
  MarkSteep(scene, camera, params, samples);
  const std::optional<Eigen::Vector3f> inside = PointInsideSupport(scene, camera, params);
  const std::vector<Wall> walls =
      inside ? FindWalls(scene, params, area_scale, samples, *inside) : std::vector<Wall>{};
  const double floor_height_m =
      RaisedFloorHeight(scene, params, area_scale, samples, walls).value_or(0.0);
  const cv::Mat1b floor_hull =
      FloorHull(RemoveSupport(scene, camera, params, walls, floor_height_m, candidate));

  // 3. Euclidean clusters of the samples left, spread to the skipped pixels, then those that are
  // support or too small dropped.
  cv::Mat1w labels(size, static_cast<std::uint16_t>(0));
  const int cluster_count = ClusterSamples(samples, candidate, params, min_px, max_px, labels);
  SpreadLabels(scene, camera, params, candidate, labels);
  DropClusters(params, area_scale, min_px, cluster_count, floor_hull, candidate, labels);

  // 4. Leftovers join the adjacent instance they slope down from.
  AttachLeftovers(scene, params, area_scale, candidate, labels);

  // Scores, then dense ids by decreasing score; clusters outside the size range are dropped.
  const std::vector<double> score = ScoreClusters(cluster_count, min_px, max_px, labels);
  return Compact(labels, min_px,
                 [&](int old_id) { return score[static_cast<std::size_t>(old_id)]; });
}

}  // namespace softgrasp::segmentation
