#pragma once
/// Internal to softgrasp_core: the fast FGE (box sums over rotated, downscaled level images).
/// See docs/fge.md, section "Fast implementation".

#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "service/core/fge.h"
#include "service/core/fge_geometry.h"

namespace softgrasp::core::fge_detail {

/// A local maximum of one graspability map, in full-resolution image pixels.
struct LocalMaximum {
  double u_px = 0;
  double v_px = 0;
  float score = 0;
};

/// Everything that depends on the scene and the slices but not on the angle is prepared once in
/// the constructor; each angle then costs one rotation of a 16-bit level image plus, per slice, a
/// few integral images, box sums around each object and a Gaussian blur of the candidate map.
/// Buffers are reused across angles and slices. Not thread-safe; use one instance per thread
/// (CandidatesAtAngles spreads its own work over threads).
class FastFge {
 public:
  /// `graspable` (image size, 255 = may be a contact surface) restricts I_t; every surface is
  /// an obstacle.
  FastFge(const Scene& scene, const Camera& camera, const Gripper& gripper, const FgeParams& params,
          std::vector<Slice> slices, const cv::Mat1b& graspable);
  ~FastFge();
  FastFge(const FastFge&) = delete;
  FastFge& operator=(const FastFge&) = delete;

  /// Work resolution is 1/scale() of the image (max-pooled heights: conservative for collisions).
  int scale() const { return scale_; }
  const std::vector<Slice>& slices() const { return slices_; }

  /// Local maxima of the graspability map of every slice at one angle; result[i] is slices()[i].
  /// Asking for angle + pi/2 right after angle reuses the rotated image (an exact 90-degree turn
  /// instead of a second resampling).
  std::vector<std::vector<LocalMaximum>> LocalMaxima(double angle_rad);

  /// The three maps of slice `slice_pos` at one angle, at image size (counts in image pixels).
  FgeMaps Maps(double angle_rad, std::size_t slice_pos);

  /// Block sums at work resolution over the crop (zeros outside the image) of `values` where
  /// `mask` is set (channel 0) and of the mask's pixel count (channel 1); both image size. The
  /// values are fractions: each counts clamped to [0, 1], NaN as 0. The input of
  /// CandidatesAtAngles; sums stay in image-pixel units.
  cv::Mat2f PoolSums(const cv::Mat1f& values, const cv::Mat1b& mask) const;

  /// A candidate of one slice at one angle with its sums of a pooled map over the closing region.
  struct RegionCandidate {
    double u_px = 0;  ///< image pixels (centre of the work pixel's block)
    double v_px = 0;
    float graspability = 0;  ///< Maps' blurred candidate map, read bilinearly from its cells
    cv::Vec2d sums;          ///< box sums of the slice's pooled map over T_t (both channels)
  };
  /// Every candidate (A_t >= min contact, no finger/palm collision, no slip, no seam: the
  /// non-zero pixels of Maps' graspability) of every slice at each angle on the canvas grid of
  /// `grid_step` work pixels; result[k][i] is angles_rad[k] and slices()[i]. `pooled[i]`
  /// (PoolSums of an image-size map; empty or missing: sums 0) is rotated with the level image
  /// and read as box sums over each candidate's closing region T_t, e.g. S * I_t and I_t for a
  /// mean of S over I_t. The angles are spread over OpenCV's threads (cv::parallel_for_, one
  /// workspace per thread); the result does not depend on the thread count.
  std::vector<std::vector<std::vector<RegionCandidate>>> CandidatesAtAngles(
      const std::vector<double>& angles_rad, const std::vector<cv::Mat2f>& pooled,
      int grid_step = 1);

  /// Per-slice sizes at work resolution and indices into the sorted level list.
  struct SliceWork {
    TemplateBoxes boxes;
    int min_contact_px = 1;
    double blur_sigma_px = 1;
    int blur_downscale = 1;  ///< the blur runs on cells of this many pixels squared
    int contact_level = 0;   ///< I_t = height level > contact_level
    int tip_level = 0;       ///< I_c, slip and seams
    int palm_level = 0;      ///< palm collisions
  };
  /// A connected graspable object at the lowest contact level: its box in crop pixels and the
  /// highest contact level it reaches. Candidates are only evaluated around objects.
  struct Object {
    cv::Rect crop_box;
    int max_contact_level = 0;
  };
  struct Canvas;     // one angle's rotated level image (fge_fast.cpp)
  struct Workspace;  // reusable buffers (fge_fast.cpp)

 private:
  /// The rotated level words; `whole`: the whole rotated crop, else only the objects'
  /// neighbourhood (what LocalMaxima reads).
  Canvas MakeCanvas(double angle_rad, bool whole, Workspace& ws) const;
  std::vector<std::vector<RegionCandidate>> CandidatesWith(double angle_rad,
                                                           const std::vector<cv::Mat2f>& pooled,
                                                           int grid_step, Workspace& ws) const;
  Canvas TurnedCanvas(const Canvas& canvas) const;
  cv::Point2d ToImage(const Canvas& canvas, cv::Point2d canvas_px) const;

  int scale_ = 1;
  cv::Size image_size_;
  cv::Size work_size_;
  std::vector<Slice> slices_;
  std::vector<SliceWork> work_;
  cv::Rect crop_;     ///< work pixels that can matter (may extend past the image; empty: none)
  cv::Mat1w levels_;  ///< crop: level words (fge_fast.cpp: levels, graspable bit, seams)
  std::vector<Object> objects_;
  int max_contact_level_ = 0;  ///< highest level of a graspable surface
  int max_level_ = 0;          ///< highest level of any surface (or of the outside)
  int max_seam_level_ = 0;
  int min_contact_level_ = 0;         ///< contact level of the lowest slice
  bool contact_is_obstacle_ = false;  ///< every surface in the crop is graspable: I_t shares I_c
  int margin_px_ = 0;                 ///< reach of a template's box sums from an I_t pixel
  std::unique_ptr<Workspace> ws_;
  std::unique_ptr<Canvas> last_canvas_;  ///< canvas of the previous LocalMaxima call
  double last_angle_rad_ = 0;
};

}  // namespace softgrasp::core::fge_detail
