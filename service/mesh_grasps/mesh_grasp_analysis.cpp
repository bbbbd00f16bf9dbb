#include "service/mesh_grasps/mesh_grasp_analysis.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include "service/raycast/raycast.h"

namespace softgrasp::mesh {
namespace {

using core::ErrorCode;
using core::MakeError;
using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::optional<core::Error> CheckOptions(const MeshGraspOptions& o) {
  const auto bad = [](const char* field, const std::string& what) {
    return MakeError(ErrorCode::kInvalidArgument, std::string(field) + " " + what, field);
  };
  if (!std::isfinite(o.friction_coefficient) || o.friction_coefficient < 0.0) {
    return bad("friction_coefficient", "must be finite and >= 0");
  }
  if (o.num_grasps < 1) return bad("num_grasps", "must be >= 1");
  if (o.robust_samples < 0) return bad("robust_samples", "must be >= 0");
  if (!std::isfinite(o.min_pose_probability) || o.min_pose_probability < 0.0 ||
      o.min_pose_probability >= 1.0) {
    return bad("min_pose_probability", "must be in [0, 1)");
  }
  if (!std::isfinite(o.approach_distance_m) || o.approach_distance_m < 0.0) {
    return bad("approach_distance_m", "must be finite and >= 0");
  }
  if (!std::isfinite(o.table_clearance_m) || o.table_clearance_m < 0.0) {
    return bad("table_clearance_m", "must be finite and >= 0");
  }
  if (!std::isfinite(o.max_approach_table_angle_rad) || o.max_approach_table_angle_rad < 0.0) {
    return bad("max_approach_table_angle_rad", "must be finite and >= 0");
  }
  if (o.approach_offsets_rad.empty()) return bad("approach_offsets_rad", "must not be empty");
  for (const double a : o.approach_offsets_rad) {
    if (!std::isfinite(a)) return bad("approach_offsets_rad", "must be finite");
  }
  return std::nullopt;
}

GraspInPose CheckInPose(const GripperCollisionChecker& checker, const JawGrasp& grasp,
                        const StablePose& pose, const MeshGraspOptions& options) {
  const TopDownApproach nominal = ApproachFromAbove(grasp, pose);
  const TableInObject table = TableInObject::Under(pose, options.table_clearance_m);
  GraspInPose out;
  out.approach_table_angle_rad = nominal.table_angle_rad;
  out.aligned = nominal.table_angle_rad <= options.max_approach_table_angle_rad;
  out.approach_o = nominal.approach_o;
  for (const double offset : options.approach_offsets_rad) {
    const Eigen::Vector3d approach = RotateApproach(grasp, nominal.approach_o, offset);
    if (!checker.Collides(GripperPose(grasp, approach), &table)) {
      out.collision_free = true;
      out.approach_offset_rad = offset;
      out.approach_o = approach;
      break;
    }
  }
  return out;
}

// The extent of `points` along the unit direction `d`.
double WidthAlong(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& d) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const Eigen::Vector3d& p : points) {
    const double t = p.dot(d);
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  return hi - lo;
}

// Pattern search on the sphere from `d`: tilts of `step` about two axes across it, the step
// halved when none narrows the width, down to 1e-5 rad.
double RefinedWidth(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d d) {
  double best = WidthAlong(points, d);
  for (double step = 0.05; step > 1e-5;) {
    const Eigen::Vector3d u = d.unitOrthogonal();
    const Eigen::Vector3d v = d.cross(u);
    bool improved = false;
    for (const Eigen::Vector3d& tilt : {u, Eigen::Vector3d(-u), v, Eigen::Vector3d(-v)}) {
      const Eigen::Vector3d candidate = (d + step * tilt).normalized();
      const double w = WidthAlong(points, candidate);
      if (w < best) {
        best = w;
        d = candidate;
        improved = true;
        break;
      }
    }
    if (!improved) step /= 2;
  }
  return best;
}

std::string Mm(double metres) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f mm", metres * 1000.0);
  return text;
}

bool Usable(const AnalysedGrasp& g) {
  for (const GraspInPose& p : g.poses) {
    if (p.aligned && p.collision_free) return true;
  }
  return false;
}

}  // namespace

const char* NoGraspReasonName(NoGraspReason reason) {
  switch (reason) {
    case NoGraspReason::kWiderThanStroke:
      return "wider_than_stroke";
    case NoGraspReason::kNoAntipodalPair:
      return "no_antipodal_pair";
    case NoGraspReason::kNoForceClosure:
      return "no_force_closure";
    case NoGraspReason::kCollidesInEveryPose:
      return "collides_in_every_pose";
  }
  return "wider_than_stroke";
}

