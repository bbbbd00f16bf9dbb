#pragma once
/// What the planning engine takes and gives: the loaded models, the options every strategy
/// shares, and the plan (scene, maps, instances, ranked grasps, timings). A strategy's own
/// options and what it adds to its grasps and to the plan are its room's types
/// (service/engine/strategies/), carried here behind StrategyOptions, GraspDetails and
/// PlanDetails.

#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"
#include "service/engine/instances.h"
#include "service/models/gqcnn_model.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"

namespace softgrasp::engine {

/// The models a process has loaded; any may be null.
struct Models {
  std::shared_ptr<const models::StiffnessModel> stiffness;
  std::shared_ptr<const models::SegmentationModel> segmentation;
  std::shared_ptr<const models::GqcnnModel> gqcnn;
};

/// A strategy's own options; each strategy's room derives its struct from it.
struct StrategyOptions {
  virtual ~StrategyOptions() = default;
};

/// What a strategy adds to one of its grasps; each room that adds anything derives from it.
struct GraspDetails {
  virtual ~GraspDetails() = default;
};

/// What a strategy adds to the whole plan; likewise.
struct PlanDetails {
  virtual ~PlanDetails() = default;
};

struct PlanOptions {
  /// A registered strategy's name (engine::Strategies()).
  std::string strategy = "fge";
  /// That strategy's own options, of its room's type (e.g. GqcnnOptions); null = its defaults.
  std::shared_ptr<const StrategyOptions> strategy_options;
  core::Gripper gripper;
  /// FGE's multi-height search; every strategy's contact region uses its floor clearance and
  /// height steps (contact_region.h), and the FGE strategies plan with it.
  core::FgeParams fge;
  /// Contacts only where non-zero (image size; empty = everywhere) and on surfaces at least
  /// min_depth_m from the camera (contact_region.h).
  cv::Mat1b region_of_interest;
  double min_depth_m = 0.0;
  /// > 0: plan on this instance (see StrategyInfo::plans_target).
  int target_id = 0;
  /// Instead of target_id: the instance under this pixel (a user's click) is the target. No
  /// instance there: the plan has no grasps and `target_not_found` is set.
  std::optional<cv::Point> target_px;
  /// Strategies without a map of their own (fge): each grasp reports the stiffness model's mean
  /// over its contact surface (costs a model run).
  bool mean_stiffness = false;
  /// Report each grasp's instance: segments the scene unless `instances.labels` are given.
  bool report_instances = false;
  /// Labels given and the segmenter to run (InstanceRequest; its need_deformability and
  /// target_id are set by the engine).
  InstanceRequest instances;
  /// Given: used instead of running the stiffness model (e.g. a ground-truth map), which then
  /// need not be loaded. The depth's size.
  cv::Mat1f stiffness_map;
  /// Maps the caller shows besides the plan (e.g. in a picture): computed even when the strategy
  /// does not need them.
  bool want_stiffness_map = false;
  bool want_deformability_map = false;
  /// false: preprocess and the maps only, no grasps.
  bool plan = true;
};

struct PlannedGrasp {
  core::Grasp grasp;
  /// The instance it grasps (0 = none) when the plan has instances.
  std::optional<int> instance_id;
  /// The mean deformability of the instance under its centre (the segmentation model's map).
  std::optional<double> instance_deformability;
  /// What the strategy adds to the grasp (its room's type); null when nothing.
  std::shared_ptr<const GraspDetails> details;
};

/// Milliseconds; a stage that did not run is 0 (stiffness_ran says whether the model ran).
struct PlanTimings {
  double preprocess_ms = 0;  ///< preprocessing and the contact region
  bool stiffness_ran = false;
  double stiffness_ms = 0;
  double segmentation_ms = 0;  ///< segmenting and describing instances
  double detect_ms = 0;
  double total_ms = 0;
};

struct Plan {
  core::Scene scene;    ///< preprocessed, with the request's contact restrictions applied
  cv::Mat1f stiffness;  ///< the stiffness map used or wanted; empty when none
  std::optional<Instances> instances;
  std::vector<PlannedGrasp> grasps;  ///< best first
  /// Strategies that plan their own target: the one chosen (0 = none or a whole-scene fallback).
  int chosen_target_id = 0;
  /// What the strategy adds to the plan (its room's type); null when nothing.
  std::shared_ptr<const PlanDetails> details;
  bool target_not_found = false;  ///< target_px was on no instance
  int target_id = 0;  ///< the named target: options.target_id or the instance under target_px
  PlanTimings timing;
};

/// What a strategy's planner works with: the scene with its contact region, the maps, the
/// instances and the target.
struct PlanContext {
  const Models& models;
  const core::Scene& scene;
  const core::Camera& camera;
  const PlanOptions& options;
  const cv::Mat1f& stiffness;  ///< empty unless needed or wanted
  const Instances* instances;  ///< null unless needed or asked for
  int target_id;               ///< > 0: the requested target
};

}  // namespace softgrasp::engine
