#pragma once
/// Pictures of results: the depth colour-mapped with grasps drawn over it; object instances.

#include <opencv2/core.hpp>
#include <vector>

#include "service/core/depth.h"
#include "service/core/grasp.h"

namespace softgrasp::io {

/// Depth colour-mapped (near = warm, missing = black; range from the valid pixels' 1st–99th
/// percentiles), each grasp drawn as its two finger rectangles and the closing line between them.
/// The best grasp (index 0) is drawn thicker in a distinct colour, the others thinner. BGR.
cv::Mat3b RenderGraspOverlay(const core::DepthImage& depth, const std::vector<core::Grasp>& grasps);

/// Depth colour-mapped alone, as above.
cv::Mat3b ColorizeDepth(const core::DepthImage& depth);

/// A stiffness map (values in [0, 1], 1 = hard) colour-mapped on a fixed scale so a colour means
/// the same stiffness in every picture: soft (0.1) blue through green and yellow to hard (1.0)
/// red (the turbo map). Pixels below `background_below` (and NaN) are background: black. BGR.
cv::Mat3b ColorizeStiffness(const cv::Mat1f& stiffness, float background_below);

/// `grasps` drawn as in RenderGraspOverlay over any picture of the image's size (e.g.
/// ColorizeStiffness). Returns a copy; `background` is not changed.
cv::Mat3b DrawGrasps(const cv::Mat3b& background, const std::vector<core::Grasp>& grasps);

/// Object instances over a picture of the labels' size (e.g. ColorizeDepth, which is dimmed to
/// grey): each id of `labels` (0 = background, 1..N) filled in its own colour (a fixed palette,
/// so an id has the same colour in every picture), outlined, and its number written at the
/// instance pixel farthest from its outline. `highlight_id` (> 0) is outlined thicker in white.
/// Returns a copy. @throws std::invalid_argument when the sizes differ.
cv::Mat3b DrawInstances(const cv::Mat3b& background, const cv::Mat1w& labels, int highlight_id = 0);

/// The outline of `mask` (non-zero pixels, the picture's size) drawn in white over a copy of
/// `background` (e.g. the target object of strategy=deformability). Empty mask: a plain copy.
/// @throws std::invalid_argument when the sizes differ.
cv::Mat3b DrawOutline(const cv::Mat3b& background, const cv::Mat1b& mask);

/// The colour DrawInstances gives instance `id` (> 0), BGR.
cv::Vec3b InstanceColor(int id);

/// A deformability map (0 rigid ... 1 very soft) colour-mapped on the same fixed scale as
/// ColorizeStiffness, run the other way so a colour means the same material in both pictures:
/// very soft blue ... rigid red. Pixels where `foreground` is 0 (and NaN) are black. BGR.
cv::Mat3b ColorizeDeformability(const cv::Mat1f& deformability, const cv::Mat1b& foreground);

}  // namespace softgrasp::io