double NarrowestWidthM(const TriangleMesh& mesh) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) points.emplace_back(v[0], v[1], v[2]);
  if (points.empty()) return 0.0;
  // Directions over a hemisphere (a width is the same both ways), Fibonacci-spaced, and the
  // faces' normals (a box is narrowest across a face); the narrowest few are refined.
  constexpr int kDirections = 1024;
  std::vector<std::pair<double, Eigen::Vector3d>> tried;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < kDirections; ++i) {
    const double z = (i + 0.5) / kDirections;
    const double r = std::sqrt(1.0 - z * z);
    const Eigen::Vector3d d(r * std::cos(golden * i), r * std::sin(golden * i), z);
    tried.emplace_back(WidthAlong(points, d), d);
  }
  // Up to 512 faces' normals, spread over the face list.
  const std::size_t stride = std::max<std::size_t>(1, mesh.faces.size() / 512);
  for (std::size_t i = 0; i < mesh.faces.size(); i += stride) {
    const auto& f = mesh.faces[i];
    const Eigen::Vector3d& a = points[static_cast<std::size_t>(f[0])];
    const Eigen::Vector3d n = (points[static_cast<std::size_t>(f[1])] - a)
                                  .cross(points[static_cast<std::size_t>(f[2])] - a);
    if (n.norm() > 0) tried.emplace_back(WidthAlong(points, n.normalized()), n.normalized());
  }
  constexpr std::size_t kRefined = 8;
  const std::size_t refined = std::min(kRefined, tried.size());
  std::partial_sort(tried.begin(), tried.begin() + static_cast<std::ptrdiff_t>(refined),
                    tried.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double best = tried.front().first;
  for (std::size_t i = 0; i < refined; ++i) {
    best = std::min(best, RefinedWidth(points, tried[i].second));
  }
  return best;
}

std::optional<NoGrasp> WhyNoGrasp(const TriangleMesh& mesh, const MeshGraspAnalysis& analysis,
                                  const MeshGraspOptions& options) {
  if (std::any_of(analysis.grasps.begin(), analysis.grasps.end(),
                  [](const AnalysedGrasp& g) { return g.ferrari_canny > 0.0 && Usable(g); })) {
    return std::nullopt;
  }
  NoGrasp out;
  out.narrowest_width_m = NarrowestWidthM(mesh);
  const double stroke = options.gripper.opening_m;
  if (out.narrowest_width_m > stroke) {
    out.needed_stroke_m = std::ceil(out.narrowest_width_m * 1000.0 - 1e-9) / 1000.0;
  }
  if (analysis.grasps.empty() && out.needed_stroke_m) {
    out.reason = NoGraspReason::kWiderThanStroke;
    out.message = "the object is " + Mm(out.narrowest_width_m) +
                  " at its narrowest, wider than the " + Mm(stroke) +
                  " stroke in every direction: it needs a stroke of at least " +
                  Mm(*out.needed_stroke_m);
  } else if (analysis.grasps.empty()) {
    out.reason = NoGraspReason::kNoAntipodalPair;
    out.message = "no two surface points within the " + Mm(stroke) +
                  " stroke face each other inside the friction cone at friction_coefficient " +
                  std::to_string(options.friction_coefficient).substr(0, 5) + " (the object is " +
                  Mm(out.narrowest_width_m) + " at its narrowest)";
  } else if (std::none_of(analysis.grasps.begin(), analysis.grasps.end(),
                          [](const AnalysedGrasp& g) { return g.ferrari_canny > 0.0; })) {
    out.reason = NoGraspReason::kNoForceClosure;
    out.message = "none of the " + std::to_string(analysis.grasps.size()) +
                  " antipodal grasps is in force closure at friction_coefficient " +
                  std::to_string(options.friction_coefficient).substr(0, 5);
  } else {
    out.reason = NoGraspReason::kCollidesInEveryPose;
    out.message = "in each of the " + std::to_string(analysis.poses.size()) +
                  " stable poses every grasp in force closure is either not approachable from "
                  "above or collides with the table or the gripper's body on the way in";
  }
  if (out.needed_stroke_m && out.reason != NoGraspReason::kWiderThanStroke) {
    // Grasps were found on edges or corners, but the object's body is wider than the stroke.
    out.message += "; the object is " + Mm(out.narrowest_width_m) + " at its narrowest, and a " +
                   Mm(*out.needed_stroke_m) + " stroke would fit it";
  }
  return out;
}

