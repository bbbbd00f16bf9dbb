#include "sim/robot/sim_robot.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "service/core/quaternion.h"

namespace softgrasp::sim {
namespace {

using Outcome = bridge::GraspOutcome;
using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

std::string Format(const Eigen::Vector3d& v) {
  std::ostringstream os;
  os.precision(4);
  os << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return os.str();
}

std::string FormatBox(const bridge::Workspace& w) {
  std::ostringstream os;
  os.precision(4);
  os << "[" << w.min_m[0] << ", " << w.max_m[0] << "] x [" << w.min_m[1] << ", " << w.max_m[1]
     << "] x [" << w.min_m[2] << ", " << w.max_m[2] << "] m in frame " << w.frame_id;
  return os.str();
}

// The support's inner area grown by the margins, as the axis-aligned hull of its 8 corners in C.
bridge::Workspace CameraWorkspace(const Support& support,
                                  const Eigen::Isometry3d& world_from_camera,
                                  const SimRobotOptions& options) {
  const double hx = support.inner_size_x_m / 2.0 + options.workspace_margin_m;
  const double hy = support.inner_size_y_m / 2.0 + options.workspace_margin_m;
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  bridge::Workspace w;
  w.frame_id = kCameraFrame;
  w.min_m.fill(std::numeric_limits<double>::infinity());
  w.max_m.fill(-std::numeric_limits<double>::infinity());
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner_w((i & 1) ? hx : -hx, (i & 2) ? hy : -hy,
                                   (i & 4) ? options.workspace_top_m : -options.workspace_floor_m);
    const Eigen::Vector3d corner_c = camera_from_world * corner_w;
    for (int k = 0; k < 3; ++k) {
      w.min_m[k] = std::min(w.min_m[k], corner_c[k]);
      w.max_m[k] = std::max(w.max_m[k], corner_c[k]);
    }
  }
  return w;
}

bridge::GraspResult Rejected(bridge::GraspResult result, std::string reason) {
  result.outcome = Outcome::kRejected;
  result.reason = std::move(reason);
  return result;
}

}  // namespace

std::string FailureReason(const GraspExecution& execution) {
  return std::string(GraspOutcomeName(execution.outcome)) + ": " + execution.reason;
}

core::Result<std::unique_ptr<SimRobot>> SimRobot::Generate(const SceneSpec& spec,
                                                           std::uint64_t scene_seed,
                                                           const SimRobotOptions& options) {
  auto generated = GenerateScene(spec, scene_seed);
  if (!generated.ok()) return generated.error();
  std::unique_ptr<SimRobot> robot(new SimRobot(spec, options));
  robot->generated_ = true;
  robot->workspace_ = CameraWorkspace(spec.support, spec.render.world_from_camera, robot->options_);
  std::lock_guard lock(robot->mutex_);
  if (auto adopted = robot->AdoptLocked(std::move(generated).value()); !adopted.ok()) {
    return adopted.error();
  }
  return robot;
}

core::Result<std::unique_ptr<SimRobot>> SimRobot::FromScene(SimScene scene,
                                                            const RenderOptions& render,
                                                            const SimRobotOptions& options) {
  SceneSpec spec;
  spec.support = scene.support;
  spec.render = render;
  std::unique_ptr<SimRobot> robot(new SimRobot(spec, options));
  robot->workspace_ = CameraWorkspace(scene.support, render.world_from_camera, robot->options_);
  robot->initial_scene_ = scene;
  std::lock_guard lock(robot->mutex_);
  GeneratedScene given;
  given.scene_seed = scene.seed;
  given.scene = std::move(scene);
  if (auto adopted = robot->AdoptLocked(std::move(given)); !adopted.ok()) return adopted.error();
  return robot;
}

core::Result<bridge::Ok> SimRobot::AdoptLocked(GeneratedScene generated) {
  current_ = std::move(generated);
  // Generated scenes were rendered with the noise stream SceneManifest names; given scenes use
  // the render options' seed as it is.
  noise_seed_ = generated_ ? SceneManifest(spec_, current_)["noise"]["seed"].get<std::uint64_t>()
                           : spec_.render.noise.seed;
  picked_ = json::array();
  ++generation_;
  return PublishViewLocked();
}

core::Result<bridge::Ok> SimRobot::PublishViewLocked() {
  auto raycaster = SceneRaycaster::Build(current_.scene);
  if (!raycaster.ok()) return raycaster.error();
  RenderOptions render = spec_.render;
  render.noise.seed = noise_seed_;
  current_.views = Render(raycaster.value(), render);

  auto view = std::make_shared<SimRobotView>();
  view->generation = generation_;
  view->scene_seed = current_.scene_seed;
  view->camera = spec_.render.camera;
  view->world_from_camera = spec_.render.world_from_camera;
  view->views = current_.views;
  view->manifest = SceneManifest(spec_, current_);
  view->manifest["noise"]["seed"] = noise_seed_;
  view->manifest["generation"] = generation_;
  view->manifest["objects_left"] = current_.scene.objects.size();
  view->manifest["picked"] = picked_;
  std::lock_guard lock(view_mutex_);
  view_ = std::move(view);
  return bridge::Ok{};
}

