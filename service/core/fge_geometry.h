#pragma once
/// Internal to softgrasp_core: geometry shared by the fast and the reference FGE and by the grasp
/// search (slices, template rasterisation, seams, poses). See docs/fge.md for the formulas.

#include <algorithm>
#include <array>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "service/core/contact_check.h"
#include "service/core/fge.h"

namespace softgrasp::core::fge_detail {

/// A_t must cover at least this fraction of the closing region (T_t) for a candidate.
inline constexpr double kMinContactFraction = 0.05;
/// Slip: the surface above the fingertips inside the closing region may cover at most this many
/// times A_t (the thesis drops candidates whose contact and collision areas differ too much: a
/// surface that widens below the contact height pushes the fingers up).
inline constexpr int kSlipRatioNum = 3;
inline constexpr int kSlipRatioDen = 2;
inline constexpr double kMaxSlipRatio = static_cast<double>(kSlipRatioNum) / kSlipRatioDen;
/// Graspability blur: sigma = kBlurSigmaPerOpening * opening (pixels at the slice).
inline constexpr double kBlurSigmaPerOpening = 0.5;
/// The fast path works at 1/s resolution with s chosen so fingers stay this thick (pixels).
inline constexpr double kMinFingerThicknessWorkPx = 2.5;
inline constexpr int kMaxWorkScale = 4;
/// The top slice sits this far below the N-th highest surface point (N = min_object_area_px).
inline constexpr double kTopSliceMarginM = 0.001;
/// Each (angle, slice) map runs at most this many contact checks (each walks the whole closing
/// region); shared by classic and stiffness-aware FGE.
inline constexpr int kMaxContactChecksPerMap = 64;

/// One contact height: the fingers close on the surface above `contact_height_m`; their tips
/// reach down to `tip_height_m` = contact height - grip depth; the palm is finger_length above the
/// tips, and nothing under the gripper footprint may reach it. Heights above the floor.
struct Slice {
  int index = 0;  ///< 0 = highest
  double contact_height_m = 0;
  double tip_height_m = 0;
  double palm_height_m = 0;
};

/// The templates rasterised on a pixel grid aligned with the closing axis (pixel-centre rule):
/// offsets (a along the closing axis, b across) with |a| <= opening/2 and |b| <= width/2 form the
/// closing region T_t; opening/2 < |a| <= opening/2 + thickness, |b| <= width/2 the fingers T_c.
struct TemplateBoxes {
  int contact_half_len = 0;  ///< A: T_t spans a in [-A, A]
  int finger_outer = 0;      ///< F: a finger spans |a| in [A + 1, F]
  int half_width = 0;        ///< B: both span b in [-B, B]
  int ContactArea() const { return (2 * contact_half_len + 1) * (2 * half_width + 1); }
};

/// Throws std::invalid_argument on a non-physical gripper, bad FGE parameters or intrinsics.
void CheckInputs(const Camera& camera, const Gripper& gripper, const FgeParams& params);

/// Camera distance of the floor along the optical axis: -d / n_z (NaN if it does not cross it).
double FloorDepthOnAxisM(const Plane& floor);

/// Pixels per metre for a surface at `height_m` above the floor: fx / (floor depth on axis - h).
double PxPerMetre(const Plane& floor, const Camera& camera, double height_m);

GripperPx GripperAtScale(const Gripper& gripper, double px_per_m);
TemplateBoxes RasteriseTemplates(const GripperPx& gripper_px);

/// Smallest A_t for a candidate: max(1, ceil(kMinContactFraction * area of T_t)).
int MinContactCount(int contact_area_px);
double BlurSigmaPx(const GripperPx& gripper_px);
/// Odd Gaussian kernel size covering +-3 sigma.
int GaussianKernelSize(double sigma_px);

/// The slices the multi-height search visits and the surfaces it may grasp.
struct SliceSearch {
  /// Highest first, down to the floor (the planners search them num_height_steps at a time,
  /// SliceBatches); empty when nothing is tall enough.
  std::vector<Slice> slices;
  /// 255 where a surface may be a contact surface (part of a free object); elsewhere surfaces
  /// are obstacles only (bin walls, robot parts, objects cut by the image border).
  cv::Mat1b graspable;
};

/// Slices the multi-height search visits, highest first, and the graspable surfaces.
/// The top slice h0 lies kTopSliceMarginM below the min_object_area_px-th highest pixel of the
/// free objects: connected regions above a level that do not touch the image border, at the
/// lowest level (floor_clearance + grip_depth, + k height steps) where such objects exist. So
/// bin walls, robot parts reaching into the image and objects cut by the frame do not set it.
/// Graspable are the pixels of regions that stand free at some level (a pile joined to a bin
/// wall low down is graspable where it rises free of it), never the wall itself.
/// If there is no free object at any level, all pixels count and all are graspable. Slices step
/// down by height_step_m; a step that would put the fingertips under floor_clearance_m is replaced
/// by a last slice with the tips exactly at the clearance (low objects keep a grasp at their base).
/// Only surfaces in `contact_allowed` (Scene::contact_allowed; empty = all) may be graspable or
/// set the top slice.
/// `floor_px_per_m`: PxPerMetre(floor, camera, 0), the image scale on the floor.
SliceSearch SearchSlices(const cv::Mat1f& height_m, const cv::Mat1b& contact_allowed,
                         double floor_px_per_m, const Gripper& gripper, const FgeParams& params);

/// What SearchSlices finds on a height image before it looks at the contact mask: the free smooth
/// pieces and the free-object pixels at each level (full-image passes and connected components).
/// A planner that searches the same heights for several contact masks (the deformability
/// planner's targets) makes it once. Levels are computed when first asked for, so an instance
/// is not thread-safe; it refers to `height_m`, which must outlive it unchanged.
class FreeSpace {
 public:
  /// `params`: min_object_area_px, floor_clearance_m, grip_depth_m and height_step_m are used.
  FreeSpace(const cv::Mat1f& height_m, double floor_px_per_m, const FgeParams& params);