core::Result<MeshGraspAnalysis> AnalyseMeshGrasps(const TriangleMesh& mesh_o,
                                                  const MeshGraspOptions& options) {
  if (auto error = CheckOptions(options)) return *error;
  const Clock::time_point start = Clock::now();
  MeshGraspAnalysis analysis;

  analysis.center_of_mass_m = VolumeCentroid(mesh_o);
  if (!analysis.center_of_mass_m.allFinite()) {
    return MakeError(ErrorCode::kUnprocessable,
                     "the mesh encloses no positive volume (open, inside out or flat)", "mesh");
  }
  StablePoseOptions pose_options;
  pose_options.min_probability = options.min_pose_probability;
  pose_options.center_of_mass = analysis.center_of_mass_m;
  auto poses = ComputeStablePoses(mesh_o, pose_options);
  if (!poses.ok()) return poses.error();
  analysis.poses = std::move(poses).value();
  if (analysis.poses.empty()) {
    return MakeError(ErrorCode::kUnprocessable,
                     "no stable pose has a probability above min_pose_probability",
                     "min_pose_probability");
  }
  analysis.timing.stable_poses_ms = MsSince(start);

  Clock::time_point phase = Clock::now();
  const std::vector<raycast::Surface> surfaces{{0, &mesh_o, Eigen::Isometry3d::Identity()}};
  auto caster = raycast::MeshRaycaster::Build(surfaces);
  if (!caster.ok()) return caster.error();
  AntipodalParams sampling;
  sampling.friction_coefficient = options.friction_coefficient;
  sampling.max_width_m = options.gripper.opening_m;
  sampling.target_num_grasps = options.num_grasps;
  sampling.max_surface_points = std::max(4000, 40 * options.num_grasps);
  sampling.seed = options.seed;
  auto grasps = SampleAntipodalGrasps(mesh_o, caster.value(), sampling);
  if (!grasps.ok()) return grasps.error();
  analysis.timing.sampling_ms = MsSince(phase);

  phase = Clock::now();
  QualityParams quality = options.quality;
  quality.friction_coefficient = options.friction_coefficient;
  RobustParams robust = options.robust;
  robust.num_samples = options.robust_samples;
  const raycast::MeshRaycaster& surface = caster.value();
  const ContactQuery query = [&surface](const Eigen::Vector3d& center, const Eigen::Vector3d& axis,
                                        double max_width) {
    return CloseJaws(surface, center, axis, max_width);
  };
  for (std::size_t i = 0; i < grasps.value().size(); ++i) {
    AnalysedGrasp analysed;
    analysed.grasp = grasps.value()[i];
    analysed.sample_index = static_cast<int>(i);
    analysed.ferrari_canny =
        FerrariCannyL1(analysed.grasp.a, analysed.grasp.b, analysis.center_of_mass_m, quality);
    if (options.robust_samples > 0) {
      // Each grasp draws its own noise stream, so a grasp's value does not depend on how many
      // grasps came before it.
      robust.seed = options.seed ^ (0x9E3779B97F4A7C15ull * (i + 1));
      analysed.robust_ferrari_canny =
          RobustFerrariCannyL1(analysed.grasp.center_m, analysed.grasp.axis,
                               options.gripper.opening_m, query, analysis.center_of_mass_m, quality,
                               robust)
              .mean;
    }
    analysis.grasps.push_back(std::move(analysed));
  }
  analysis.timing.quality_ms = MsSince(phase);

  phase = Clock::now();
  auto checker =
      GripperCollisionChecker::Build(mesh_o, options.gripper, options.approach_distance_m);
  if (!checker.ok()) return checker.error();
  for (AnalysedGrasp& analysed : analysis.grasps) {
    for (const StablePose& pose : analysis.poses) {
      analysed.poses.push_back(CheckInPose(checker.value(), analysed.grasp, pose, options));
    }
  }
  analysis.timing.collisions_ms = MsSince(phase);

  std::stable_sort(analysis.grasps.begin(), analysis.grasps.end(),
                   [](const AnalysedGrasp& a, const AnalysedGrasp& b) {
                     return a.robust_ferrari_canny.value_or(a.ferrari_canny) >
                            b.robust_ferrari_canny.value_or(b.ferrari_canny);
                   });
  analysis.no_grasp = WhyNoGrasp(mesh_o, analysis, options);
  analysis.timing.total_ms = MsSince(start);
  return analysis;
}

core::Result<MeshFileAnalysis> AnalyseMeshFile(std::string_view bytes, const MeshFileJob& job) {
  MeshFileAnalysis out;
  Clock::time_point phase = Clock::now();
  auto format = SniffMeshFormat(bytes);
  if (!format.ok()) return format.error();
  out.format = format.value();
  MeshReadOptions read;
  read.max_faces = job.prepare.max_triangles;
  read.max_vertices = 3 * job.prepare.max_triangles;
  auto decoded = ReadMesh(bytes, read);
  if (!decoded.ok()) return decoded.error();
  out.decode_ms = MsSince(phase);

  phase = Clock::now();
  auto prepared = PrepareMesh(std::move(decoded).value(), job.prepare);
  if (!prepared.ok()) return prepared.error();
  out.prepared = std::move(prepared).value();
  out.prepare_ms = MsSince(phase);

  auto analysis = AnalyseMeshGrasps(out.prepared.mesh, job.analysis);
  if (!analysis.ok()) return analysis.error();
  out.analysis = std::move(analysis).value();
  return out;
}

