#pragma once
/// The planning engine: one call from a decoded depth image, its camera, the options and the
/// loaded models to the scene, the maps it computed, ranked grasps and timings. The REST handler
/// and the evaluation tools call it alike; strategies are registered in engine.cpp alone.
///
///   engine::PlanOptions options;
///   options.strategy = engine::Strategy::kStiffness;
///   auto plan = engine::PlanGrasps(depth, camera, options, {stiffness_model, nullptr});
///   if (!plan.ok()) return plan.error();
///   for (const engine::PlannedGrasp& g : plan.value().grasps) ...

#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string_view>
#include <vector>

#include "service/core/depth.h"
#include "service/core/fge.h"
#include "service/core/fge_deformability.h"
#include "service/core/fge_stiffness.h"
#include "service/core/grasp.h"
#include "service/core/preprocess.h"
#include "service/core/status.h"
#include "service/engine/instances.h"
#include "service/gqcnn/policy.h"
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

enum class Strategy {
  kFge,  ///< classic FGE: graspability (centre of the contact surface)
  /// Dex-Net 2.0's policy: antipodal candidates ranked by the GQ-CNN, CEM-refined (docs/gqcnn.md)
  kGqcnn,
  kStiffness,  ///< stiffness-aware FGE on the stiffness model's map
  /// Algorithm 1 on one target object with the segmentation model's deformability map
  /// (docs/deformability.md)
  kDeformability,
};

/// What a registered strategy is called and what it needs.
struct StrategyInfo {
  Strategy strategy;
  const char* name;               ///< as requests name it
  bool needs_stiffness_model;     ///< plans on the stiffness model's map
  bool needs_segmentation_model;  ///< plans on instances and the deformability map
  bool needs_gqcnn_model;         ///< ranks its candidates with the GQ-CNN
  /// Chooses and plans its own target (a requested target is its input); for the others a
  /// target restricts contacts to that instance and every other object stays an obstacle.
  bool plans_target;
  /// Keeps its contacts on the surfaces that stand free of the image border itself, by FGE's
  /// search on the scene's contact mask (contact_region.h); the others get the whole contact
  /// region as their scene's mask.
  bool finds_free_surfaces;
};

/// Every strategy, in order of preference: the default is the last one the loaded models serve.
const std::vector<StrategyInfo>& Strategies();
const StrategyInfo& InfoOf(Strategy strategy);
const char* StrategyName(Strategy strategy);
std::optional<Strategy> StrategyByName(std::string_view name);
/// Whether `models` has what `strategy` needs.
bool Serves(const Models& models, Strategy strategy);
/// Why `models` cannot serve `strategy` (kInvalidArgument, field "strategy": what is missing and
/// which strategies are served); nullopt when they can.
std::optional<core::Error> Unserved(const Models& models, Strategy strategy);
Strategy DefaultStrategy(const Models& models);
/// The strategies `models` serve, in Strategies() order.
std::vector<Strategy> ServedStrategies(const Models& models);

struct PlanOptions {
  Strategy strategy = Strategy::kFge;
  core::Gripper gripper;
  core::FgeParams fge;
  /// strategy=deformability: K, L, M, R and the rest; its `fge` and `target_id` are replaced by
  /// this struct's.
  core::DeformabilityParams deformability;
  /// Contacts only where non-zero (image size; empty = everywhere) and on surfaces at least
  /// min_depth_m from the camera (core::RestrictContact).
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
  /// strategy=stiffness: its ranking parameters; its `fge` is replaced by this struct's.
  core::StiffnessFgeParams stiffness;
  /// strategy=gqcnn: sampling and refinement; its num_grasps is replaced by fge.top_k (the
  /// request's number of grasps).
  gqcnn::PolicyParams gqcnn;
  /// Maps the caller shows besides the plan (e.g. in a picture): computed even when the strategy
  /// does not need them.
  bool want_stiffness_map = false;
  bool want_deformability_map = false;
  /// false: preprocess and the maps only, no grasps.
  bool plan = true;
};

/// What the deformability strategy knows about one of its grasps.
struct DeformabilityRecord {
  core::TargetPolicy policy = core::TargetPolicy::kHighest;
  const char* target_by = "policy";  ///< "policy", "request" or "fallback"
  double opening_fraction = 1.0;
  double mean_deformability = 0.0;  ///< NaN when unknown
  std::vector<int> pressed_ids;     ///< soft neighbours the fingers press aside
  double press_depth_m = 0.0;
};

