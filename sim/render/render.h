#pragma once
/// Rendering a simulated scene from a pinhole camera by ray casting (docs/sim-rendering.md):
/// depth, instance labels, stiffness and deformability maps, and an optional sensor-noise model.

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>

#include "service/core/depth.h"
#include "sim/render/raycast.h"

namespace softgrasp::sim {

/// Intel RealSense SR305 depth stream defaults: 640x480, about 69 x 54 degrees field of view.
core::Camera Sr305Camera();

/// A camera `height_m` above W's origin looking straight down (optical axis = -z of W), with
/// image +u along +x of W and image +v along -y of W. Returns world_from_camera (camera frame
/// C in OpenCV convention).
Eigen::Isometry3d OverheadCameraPose(double height_m = 0.55);

/// A depth-sensor noise model (all lengths in metres).
struct NoiseModel {
  bool enabled = false;
  std::uint64_t seed = 0;
  /// A pixel goes missing where the angle between the viewing ray and the surface normal exceeds
  /// this (grazing surfaces return no light).
  double grazing_angle_deg = 78.0;
  /// Pixels next to a depth jump larger than edge_jump_m go missing with this probability.
  double edge_jump_m = 0.01;
  double edge_dropout_probability = 0.6;
  /// Gaussian depth noise with sigma = sigma_base_m + sigma_quadratic_per_m * z^2.
  double sigma_base_m = 0.0005;
  double sigma_quadratic_per_m = 0.0025;
};

struct RenderOptions {
  core::Camera camera = Sr305Camera();
  Eigen::Isometry3d world_from_camera = OverheadCameraPose();
  NoiseModel noise;
};

/// Per-pixel views, all camera.width x camera.height.
struct RenderedViews {
  core::DepthImage depth;   ///< z in C, metres; NaN where nothing was hit or noise dropped it
  cv::Mat1w labels;         ///< instance id of the hit object, 0 for support/nothing
  cv::Mat1f stiffness;      ///< surface stiffness of the hit object in [0.1, 1], 0 elsewhere
  cv::Mat1f deformability;  ///< 1 - stiffness on objects, 0 elsewhere
};

/// The noise step of Render on its own, for renderers that cast their own rays (the GQ-CNN
/// dataset): a copy of `clean_depth_m` (NaN = no hit) with grazing dropout where
/// `cos_incidence` < cos(grazing angle), edge dropout and Gaussian noise. Randomness is a pure
/// function of (noise.seed, row * cols + col), so the same inputs give the same bytes. Does not
/// check the model's ranges (Render does) and ignores noise.enabled.
/// @pre cos_incidence has clean_depth_m's size.
cv::Mat1f ApplyDepthNoise(const cv::Mat1f& clean_depth_m, const cv::Mat1f& cos_incidence,
                          const NoiseModel& noise);

/// Renders every pixel's centre ray. Labels, stiffness and deformability are the noise-free
/// truth (noise only touches depth). Deterministic in (scene, options).
RenderedViews Render(const SceneRaycaster& raycaster, const RenderOptions& options);

}  // namespace softgrasp::sim