core::Result<PoseView> RenderPoseView(const TriangleMesh& mesh_o, const MeshGraspAnalysis& analysis,
                                      int pose_index, const GripperBoxes& gripper, int size_px,
                                      int max_grasps) {
  if (pose_index < 0 || pose_index >= static_cast<int>(analysis.poses.size())) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "pose " + std::to_string(pose_index) + " is out of range (the mesh has " +
                         std::to_string(analysis.poses.size()) + " stable poses)",
                     "pose");
  }
  if (size_px < 16 || size_px > 4096) {
    return MakeError(ErrorCode::kInvalidArgument, "the image size must be in [16, 4096] px",
                     "size_px");
  }
  const StablePose& pose = analysis.poses[static_cast<std::size_t>(pose_index)];
  Eigen::Isometry3d table_from_object = Eigen::Isometry3d::Identity();
  table_from_object.linear() = pose.table_from_object_rotation;
  table_from_object.translation() = pose.table_from_object_translation;

  // Frame the bounding sphere about the centre of mass.
  const Eigen::Vector3d com_t = table_from_object * analysis.center_of_mass_m;
  double radius_m = 0.0;
  double top_m = 0.0;
  for (const auto& v : mesh_o.vertices) {
    const Eigen::Vector3d p_t = table_from_object * Eigen::Vector3d(v[0], v[1], v[2]);
    radius_m = std::max(radius_m, (p_t - com_t).norm());
    top_m = std::max(top_m, p_t.z());
  }
  PoseView view;
  view.camera.width = size_px;
  view.camera.height = size_px;
  view.camera.fx = view.camera.fy = 1.1 * size_px;  // about 49 degrees field of view
  view.camera.cx = view.camera.cy = 0.5 * size_px - 0.5;
  const double fill = 0.8;
  const double distance_m = view.camera.fx * radius_m / (fill * 0.5 * size_px);
  // Camera axes in the table frame: x -> +x, y (image down) -> -y, optical axis -> -z.
  view.table_from_camera.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  view.table_from_camera.translation() =
      Eigen::Vector3d(com_t.x(), com_t.y(), std::max(com_t.z() + distance_m, top_m + 0.01));

  const std::vector<raycast::Surface> surfaces{{0, &mesh_o, table_from_object}};
  auto caster = raycast::MeshRaycaster::Build(surfaces);
  if (!caster.ok()) return caster.error();
  view.depth = raycast::RenderDepth(caster.value(), view.camera, view.table_from_camera);

  const Eigen::Isometry3d camera_from_object = view.table_from_camera.inverse() * table_from_object;
  for (const AnalysedGrasp& analysed : analysis.grasps) {
    if (static_cast<int>(view.grasps.size()) >= max_grasps) break;
    const GraspInPose& in_pose = analysed.poses[static_cast<std::size_t>(pose_index)];
    if (!in_pose.aligned || !in_pose.collision_free) continue;
    const Eigen::Vector3d center_c = camera_from_object * analysed.grasp.center_m;
    const Eigen::Vector3d axis_c = camera_from_object.linear() * analysed.grasp.axis;
    if (!(center_c.z() > 0.0)) continue;
    const double px_per_m = view.camera.fx / center_c.z();
    core::Grasp g;
    g.center_u_px = view.camera.cx + view.camera.fx * center_c.x() / center_c.z();
    g.center_v_px = view.camera.cy + view.camera.fy * center_c.y() / center_c.z();
    double angle = std::atan2(axis_c.y(), axis_c.x());
    if (angle < 0.0) angle += std::numbers::pi;
    if (angle >= std::numbers::pi) angle -= std::numbers::pi;
    g.angle_rad = angle;
    // Drawn closed on the object: the fingers at the contacts.
    g.opening_m = analysed.grasp.width_m;
    g.opening_px = analysed.grasp.width_m * px_per_m;
    g.finger_width_px = gripper.finger_width_m * px_per_m;
    g.finger_thickness_px = gripper.finger_thickness_m * px_per_m;
    g.score = analysed.robust_ferrari_canny.value_or(analysed.ferrari_canny);
    g.p_CG_m = {center_c.x(), center_c.y(), center_c.z()};
    view.grasps.push_back(g);
  }
  return view;
}

}  // namespace softgrasp::mesh
