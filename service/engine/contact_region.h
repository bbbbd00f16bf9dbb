#pragma once
/// The one contact-region policy: where any strategy's fingers may touch, applied by the engine
/// to every strategy alike, before it plans (the scene's contact mask) and to its answers (each
/// grasp's contacts). A contact must lie
///   - inside the request's segmask, when one is given;
///   - on a surface at least min_depth_m from the camera and not joined to a nearer one
///     (core::RestrictContact), when min_depth_m > 0;
///   - on the named target, when the strategy does not choose its own;
///   - on a surface that stands free of the image border at some height (core::GraspableSurfaces):
///     the robot's own fingers in a wrist camera's view, bin walls and objects cut by the frame
///     reach in from the border and are obstacles, never contacts, with or without min_depth_m.
/// The fingers' 3-D clearance (core::FingerClearance) is each planner's own test, since it
/// depends on the slice the planner chose.

#include <opencv2/core.hpp>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"

namespace softgrasp::engine {

struct ContactRegionRequest {
  cv::Mat1b segmask;  ///< the scene's size, non-zero = allowed; empty = everywhere
  double min_depth_m = 0;
  cv::Mat1b target;  ///< the scene's size, non-zero = the target; empty = no target
  /// Find the surfaces that stand free of the border (for a planner that does not itself).
  bool free_surfaces = true;
};

/// Narrows `scene->contact_allowed` to the request's part of the region (segmask, min_depth_m,
/// target) and, when request.free_surfaces, returns the whole region: the surfaces that stand
/// free of the border, found on that mask (`gripper` and `fge` set the floor clearance and height
/// steps of FGE's search), grown by 3 px so that an object's outline stays in it (a finger that
/// enters from the border is tens of pixels from any free object). A planner that samples contacts
/// anywhere is given the whole region as its scene's mask; FGE's planners find the free surfaces on
/// the narrowed mask themselves, by the same rule (narrowing their mask twice would move their
/// slices), and ask for no region. Empty when not asked for and for an empty scene.
/// @pre the masks have the scene's size and min_depth_m is finite and >= 0.
cv::Mat1b ApplyContactRegion(core::Scene* scene, const core::Camera& camera,
                             const core::Gripper& gripper, const core::FgeParams& fge,
                             const ContactRegionRequest& request);

/// Whether the surfaces `grasp`'s fingers close on lie in `region` (ApplyContactRegion's; empty =
/// everywhere): on the closing axis and on the lines at the fingers' edges, the outermost surface
/// of `scene` above the fingertips on each side of the centre (where a finger pad meets it) is in
/// the region. A line that meets no surface is not checked; a grasp whose lines meet none is
/// judged by its centre.
bool ClosesInRegion(const core::Scene& scene, const cv::Mat1b& region, const core::Grasp& grasp);

}  // namespace softgrasp::engine
