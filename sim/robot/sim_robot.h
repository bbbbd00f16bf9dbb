#pragma once
/// The simulated robot (docs/sim-robot.md): a scene, its camera and a parallel gripper that
/// executes bridge::GraspCommands with the simulator's grasp execution model, removes what it
/// picks and re-renders the camera's view. The DDS loop (robot_loop.h) and the HTTP views
/// (robot_http.h) are thin layers over this class.
///
/// Frames: W is the scene's world frame (z up, support top at z = 0); "camera" is the scene
/// camera's OpenCV frame C (x right, y down, z forward), placed by world_from_camera. A command
/// pose is the grasp point between the fingertips with the gripper frame G: z = approach
/// direction, x = closing axis (as the planner's grasps in /v1/grasps).

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "service/bridge/dds.h"
#include "service/bridge/messages.h"
#include "service/core/status.h"
#include "sim/dataset/scene_gen.h"
#include "sim/grasp/execute.h"
#include "sim/render/render.h"
#include "sim/scene/scene.h"

namespace softgrasp::sim {

/// Frame names a command may use.
inline constexpr char kCameraFrame[] = "camera";
inline constexpr char kWorldFrame[] = "world";

/// The simulated gripper only moves straight down in W: a command whose approach axis (G's z)
/// is further than this from -z of W is REJECTED.
inline constexpr double kMaxApproachTiltDeg = 10.0;

/// What the camera sees now, with the scene it was rendered from. Immutable once published:
/// readers hold it by shared_ptr while the robot moves on.
struct SimRobotView {
  std::uint64_t generation = 0;  ///< +1 on every change of the scene (pick or reset)
  std::uint64_t scene_seed = 0;
  core::Camera camera;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  RenderedViews views;
  /// SceneManifest of the current scene (objects left and their poses) plus "generation",
  /// "objects_left" and "picked" (instance ids removed so far, in order).
  nlohmann::json manifest;
};

/// The robot's fixed parts.
struct SimRobotOptions {
  core::Gripper gripper;  ///< closing_force_n is replaced by each command's force
  /// Workspace margins around the support's inner area in W: `workspace_margin_m` beyond its x/y
  /// edges, from `workspace_floor_m` below the support top up to `workspace_top_m` above it.
  double workspace_margin_m = 0.05;
  double workspace_floor_m = 0.05;
  double workspace_top_m = 0.30;
};

class SimRobot {
 public:
  /// A robot over a generated scene (GenerateScene(spec, seed)). Reset() draws new scenes from
  /// the same spec. Errors: those of GenerateScene.
  static core::Result<std::unique_ptr<SimRobot>> Generate(const SceneSpec& spec,
                                                          std::uint64_t scene_seed,
                                                          const SimRobotOptions& options = {});
  /// A robot over a given scene seen through `render` (tests: hand-made scenes). Reset()
  /// restores this scene. Errors: those of SceneRaycaster::Build.
  static core::Result<std::unique_ptr<SimRobot>> FromScene(SimScene scene,
                                                           const RenderOptions& render,
                                                           const SimRobotOptions& options = {});

  SimRobot(const SimRobot&) = delete;
  SimRobot& operator=(const SimRobot&) = delete;

  /// Executes one command and answers with its result (never throws for bad commands):
  /// - REJECTED (nothing moved) for a frame other than "camera"/"world", a position outside
  ///   workspace(), an approach tilted more than kMaxApproachTiltDeg from straight down, or
  ///   numbers the execution model refuses (opening beyond the stroke, force <= 0, ...);
  /// - SUCCEEDED when the object was lifted and held with deformation rate <= 0.2; it leaves the
  ///   scene and the view is re-rendered;
  /// - FAILED with the execution model's reason otherwise (collision, empty, too wide, several
  ///   objects, slipped) or when the lift crushed the object (deformation rate > 0.2: it was
  ///   lifted, so it also leaves the scene).
  /// object_id is the instance id touched ("" when none); execution_s is the wall time the
  /// simulation took. Thread-safe: commands run one at a time.
  bridge::GraspResult Execute(const bridge::GraspCommand& command);

  /// A new scene: generated robots draw GenerateScene(spec, seed), seed defaulting to the last
  /// seed + 1; FromScene robots restore their scene (seed ignored). Errors: GenerateScene's.
  core::Result<bridge::Ok> Reset(std::optional<std::uint64_t> seed = std::nullopt);

  /// The current view (cheap: a shared_ptr copy). Never null.
  std::shared_ptr<const SimRobotView> view() const;

  /// The box commands must fall in, in the camera frame C: the axis-aligned hull in C of the
  /// support's inner area grown by the options' margins (see SimRobotOptions).
  const bridge::Workspace& workspace() const { return workspace_; }

  /// The pose of a named frame in W, or nullopt for an unknown frame.
  std::optional<Eigen::Isometry3d> WorldFromFrame(const std::string& frame_id) const;

 private:
  SimRobot(SceneSpec spec, SimRobotOptions options) : spec_(std::move(spec)), options_(options) {}
  /// Renders the scene and publishes a new view. Caller holds mutex_.
  core::Result<bridge::Ok> PublishViewLocked();
  core::Result<bridge::Ok> AdoptLocked(GeneratedScene generated);
  bridge::GraspResult ExecuteLocked(const bridge::GraspCommand& command);

  SceneSpec spec_;  ///< render options (camera, noise) and, for generated robots, the scene draw
  SimRobotOptions options_;
  bridge::Workspace workspace_;
  bool generated_ = false;
  SimScene initial_scene_;  ///< FromScene robots: what Reset restores

  mutable std::mutex mutex_;  // guards everything below, and serialises Execute and Reset
  GeneratedScene current_;
  std::uint64_t noise_seed_ = 0;
  std::uint64_t generation_ = 0;
  nlohmann::json picked_ = nlohmann::json::array();

  // The published view has its own lock, so HTTP readers never wait for a grasp to finish.
  mutable std::mutex view_mutex_;
  std::shared_ptr<const SimRobotView> view_;
};

/// Outcome names of the execution model as a result reason prefix, e.g.
/// "collision: the left finger hits ...".
std::string FailureReason(const GraspExecution& execution);

}  // namespace softgrasp::sim
