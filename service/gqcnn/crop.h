#pragma once
/// The one grasp-aligned crop of a depth image (docs/gqcnn-dataset.md, REFERENCE §1.8): what the
/// dataset generator (softgrasp-sim gqcnn-dataset) stores and what the GQ-CNN planner feeds its
/// network, so the two can never drift apart.
///
/// The crop: a square of `source_crop_px` image pixels (Dex-Net 2.0: 96) centred on the grasp
/// centre and rotated so the grasp axis runs along the crop's +u (columns; rows run across the
/// jaws), sampled at the nearest image pixel (Dex-Net's INTER_NEAREST rotation), then shrunk to
/// kCropSizePx (32) with a bilinear (triangle, radius = the scale factor, as PIL's antialiased
/// bilinear resize that Dex-Net's scipy.misc.imresize calls) filter that averages **valid
/// readings only**: a missing reading (NaN or <= 0) or a pixel outside the image has weight 0, so
/// holes do not bleed into their neighbours as near-zero depths; an output pixel none of whose
/// taps is valid is 0.
///
/// Crop pixel (row i, column j) is centred (j - 16, i - 16) x (source_crop_px / 32) source
/// pixels from the grasp centre along (axis, across): pixel (16, 16) sits exactly on the grasp
/// centre (Dex-Net's floor(c) crop convention).
///
/// Units: metres for depths, pixels for image coordinates (u right, v down; pixel (u, v)'s centre
/// at integer (u, v)), radians for angles.

#include <Eigen/Core>
#include <optional>

#include "service/core/depth.h"
#include "service/gqcnn/dataset_format.h"

namespace softgrasp::gqcnn {

/// Dex-Net 2.0's source crop side, pixels.
inline constexpr int kDexNetSourceCropPx = 96;

/// A grasp as seen in a depth image.
struct GraspImagePose {
  double center_u_px = 0.0;  ///< image column of the grasp centre
  double center_v_px = 0.0;  ///< image row of the grasp centre
  /// Direction of the grasp axis in the image, atan2(dv, du) with v down, in [0, 2 pi).
  double angle_rad = 0.0;
  double depth_m = 0.0;   ///< z of the grasp centre in the camera frame
  double width_px = 0.0;  ///< the jaw opening projected at the grasp depth
};

/// Fills out[kCropPixels] (row-major) with the grasp-aligned crop described above: absolute
/// depth in metres, 0 where the image has no reading, 0 outside the image. Costs about
/// (source_crop_px + 4)^2 nearest samples plus a separable 32 x 32 filter, independent of the
/// image size (only the rotated window is read).
/// @throws std::invalid_argument for non-finite centre or angle, or source_crop_px outside
///   [kCropSizePx, 4096].
void CropGrasp(const core::DepthImage& depth, const GraspImagePose& grasp, float* out,
               int source_crop_px = kDexNetSourceCropPx);

/// Projects a jaw grasp given in the camera frame C (OpenCV: x right, y down, z forward) with
/// pinhole intrinsics `camera`: centre pixel = K * center_c, depth = center_c.z, angle of the
/// axis between the projections of center_c -/+ axis_c * opening_m / 2, width_px = their
/// distance. `opening_m` is the gripper's opening (Dex-Net stores its 5 cm open width).
/// nullopt when the centre or a jaw point is not in front of the camera (z <= 0), the axis
/// projects to a point (it is parallel to the line of sight), or an input is not finite.
std::optional<GraspImagePose> ProjectGrasp(const core::Camera& camera,
                                           const Eigen::Vector3d& center_c,
                                           const Eigen::Vector3d& axis_c, double opening_m);

}  // namespace softgrasp::gqcnn