std::shared_ptr<const SimRobotView> SimRobot::view() const {
  std::lock_guard lock(view_mutex_);
  return view_;
}

std::optional<Eigen::Isometry3d> SimRobot::WorldFromFrame(const std::string& frame_id) const {
  if (frame_id == kCameraFrame) return spec_.render.world_from_camera;
  if (frame_id == kWorldFrame) return Eigen::Isometry3d::Identity();
  return std::nullopt;
}

core::Result<bridge::Ok> SimRobot::Reset(std::optional<std::uint64_t> seed) {
  std::lock_guard lock(mutex_);
  if (!generated_) {
    GeneratedScene given;
    given.scene_seed = initial_scene_.seed;
    given.scene = initial_scene_;
    return AdoptLocked(std::move(given));
  }
  auto generated = GenerateScene(spec_, seed.value_or(current_.scene_seed + 1));
  if (!generated.ok()) return generated.error();
  return AdoptLocked(std::move(generated).value());
}

bridge::GraspResult SimRobot::Execute(const bridge::GraspCommand& command) {
  const auto start = std::chrono::steady_clock::now();
  bridge::GraspResult result;
  {
    std::lock_guard lock(mutex_);
    result = ExecuteLocked(command);
  }
  result.execution_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.finished_unix_ns = bridge::UnixNowNs();
  return result;
}

bridge::GraspResult SimRobot::ExecuteLocked(const bridge::GraspCommand& command) {
  bridge::GraspResult result;
  result.command_id = command.command_id;
  result.robot_id = command.robot_id;

  const std::optional<Eigen::Isometry3d> world_from_frame = WorldFromFrame(command.frame_id);
  if (!world_from_frame) {
    return Rejected(result, "unknown frame '" + command.frame_id +
                                "': the simulated robot takes poses in 'camera' (the scene "
                                "camera's OpenCV frame) or 'world' (the scene's frame W)");
  }
  const Eigen::Vector3d p_FG(command.position_m[0], command.position_m[1], command.position_m[2]);
  const Eigen::Vector3d p_WG = *world_from_frame * p_FG;
  const Eigen::Vector3d p_CG = spec_.render.world_from_camera.inverse() * p_WG;
  if (!workspace_.Contains(kCameraFrame, {p_CG.x(), p_CG.y(), p_CG.z()})) {
    return Rejected(result, "position " + Format(p_CG) +
                                " m in frame camera is outside the workspace " +
                                FormatBox(workspace_));
  }
  const core::QuaternionWxyz q = core::WxyzFromXyzw(command.orientation_xyzw);
  const Eigen::Quaterniond q_FG = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  const Eigen::Vector3d approach_w = world_from_frame->linear() * (q_FG * Eigen::Vector3d::UnitZ());
  const double tilt_deg = std::acos(std::clamp(-approach_w.z(), -1.0, 1.0)) * 180.0 / kPi;
  if (!(tilt_deg <= kMaxApproachTiltDeg)) {
    std::ostringstream os;
    os.precision(3);
    os << "the approach axis is " << tilt_deg << " deg from straight down; the simulated gripper "
       << "approaches vertically (at most " << kMaxApproachTiltDeg << " deg)";
    return Rejected(result, os.str());
  }

  // SimGraspFromCamera reads the pose in whatever frame world_from_frame places.
  core::Grasp grasp;
  grasp.p_CG_m = {p_FG.x(), p_FG.y(), p_FG.z()};
  grasp.q_CG_wxyz = {q_FG.w(), q_FG.x(), q_FG.y(), q_FG.z()};
  grasp.opening_m = command.opening_width_m;
  const SimGrasp sim_grasp = SimGraspFromCamera(grasp, *world_from_frame);
  core::Gripper gripper = options_.gripper;
  gripper.closing_force_n = command.closing_force_n;

  auto execution = ExecuteAndRemove(&current_.scene, sim_grasp, gripper);
  if (!execution.ok()) {
    return Rejected(result,
                    "the simulated gripper cannot run this command: " + execution.error().message);
  }
  const GraspExecution& e = execution.value();
  result.object_id = e.instance_id > 0 ? std::to_string(e.instance_id) : "";
  result.contact_width_m = e.contact_width_m;
  result.grasped_width_m = e.grasped_width_m;
  result.deformation_rate = e.deformation_rate;
  if (e.succeeded()) {
    // Lifted: the object left the scene, whole or crushed.
    picked_.push_back(e.instance_id);
    ++generation_;
    if (auto rendered = PublishViewLocked(); !rendered.ok()) {
      result.outcome = Outcome::kFailed;
      result.reason =
          "picked, but the scene could not be rendered again: " + rendered.error().message;
      return result;
    }
  }
  if (e.succeeded() && !e.damaged) {
    result.outcome = Outcome::kSucceeded;
    result.reason = e.reason;
  } else if (e.succeeded()) {
    result.outcome = Outcome::kFailed;
    result.reason = "crushed: " + e.reason;
  } else {
    result.outcome = Outcome::kFailed;
    result.reason = FailureReason(e);
  }
  return result;
}

}  // namespace softgrasp::sim
