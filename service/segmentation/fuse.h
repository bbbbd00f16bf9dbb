#pragma once
/// Fusing the learned model's instances with the PCL baseline's: the model separates touching
/// objects and knows their deformability, but on frames far from its training data (another
/// sensor, a heap of flat tools) it scores real objects low; the PCL baseline's support removal
/// and clustering are geometric and hold on any camera, but merge touching objects.
///
/// FuseInstances keeps every model instance and adds the objects only the geometry found: a PCL
/// instance of which at most `max_covered_fraction` lies inside the model's confident instances
/// becomes a new instance on its pixels outside them (taking them from unconfident model
/// instances), scored `geometry_score`. A PCL instance around one confident model instance
/// extends it over the background (extend_min_inside_fraction). Model instances left smaller
/// than `min_area_px` are dropped. See docs/segmentation.md ("Fused").

#include <vector>

#include "service/segmentation/instances.h"

namespace softgrasp::segmentation {

struct FuseParams {
  /// Model instances scoring at least this are confident (models/segmentation.json
  /// `confident_score`); their pixels are never given to a geometric instance.
  float confident_score = 0.25f;
  /// A PCL instance adds an object when at most this fraction of its pixels lies in confident
  /// model instances (more: the model already has it, the rest is its rim or a merged neighbour).
  double max_covered_fraction = 0.2;
  /// A PCL instance adds an object only when some model instance (necessarily unconfident)
  /// overlaps it with at least this IoU: both methods see it. 0 = the geometry alone suffices.
  double min_model_iou = 0.0;
  /// Score of an instance found only by the geometry (docs/segmentation.md: its measured
  /// precision on the simulated selection scenes).
  float geometry_score = 0.3f;
  /// A PCL instance that overlaps exactly one confident model instance and holds at least this
  /// fraction of it extends that instance over its pixels the model left as background (the
  /// flat rim of an object whose raised middle the model found). Above 1: never.
  double extend_min_inside_fraction = 0.8;
  /// Least pixels of any output instance (at 640 x 480, scaled with the image area).
  int min_area_px = 150;
};

/// `model` and `pcl` label the same image. Output ids are dense, by decreasing score.
/// `from_geometry` (optional) receives, for each output id - 1, whether the instance was added
/// from the geometry alone. Deterministic.
/// @throws std::invalid_argument when the label images differ in size or a label exceeds its
/// scores.
InstanceMasks FuseInstances(const InstanceMasks& model, const InstanceMasks& pcl,
                            const FuseParams& params = {},
                            std::vector<bool>* from_geometry = nullptr);

}  // namespace softgrasp::segmentation
