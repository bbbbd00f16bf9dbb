#pragma once
/// Stiffness-aware FGE (thesis eq. 3.6-3.10 and its clutter variant): among the FGE candidates
/// (contact, no finger/palm collision, no slip, no seam), prefer closing regions on hard surfaces.
/// See docs/stiffness.md, "Stiffness-aware FGE".

#include <opencv2/core.hpp>
#include <vector>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/fge_geometry.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"

namespace softgrasp::core {

struct StiffnessFgeParams {
  FgeParams fge;  ///< angles, slices, slip/seam rules, top_k and NMS as for classic FGE
  /// Ranking key = mean stiffness + centre_weight * graspability: stiffness comes in 0.1 steps,
  /// so among equally hard regions the more central (FGE's preference) wins. 0 = pure eq. 3.10.
  double centre_weight = 0.05;
  /// > 0: the mean stiffness enters the ranking key rounded down to this step, so differences
  /// below a learned map's noise do not outrank the centre (0 = as it is; ground-truth maps
  /// come in 0.1 steps already). The reported mean_stiffness is never rounded.
  double key_step = 0.0;
  /// Candidate pixels are evaluated on a grid of this step (image pixels), rounded down to the
  /// fast FGE's work resolution (a multiple of its scale, at least one work pixel).
  int candidate_step_px = 2;
  /// Batches of fge.num_height_steps slices searched at most (0 = down to the floor while fewer
  /// than top_k grasps are found). Algorithm 1 of the deformability planner searches one.
  int max_slice_batches = 0;
};

/// Why DetectGraspsStiffness cannot plan with these inputs (ValidateFgeInputs' reasons, and its
/// own parameters out of range: field "stiffness"); nullopt when it can.
std::optional<Error> ValidateStiffnessFgeInputs(const Camera& camera, const Gripper& gripper,
                                                const StiffnessFgeParams& params);

/// Ranked grasps, best first, each with `mean_stiffness` = mean of `stiffness_map` over the
/// contact surface I_t inside its closing region T_t (A_st / A_t). `score` stays FGE's
/// graspability. `stiffness_map`: the scene's size, values in [0, 1] (e.g.
/// models::StiffnessModel::Predict). Throws std::invalid_argument like DetectGraspsFge, and when
/// the map's size differs from the scene's or params are out of range (centre_weight >= 0,
/// 1 <= candidate_step_px <= 16, max_slice_batches >= 0, key_step in [0, 1]).
std::vector<Grasp> DetectGraspsStiffness(const Scene& scene, const Camera& camera,
                                         const cv::Mat1f& stiffness_map, const Gripper& gripper,
                                         const StiffnessFgeParams& params = {});

/// The slices and graspable surfaces DetectGraspsStiffness searches on `scene`. They depend on
/// the scene, the camera, params.fge and the finger length, not on the opening stroke: a planner
/// that tries several openings on one scene computes them once (about 10 ms on 640x480).
fge_detail::SliceSearch StiffnessSliceSearch(const Scene& scene, const Camera& camera,
                                             const Gripper& gripper,
                                             const StiffnessFgeParams& params = {});

/// As above, on a FreeSpace made for scene.height_m with PxPerMetre(scene.floor, camera, 0) and
/// params.fge: a planner that searches the same heights for several contact masks (targets)
/// shares the work that does not depend on the mask. The same result as without it.
fge_detail::SliceSearch StiffnessSliceSearch(const Scene& scene, const Camera& camera,
                                             const Gripper& gripper,
                                             const StiffnessFgeParams& params,
                                             fge_detail::FreeSpace& free_space);

/// As above on a `search` that StiffnessSliceSearch made for the same scene, camera and params
/// and a gripper that differs at most in its opening stroke (the same grasps as without it).
std::vector<Grasp> DetectGraspsStiffness(const Scene& scene, const Camera& camera,
                                         const cv::Mat1f& stiffness_map, const Gripper& gripper,
                                         const StiffnessFgeParams& params,
                                         const fge_detail::SliceSearch& search);

/// Mean of `stiffness_map` over the pixels of `grasp`'s closing region (|a| <= opening/2,
/// |b| <= finger width/2, pixel-centre rule) whose height is above the grasp's contact height;
/// NaN when there is none. Used to fill `mean_stiffness` of classic FGE grasps.
double ContactMeanStiffness(const Scene& scene, const cv::Mat1f& stiffness_map, const Grasp& grasp);

}  // namespace softgrasp::core