  const cv::Mat1f& height_m() const { return height_m_; }
  /// Whether SearchSlices with these params asks for the same pieces and levels.
  bool Serves(const FgeParams& params) const;
  /// FreeSmoothPieces at the lowest level (not yet limited to a contact mask).
  const cv::Mat1b& smooth_pieces() const { return smooth_pieces_; }
  /// Level k = lowest + k height steps (the same sum as SearchSlices' loop), while below the
  /// highest pixel; nullptr past it.
  const cv::Mat1b* FreeObjectsAtLevel(int k, double* level_m);
  /// The image's block maxima for FreeAtSomeLevel.
  const cv::Mat1f& block_max() const { return block_max_; }

 private:
  cv::Mat1f height_m_;
  int min_area_px_ = 1;
  double lowest_m_ = 0, step_m_ = 0, max_height_m_ = 0;
  cv::Mat1b smooth_pieces_;
  cv::Mat1f block_max_;
  std::vector<double> levels_m_;         // levels_m_[k]: level k
  std::vector<cv::Mat1b> free_objects_;  // free_objects_[k]: FreeObjectPixels at level k
};

/// SearchSlices on `free_space`'s heights (the same slices and graspable pixels).
SliceSearch SearchSlices(FreeSpace& free_space, const cv::Mat1b& contact_allowed,
                         const Gripper& gripper, const FgeParams& params);
/// [first, last) ranges of num_height_steps slices each, in order: the planners search a batch
/// and go on to the next, lower one only while they have fewer than top_k grasps.
std::vector<std::pair<std::size_t, std::size_t>> SliceBatches(std::size_t num_slices,
                                                              const FgeParams& params);
Slice SliceAt(double contact_height_m, const Gripper& gripper, const FgeParams& params,
              int index = 0);

/// Seam levels: for every pair of 4-neighbours whose heights differ by >= seam_step_m and whose
/// lower pixel continues flat away from the step (next pixel within seam_step_m / 2; this
/// excludes walls seen edge-on), both pixels get the lower of the two heights (max over their
/// pairs); 0 elsewhere. A seam whose both sides reach above a level t lies at a pixel iff its
/// seam level is > t. Pixels set in `missing` (filled in, not measured; empty = none) take part
/// in no pair.
cv::Mat1f SeamLevels(const cv::Mat1f& height_m, const cv::Mat1b& missing, double seam_step_m);

/// Grasp point: the centre pixel's ray meets the plane `height_m` above the floor.
std::array<double, 3> PointOnRayAtHeight(const Camera& camera, const Plane& floor, double u_px,
                                         double v_px, double height_m);
/// Rotation about the camera z axis by angle_rad, as (w, x, y, z).
std::array<double, 4> QuaternionAboutZ(double angle_rad);

/// Angle of map `index` of `num_angles` in [0, pi).
inline double AngleOf(int index, int num_angles) {
  return 3.14159265358979323846 * index / num_angles;
}

/// Candidates within radius_px of each other (any type with u_px, v_px).
template <class C>
bool Near(const C& a, const C& b, double radius_px) {
  const double du = a.u_px - b.u_px;
  const double dv = a.v_px - b.v_px;
  return du * du + dv * dv < radius_px * radius_px;
}

/// Angles within one step (180 / num_angles degrees) are similar; the angle wraps at pi.
template <class C>
bool SimilarAngle(const C& a, const C& b, int num_angles) {
  const int d = std::abs(a.angle_index - b.angle_index) % num_angles;
  return std::min(d, num_angles - d) <= 1;
}

}  // namespace softgrasp::core::fge_detail
