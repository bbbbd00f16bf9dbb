#pragma once
/// Deformability-aware grasping (thesis §5.2.4, Algorithm 1, §5.3.3-5.3.4): choose one target
/// object among the confident instances, search Algorithm 1's height slices on it for the
/// closing region with the lowest mean deformability, with the smallest opening that works,
/// never on the target's soft parts, pressing soft neighbours aside where needed.
/// See docs/deformability.md.

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"

namespace softgrasp::core {

/// Which confident instance becomes the target.
enum class TargetPolicy {
  kHighest,          ///< the thesis: the one whose top is highest
  kLeastDeformable,  ///< the one least likely to be damaged; ties go to the highest
};
const char* TargetPolicyName(TargetPolicy policy);  ///< "highest" | "least_deformable"

/// What a segmenter says about a scene: labels (0 = none, ids 1..N), scores[id - 1] in [0, 1],
/// a deformability map in [0, 1] (0 rigid ... 1 very soft), all of the scene's size, and
/// optionally the foreground probability: unlabelled foreground pixels (>= 0.5) connected to the
/// target count as the target (a mask that covers only part of its object must not make the
/// rest of the object an obstacle).
struct ObjectMaps {
  cv::Mat1w labels;
  std::vector<float> scores;
  cv::Mat1f deformability;
  cv::Mat1f foreground;  ///< empty = no growing
};

struct DeformabilityParams {
  /// Angles, top_k, NMS, seams, floor clearance as for classic FGE. Its height_step_m,
  /// num_height_steps, grip_depth_m and min_object_area_px are replaced by L, M, L and K.
  FgeParams fge;
  double min_target_area_px = 100;  ///< K: the first slice is where the target's area exceeds it
  double slice_step_m = 0.010;      ///< L: slices this far apart; the collision image is the next
                                    ///< slice down, so the fingertips go L below the contact
  int num_slices = 5;               ///< M: slices searched from the first one down
  double min_score = 0.25;          ///< R: instances scoring below are never targets
  TargetPolicy policy = TargetPolicy::kHighest;
  int target_id = 0;  ///< > 0: this instance, whatever its score (wins over policy)
  /// With target_id: the pixel that named it (a click). The target is then the part of the
  /// instance joined to this pixel by neighbours whose heights differ by at most fge.seam_step_m:
  /// a segmentation that merged the clicked object with a neighbour of another height (a box
  /// with the sponge beside it) gives the clicked object only; the rest stays an obstacle.
  std::optional<cv::Point> target_px;
  /// Pre-grasp openings tried, as fractions of the stroke, in increasing order; the smallest
  /// that gives a grasp is kept.
  std::vector<double> opening_fractions{0.5, 0.75, 1.0};
  /// An opening narrower than the widest one works only with a grasp of at least this FGE
  /// graspability (a narrow opening that only just clears the object leaves a sliver of
  /// candidates, often at the object's end); grasps below it are dropped. The widest opening
  /// takes what it finds, as classic FGE does.
  double min_graspability = 0.05;
  /// Partially deformable objects: target pixels whose stiffness (1 - deformability) is below
  /// this fraction of the target's maximum are never contact (thesis §5.3.3); they stay
  /// obstacles, so a closing region that would squeeze them fails FGE's slip rule.
  double stiff_part_fraction = 0.5;
  /// Only when no target gives a grasp with every soft part kept out, targets are planned again
  /// with soft-looking pixels allowed as contact where the two parts differ by less than this in
  /// mean stiffness: a learned map shows rigid objects packed among sponges half soft, and the
  /// rule then cut most of them away (docs/deformability.md). A named target (target_id) that
  /// still gives none is planned whole in a last pass. 0 = never (neither pass).
  double min_part_contrast = 0.3;
  /// Neighbour pixels softer than this (deformability) are not collisions up to
  /// max_press_depth_m: a finger may press them aside, but only when the target gives no grasp
  /// that touches nothing (all openings tried without pressing first) and a soft neighbour is
  /// within the gripper's reach of the target (SoftNeighbourInReach). > 1 disables pushing.
  double soft_obstacle_threshold = 0.5;
  double max_press_depth_m = 0.02;
  /// kLeastDeformable: instances whose mean deformability is within this of the least are ties.
  double tie_tolerance = 0.05;
  int max_targets = 8;  ///< candidate targets planned at most, in policy order
  /// When no target gives a grasp (no confident instance, or their masks cover too little of
  /// their objects, as on some real frames), plan on the whole scene instead: FGE's own
  /// multi-height search (fge as given) ranked by the mean (1 - deformability), like the
  /// stiffness strategy on the segmentation model's map. Never with target_id.
  bool whole_scene_fallback = true;
  double centre_weight = 0.05;  ///< as StiffnessFgeParams::centre_weight
  /// The mean deformability ranks in steps of this size (StiffnessFgeParams::key_step): a
  /// learned map's small ripples do not pull the grasp off the object's centre.
  double deformability_step = 0.05;
};

/// A grasp on the target with what the strategy knows about it.
struct DeformabilityGrasp {
  Grasp grasp;          ///< mean_stiffness = 1 - mean_deformability
  int instance_id = 0;  ///< the target (fallback: the instance under the centre, 0 = none)
  double mean_deformability = 0;  ///< over the contact surface in the closing region
  double opening_fraction = 1;    ///< of the stroke (grasp.opening_m is the opening itself)
  std::vector<int> pressed_ids;   ///< soft neighbours under the finger footprints, ascending
  double press_depth_m = 0;       ///< deepest press into them (0 = none)
};

struct DeformabilityResult {
  int target_id = 0;           ///< whose grasps these are; 0 when no target gave a grasp
  std::vector<int> tried_ids;  ///< targets planned, in order
  bool fallback = false;       ///< the grasps come from the whole-scene fallback
  /// The grasps may close on soft-looking pixels of the target: they come from the second pass
  /// (low-contrast soft parts allowed, min_part_contrast) or, for a named target, the last pass
  /// (the whole target allowed).
  bool soft_part_allowed = false;
  std::vector<DeformabilityGrasp> grasps;  ///< best first, all on target_id
};

/// The candidate targets in policy order (params.target_id alone when set): confident
/// (score >= min_score) instances of at least min_target_area_px pixels in
/// scene.contact_allowed. Top = the 98th percentile of the instance's heights.
std::vector<int> OrderTargets(const Scene& scene, const ObjectMaps& objects,
                              const DeformabilityParams& params);

/// Whether a pixel set in `soft` can lie under the gripper of some grasp whose closing region
/// holds a pixel of `contact`: soft pixels are looked for in the image box where every point
/// within the gripper's reach (stroke + finger thickness along the closing axis, finger width
/// across, plus a margin) of the contact pixels' camera x-y projects at any depth between the
/// scene's nearest and farthest surface (scene.depth_filled_m; without it, anywhere in the
/// image). The deformability planner presses soft neighbours aside only when this holds.
bool SoftNeighbourInReach(const Scene& scene, const Camera& camera, const Gripper& gripper,
                          const cv::Mat1b& contact, const cv::Mat1b& soft);

/// Why DetectGraspsDeformability cannot plan with these parameters for this gripper
/// (kInvalidArgument naming the field, e.g. a slice step longer than the fingers); nullopt when it
/// can.
std::optional<Error> ValidateDeformabilityParams(const DeformabilityParams& params,
                                                 const Gripper& gripper);

/// Plans on the targets of OrderTargets (at most max_targets) until one gives grasps. With
/// kLeastDeformable (and no target_id) it goes on while a later target's touchable part is less
/// deformable, by more than tie_tolerance, than the best grasp found so far (the first target's
/// stiff part may be out of reach), and keeps the target whose best grasp is least deformable.
/// Throws std::invalid_argument on maps of another size, scores not matching the labels' ids,
/// or parameters out of range (and as DetectGraspsFge does).
DeformabilityResult DetectGraspsDeformability(const Scene& scene, const Camera& camera,
                                              const ObjectMaps& objects, const Gripper& gripper,
                                              const DeformabilityParams& params = {});

}  // namespace softgrasp::core