struct PlannedGrasp {
  core::Grasp grasp;
  /// The instance it grasps (0 = none) when the plan has instances.
  std::optional<int> instance_id;
  /// The mean deformability of the instance under its centre (the segmentation model's map).
  std::optional<double> instance_deformability;
  std::optional<DeformabilityRecord> deformability;  ///< strategy=deformability only
  /// strategy=gqcnn only: the network's P(success) (also the grasp's score) and the grasp's
  /// image pose as the network saw it (depth = z of the grasp centre, metres).
  std::optional<gqcnn::GraspImagePose> gqcnn_pose;
  /// strategy=gqcnn only: the contact check's verdict (firm grasps rank first).
  core::ContactHold gqcnn_contacts = core::ContactHold::kFirm;
  /// strategy=gqcnn only: P(success) at or above the model's decision threshold.
  bool gqcnn_predicted_success = false;
};

/// What strategy=gqcnn did.
struct GqcnnStats {
  int edge_pixels = 0;
  int antipodal_pairs = 0;
  int evaluated = 0;  ///< crops the network scored
  double sample_ms = 0;
  double evaluate_ms = 0;
  /// The model's decision threshold (models::GqcnnModel::decision_threshold).
  double decision_threshold = 0.5;
};

/// The target a strategy that plans targets chose.
struct TargetChoice {
  int id = 0;  ///< 0 = none (no grasp, or the whole-scene fallback)
  core::TargetPolicy policy = core::TargetPolicy::kHighest;
  std::vector<int> tried_ids;
  bool fallback = false;
  /// The target's low-contrast soft-looking pixels were allowed as contact (no grasp kept out of
  /// them; core::DeformabilityResult::soft_part_allowed).
  bool soft_part_allowed = false;
};

/// Milliseconds; a stage that did not run is 0 (stiffness_ran says whether the model ran).
struct PlanTimings {
  double preprocess_ms = 0;
  bool stiffness_ran = false;
  double stiffness_ms = 0;
  double segmentation_ms = 0;  ///< segmenting and describing instances
  double detect_ms = 0;
  double total_ms = 0;
};

struct Plan {
  core::Scene scene;    ///< preprocessed, with the contact restrictions applied
  cv::Mat1f stiffness;  ///< the stiffness map used or wanted; empty when none
  std::optional<Instances> instances;
  std::vector<PlannedGrasp> grasps;    ///< best first
  std::optional<TargetChoice> target;  ///< strategies that plan targets
  std::optional<GqcnnStats> gqcnn;     ///< strategy=gqcnn
  bool target_not_found = false;       ///< target_px was on no instance
  int target_id = 0;  ///< the named target: options.target_id or the instance under target_px
  PlanTimings timing;
};

/// Preprocesses the depth, restricts contacts, runs the models the strategy, the options and the
/// wanted maps need, and plans. Errors: core::Preprocess's (kUnprocessable), kInvalidArgument
/// (field "strategy") when `models` do not serve the strategy or "mean_stiffness" when no
/// stiffness model is loaded for it, InstancesForPlan's, and kInvalidArgument for options
/// the planners refuse (a region of interest of another size, slice_step > finger length).
core::Result<Plan> PlanGrasps(const core::DepthImage& depth, const core::Camera& camera,
                              const PlanOptions& options, const Models& models);

/// What a segmentation (POST /v1/segmentation) asks for.
struct SegmentOptions {
  /// The segmenter; unset: the model when one is loaded, else pcl.
  std::optional<segmentation::Method> method;
  /// Describe every instance (DescribeSceneInstances; with the stiffness model's mean when one
  /// is loaded).
  bool describe = false;
};

struct SegmentTimings {
  double preprocess_ms = 0;
  double segment_ms = 0;
  double stiffness_ms = 0;  ///< 0 when the stiffness model did not run
  double describe_ms = 0;   ///< describing, the stiffness model's time excluded
};

struct Segmentation {
  core::Scene scene;  ///< preprocessed
  SceneInstances instances;
  std::vector<segmentation::InstanceInfo> described;  ///< filled when options.describe
  SegmentTimings timing;
};

/// Preprocesses the depth and segments it into object instances. Errors: core::Preprocess's
/// (kUnprocessable), ResolveSegmentationMethod's (field "method") and SegmentInstances'.
core::Result<Segmentation> Segment(const core::DepthImage& depth, const core::Camera& camera,
                                   const SegmentOptions& options, const Models& models);

}  // namespace softgrasp::engine
