#pragma once
/// The classical baseline segmenter, on PCL: support removal (the fitted floor, the bin's walls
/// and rim, a table) then Euclidean clustering of the remaining points.
/// The fallback when no segmentation model is loaded and the baseline of every evaluation.
/// Parameters, their published sources and measured accuracy: docs/segmentation.md.
///
/// Method (SegmentPcl):
///  1. Candidates: pixels that were measured (not scene.missing_mask) and stand at least the
///     floor margin above the fitted floor (scene.height_m); the floor, a table and anything
///     below them are support. The margin follows the frame's floor noise (FloorMarginM: a
///     robust sigma of the measured heights within 4 mm of the fitted floor). Candidates are
///     back-projected into the camera frame C (every stride_px-th row and column) into a
///     pcl::PointCloud<pcl::PointXYZ>, with each point's pixel.
///  2. Support beyond the fitted floor. Walls: candidates on steep surfaces (normal more than
///     wall_steep_deg from the floor normal) go to RANSAC (pcl::SACSegmentation,
///     SACMODEL_PARALLEL_PLANE about the floor normal: vertical planes). A plane is a wall when it
///     has at least wall_min_px inliers spanning at least wall_min_length_m horizontally; then
///     the candidates from wall_outer_band_m behind its face (the wall's thickness and rim) to
///     wall_inlier_m in front of it, within the inliers' extent, are support. Up to max_walls.
///     Raised floor: core::Preprocess fits the deepest plane, which in a bin on a table is the
///     table around the bin; when the walls' lowest points stand above the fitted floor, the
///     bin's bottom is the most common height of the upward-facing candidates below them, and
///     candidates less than min_height_m above it are support.
///  3. pcl::EuclideanClusterExtraction (pcl::search::KdTree) of what is left. Skipped pixels
///     (stride_px > 1) take the label of the nearest clustered sample of their grid cell within
///     the cluster tolerance. Clusters cut by the image border (border_touch_px) or lying mostly
///     beside the floor (min_over_floor_fraction: sloped walls) are support; clusters smaller
///     than min_cluster_px are dropped.
///  4. Leftover candidate pixels (steep sides, dropped small clusters) join an adjacent instance
///     they do not rise above, within attach_leftovers_px (a breadth-first growth in the image).
///     Instances larger than max_cluster_px are dropped.
///
/// Score of an instance (PCL gives no confidence): solidity × size, both in [0, 1]:
/// solidity = area / area of the mask's convex hull in the image (merged neighbours, fragments and
/// wall leftovers are concave or ragged), size = 1 - exp(-area / (3 · min_cluster_px)) (the
/// smallest kept clusters score about 0.28 × solidity; objects of several thousand pixels near
/// 1 × solidity), with areas in pixels scaled to 640 x 480.

#include "service/core/depth.h"
#include "service/core/preprocess.h"
#include "service/core/status.h"
#include "service/segmentation/instances.h"

namespace softgrasp::segmentation {

/// Pixel counts are given for a 640 x 480 image and scaled with the image area for other sizes.
struct PclParams {
  /// Points lower than the floor margin above the fitted floor are support (floor noise, thin
  /// debris). The margin is floor_noise_sigmas x this frame's floor noise, clamped to
  /// [min_height_lowest_m, min_height_m]: 5.8-6 mm on the simulated sensors (noise 1.5 mm) and
  /// PhoXi-like frames, 2.5 mm on a Primesense frame whose table is flat to 0.3 mm, where 6 mm
  /// cut off objects' flat rims. floor_noise_sigmas = 0: min_height_m on every frame.
  double min_height_m = 0.006;
  double min_height_lowest_m = 0.0025;
  double floor_noise_sigmas = 4.0;
  /// EuclideanClusterExtraction tolerance. SD Mask R-CNN's baseline uses 0.004 m (Primesense)
  /// and 0.002 m (PhoXi); 0.003 m separates more touching objects in dense simulated bins and
  /// does as well on the real frames (docs/segmentation.md).
  double cluster_tolerance_m = 0.003;
  /// Clusters with fewer pixels are dropped (Primesense baseline: 450 at 640x480).
  int min_cluster_px = 450;
  /// Clusters with more pixels are dropped (baseline: 1e6, i.e. no limit at 640 x 480).
  int max_cluster_px = 1000000;
  /// Cloud sampling: every stride_px-th row and column (1 = every pixel). Labels are spread back
  /// to every pixel.
  int stride_px = 1;
  /// Step 4: candidate pixels left without an instance (steep sides, clusters below
  /// min_cluster_px) join an adjacent instance they do not rise above (by more than the cluster
  /// tolerance), up to this many pixels away (at 640 x 480; scaled with the image width). 0 = off.
  int attach_leftovers_px = 12;

  /// Clusters with at least this many pixels in the image's outermost rows and columns are cut
  /// by the field of view: scene structure (a robot's fingers, a shelf), not objects in a bin or
  /// on a table; dropped (pixels at 640 x 480, scaled with the image width). 0 = keep them.
  int border_touch_px = 20;

  /// Clusters with less than this fraction of their pixels over the floor (inside the convex
  /// hull of the floor's pixels in the image) are support: sloped bin walls, things beside the
  /// bin. 0 = keep them.
  double min_over_floor_fraction = 0.5;

  /// Support beyond the fitted floor (step 2): walls, rim and a raised floor. false = only the
  /// fitted floor is support.
  bool remove_support = true;
  /// A raised floor (a bin's bottom above the table that core::Preprocess fitted) is looked for
  /// when walls were found whose lowest points stand between min_height_m and
  /// support_max_height_m above the fitted floor: the most common height of the upward-facing
  /// candidates below that, shared by at least support_min_px of them (at 640 x 480).
  int support_min_px = 1000;
  double support_max_height_m = 0.05;
  /// A candidate whose surface normal is more than this from the floor normal is steep.
  double wall_steep_deg = 60.0;
  /// RANSAC inlier distance to a wall plane, and how far in front of it points are removed.
  double wall_inlier_m = 0.005;
  /// A wall plane's normal may deviate this much from horizontal.
  double wall_angle_tolerance_deg = 10.0;
  /// Least inliers of a wall (pixels at 640 x 480).
  int wall_min_px = 2000;
  /// Least horizontal extent of a wall's inliers along the wall, metres.
  double wall_min_length_m = 0.15;
  /// Behind a wall's inner face (away from the floor's centre) candidates this close are the
  /// wall's thickness and rim, and support. The simulated bin's wall is 0.01 m thick.
  double wall_outer_band_m = 0.03;
  /// A plane with more candidates behind it (beyond the outer band, within the inliers' extent)
  /// than this fraction of its inliers is an object's side, not a wall.
  double wall_max_behind_fraction = 0.1;
  int max_walls = 6;
  int ransac_iterations = 300;
};

/// The floor margin SegmentPcl uses on this scene (metres; see PclParams::min_height_m): the
/// floor noise is 1.4826 x the median absolute height of the measured pixels within 4 mm of the
/// fitted floor (every second row and column); min_height_m when fewer than 1,000 such pixels.
double FloorMarginM(const core::Scene& scene, const PclParams& params);

/// Segments a preprocessed scene (core::Preprocess) seen by `camera`. Missing input pixels
/// (scene.missing_mask) belong to no instance. Instances are ordered by decreasing score (see
/// the file comment). Deterministic. Errors: kInvalidArgument when the scene and camera sizes
/// differ or a parameter is out of range. A scene with no objects gives zero instances.
core::Result<InstanceMasks> SegmentPcl(const core::Scene& scene, const core::Camera& camera,
                                       const PclParams& params = {});

}  // namespace softgrasp::segmentation
