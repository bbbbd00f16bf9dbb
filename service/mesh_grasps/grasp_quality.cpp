#include "service/mesh_grasps/grasp_quality.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

extern "C" {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wshadow"
#include <glpk.h>
#include <libqhull_r/qhull_ra.h>
#pragma GCC diagnostic pop
}

namespace softgrasp::mesh {
namespace {

using Wrenches = Eigen::Matrix<double, 6, Eigen::Dynamic>;

bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

void CheckParams(const QualityParams& p) {
  if (!std::isfinite(p.friction_coefficient) || p.friction_coefficient < 0.0) {
    throw std::invalid_argument("grasp quality: friction coefficient must be finite and >= 0");
  }
  if (p.num_cone_faces < 3) {
    throw std::invalid_argument("grasp quality: num_cone_faces must be >= 3");
  }
  if (!std::isfinite(p.torque_scaling) || p.torque_scaling <= 0.0) {
    throw std::invalid_argument("grasp quality: torque_scaling must be finite and > 0");
  }
  if (!std::isfinite(p.finger_radius_m) || p.finger_radius_m < 0.0) {
    throw std::invalid_argument("grasp quality: finger_radius_m must be finite and >= 0");
  }
}

/// Contacts usable for wrenches: finite points, finite non-zero normals.
bool UsableContacts(const Contact& a, const Contact& b) {
  for (const Contact* c : {&a, &b}) {
    if (!Finite(c->point_m) || !Finite(c->inward_normal)) return false;
    const double norm = c->inward_normal.norm();
    if (!(norm > 0.0) || !std::isfinite(norm)) return false;
  }
  return true;
}

/// The part of `reference` orthogonal to unit `n`, normalised, if it is not negligible.
std::optional<Eigen::Vector3d> OrthogonalPart(const Eigen::Vector3d& n,
                                              const Eigen::Vector3d& reference) {
  const double ref_norm = reference.norm();
  if (!(ref_norm > 0.0) || !std::isfinite(ref_norm)) return std::nullopt;
  const Eigen::Vector3d r = reference / ref_norm;
  const Eigen::Vector3d t = r - r.dot(n) * n;
  const double t_norm = t.norm();
  if (!(t_norm > 1e-9)) return std::nullopt;
  return t / t_norm;
}

/// t1 for a contact with unit normal n (see the header: tangent basis).
Eigen::Vector3d FirstTangent(const Eigen::Vector3d& n, const Eigen::Vector3d& point,
                             const Eigen::Vector3d& other_point,
                             const Eigen::Vector3d& other_normal,
                             const Eigen::Vector3d& center_of_mass) {
  if (auto t = OrthogonalPart(n, other_point - point)) return *t;
  if (auto t = OrthogonalPart(n, center_of_mass - point)) return *t;
  if (auto t = OrthogonalPart(n, other_normal)) return *t;
  int axis = 0;
  for (int i = 1; i < 3; ++i) {
    if (std::abs(n[i]) < std::abs(n[axis])) axis = i;
  }
  return *OrthogonalPart(n, Eigen::Vector3d::Unit(axis));
}

/// What one Qhull run found.
enum class HullOutcome { kFailed, kOriginNotInside, kOriginInside };

/// Runs Qhull on the 6-D points with `flags`. kOriginInside sets `distance` to the smallest
/// distance from the origin to a facet hyperplane. With `verify`, a facet that some point lies
/// beyond by more than `tolerance` makes the run kFailed (unmerged hulls may be slightly
/// non-convex). Qhull's messages go to a private memory stream that is discarded.
HullOutcome RunQhull(std::vector<coordT>& points, int count, const char* flags, bool verify,
                     double tolerance, double& distance) {
  char* message_buffer = nullptr;
  std::size_t message_size = 0;
  FILE* errfile = open_memstream(&message_buffer, &message_size);
  if (errfile == nullptr) return HullOutcome::kFailed;

  qhT qh_storage;
  qhT* qh = &qh_storage;
  qh_zero(qh, errfile);
  std::string command = flags;
  const int exit_code =
      qh_new_qhull(qh, 6, count, points.data(), False, command.data(), nullptr, errfile);

  HullOutcome outcome = HullOutcome::kFailed;
  if (exit_code == 0) {
    double min_distance = std::numeric_limits<double>::infinity();
    bool inside = true;
    bool valid = true;
    int facets = 0;
    for (facetT* facet = qh->facet_list; facet != nullptr && facet->next != nullptr;
         facet = facet->next) {
      ++facets;
      // Outward unit normal, offset: normal . x + offset = 0 on the hyperplane, < 0 inside.
      const double offset = facet->offset;
      if (!std::isfinite(offset)) {
        valid = false;
        break;
      }
      if (verify) {
        for (int j = 0; j < count && valid; ++j) {
          double side = offset;
          for (int i = 0; i < 6; ++i) {
            side += facet->normal[i] * points[static_cast<std::size_t>(6 * j + i)];
          }
          valid = side <= tolerance;
        }
        if (!valid) break;
      }
      if (offset >= -tolerance) inside = false;
      min_distance = std::min(min_distance, -offset);
    }
    if (valid && facets > 0) {
      outcome = inside ? HullOutcome::kOriginInside : HullOutcome::kOriginNotInside;
      distance = min_distance;
    }
  }

  qh_freeqhull(qh, !qh_ALL);
  int curlong = 0;
  int totlong = 0;
  qh_memfreeshort(qh, &curlong, &totlong);
  std::fclose(errfile);
  std::free(message_buffer);
  return outcome;
}

/// Distance from the origin to the boundary of conv(columns) if the origin is strictly inside,
/// else 0. Qhull first runs without merging ("Q0", several times faster on these small, nearly
/// degenerate sets) and its facets are checked to support every point; if that run fails or a
/// check fails, Qhull runs again with its default merging of coplanar facets.
/// True when a direction u with w_j . u <= tolerance |u| for every column is found, i.e. the
/// wrench hull lies in a half-space whose boundary passes within `tolerance` of the origin: the
/// origin is then not inside by more than the tolerance and the quality is 0 without a hull.
/// GLPK's simplex looks for u with w_j . u <= 0 and (sum_j w_j) . u = -1, which is feasible
/// exactly when the origin is not interior (for a full-dimensional set); its answer is then
/// checked on the columns themselves, so a rounding in the solver can only send the case on to
/// Qhull, never decide it.
bool OriginSeparated(const Wrenches& w, double tolerance) {
  const int m = static_cast<int>(w.cols());
  glp_prob* lp = glp_create_prob();
  glp_add_cols(lp, 6);
  for (int i = 1; i <= 6; ++i) glp_set_col_bnds(lp, i, GLP_FR, 0.0, 0.0);
  glp_add_rows(lp, m + 1);
  std::vector<int> rows(1), cols(1);
  std::vector<double> values(1);  // GLPK's arrays start at index 1
  const Eigen::Matrix<double, 6, 1> sum = w.rowwise().sum();
  for (int j = 0; j <= m; ++j) {
    if (j < m) {
      glp_set_row_bnds(lp, j + 1, GLP_UP, 0.0, 0.0);
    } else {
      glp_set_row_bnds(lp, j + 1, GLP_FX, -1.0, -1.0);
    }
    for (int i = 0; i < 6; ++i) {
      rows.push_back(j + 1);
      cols.push_back(i + 1);
      values.push_back(j < m ? w(i, j) : sum[i]);
    }
  }
  glp_load_matrix(lp, static_cast<int>(values.size()) - 1, rows.data(), cols.data(), values.data());
  glp_smcp options;
  glp_init_smcp(&options);
  options.msg_lev = GLP_MSG_OFF;
  Eigen::Matrix<double, 6, 1> u = Eigen::Matrix<double, 6, 1>::Zero();
  const bool feasible = glp_simplex(lp, &options) == 0 && glp_get_status(lp) == GLP_OPT;
  if (feasible) {
    for (int i = 0; i < 6; ++i) u[i] = glp_get_col_prim(lp, i + 1);
  }
  glp_delete_prob(lp);
  const double norm = u.norm();
  if (!feasible || !(norm > 0.0) || !std::isfinite(norm)) return false;
  return (w.transpose() * u).maxCoeff() <= tolerance * norm;
}

double HullQuality(const Wrenches& w) {
  const Eigen::Index m = w.cols();
  if (m < 7 || !w.allFinite()) return 0.0;
  const double scale = w.colwise().norm().maxCoeff();
  if (!(scale > 0.0)) return 0.0;

  // Full dimension first: a flat wrench set (rank of the centred columns < 6) cannot hold the
  // origin in its interior, and Qhull would only report a flat initial simplex.
  const Eigen::Matrix<double, 6, 1> mean = w.rowwise().mean();
  const Wrenches centred = w.colwise() - mean;
  const Eigen::JacobiSVD<Wrenches> svd(centred);
  const auto& sv = svd.singularValues();
  if (!(sv[5] > 1e-10 * sv[0])) return 0.0;

  const double tolerance = 1e-12 * scale;
  // Most noisy samples of a grasp are not in force closure: prove those 0 by a separating
  // direction (a small linear programme) before building a hull.
  if (OriginSeparated(w, tolerance)) return 0.0;

  std::vector<coordT> points(static_cast<std::size_t>(6 * m));
  for (Eigen::Index j = 0; j < m; ++j) {
    for (int i = 0; i < 6; ++i) points[static_cast<std::size_t>(6 * j + i)] = w(i, j);
  }
  const int count = static_cast<int>(m);
  double distance = 0.0;
  HullOutcome outcome = RunQhull(points, count, "qhull Q0", true, tolerance, distance);
  if (outcome == HullOutcome::kFailed) {
    outcome = RunQhull(points, count, "qhull", false, tolerance, distance);
  }
  return outcome == HullOutcome::kOriginInside ? distance : 0.0;
}

/// exp([xi]x): Rodrigues; exactly the identity for xi = 0.
Eigen::Matrix3d ExpMap(const Eigen::Vector3d& xi) {
  const double angle = xi.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, xi / angle).toRotationMatrix();
}

/// A double in [0, 1) from the top 53 bits of one engine output.
double Uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// A standard normal from two engine outputs (Box-Muller, cosine branch).
double StandardNormal(std::mt19937_64& rng) {
  const double u1 = Uniform01(rng);
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log1p(-u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

Eigen::Vector3d NormalVector(std::mt19937_64& rng, double sigma) {
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) v[i] = sigma * StandardNormal(rng);
  return v;
}

void CheckSigma(double sigma, const char* name) {
  if (!std::isfinite(sigma) || sigma < 0.0) {
    throw std::invalid_argument(std::string("robust grasp quality: ") + name +
                                " must be finite and >= 0");
  }
}

}  // namespace

bool ForceClosure(const Contact& a, const Contact& b, double friction_coefficient) {
  if (!std::isfinite(friction_coefficient) || friction_coefficient < 0.0) return false;
  if (!UsableContacts(a, b)) return false;
  const Eigen::Vector3d line = b.point_m - a.point_m;
  const double length = line.norm();
  if (!(length > 0.0) || !std::isfinite(length)) return false;
  const double max_angle = std::atan(friction_coefficient);
  const auto within = [&](const Eigen::Vector3d& normal, const Eigen::Vector3d& to_other) {
    const Eigen::Vector3d n = normal.normalized();
    const Eigen::Vector3d d = to_other / length;
    // atan2 of |n x d| and n . d: accurate at small angles, where acos is not.
    const double angle = std::atan2(n.cross(d).norm(), n.dot(d));
    return angle <= max_angle;
  };
  return within(a.inward_normal, line) && within(b.inward_normal, -line);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> GraspMatrix(const Contact& a, const Contact& b,
                                                     const Eigen::Vector3d& center_of_mass_m,
                                                     const QualityParams& params) {
  CheckParams(params);
  if (!UsableContacts(a, b) || !Finite(center_of_mass_m)) {
    throw std::invalid_argument("GraspMatrix: non-finite point or zero or non-finite normal");
  }
  const int k = params.num_cone_faces;
  const double mu = params.friction_coefficient;
  const double s = params.torque_scaling;
  const int columns = 2 * k + (params.soft_fingers ? 4 : 0);
  Wrenches g(6, columns);

  const std::array<const Contact*, 2> contacts{&a, &b};
  std::array<Eigen::Vector3d, 2> normals{a.inward_normal.normalized(),
                                         b.inward_normal.normalized()};
  for (int c = 0; c < 2; ++c) {
    const Contact& self = *contacts[static_cast<std::size_t>(c)];
    const Contact& other = *contacts[static_cast<std::size_t>(1 - c)];
    const Eigen::Vector3d& n = normals[static_cast<std::size_t>(c)];
    const Eigen::Vector3d t1 = FirstTangent(
        n, self.point_m, other.point_m, normals[static_cast<std::size_t>(1 - c)], center_of_mass_m);
    const Eigen::Vector3d t2 = n.cross(t1);
    const Eigen::Vector3d arm = self.point_m - center_of_mass_m;
    for (int j = 0; j < k; ++j) {
      const double theta = 2.0 * std::numbers::pi * j / k;
      const Eigen::Vector3d f =
          (n + mu * (std::cos(theta) * t1 + std::sin(theta) * t2)).normalized();
      g.col(c * k + j) << f, s * arm.cross(f);
    }
  }
  if (params.soft_fingers) {
    const double torsion =
        s * std::numbers::pi * params.finger_radius_m * params.finger_radius_m * mu;
    for (int c = 0; c < 2; ++c) {
      const Eigen::Vector3d t = torsion * normals[static_cast<std::size_t>(c)];
      g.col(2 * k + c) << Eigen::Vector3d::Zero(), t;
      g.col(2 * k + 2 + c) << Eigen::Vector3d::Zero(), -t;
    }
  }
  return g;
}

double FerrariCannyL1(const Eigen::Matrix<double, 6, Eigen::Dynamic>& wrenches) {
  return HullQuality(wrenches);
}

double FerrariCannyL1(const Contact& a, const Contact& b, const Eigen::Vector3d& center_of_mass_m,
                      const QualityParams& params) {
  CheckParams(params);
  if (!UsableContacts(a, b) || !Finite(center_of_mass_m)) return 0.0;
  return HullQuality(GraspMatrix(a, b, center_of_mass_m, params));
}

RobustQuality RobustFerrariCannyL1(const Eigen::Vector3d& center_m,
                                   const Eigen::Vector3d& axis_unit, double max_width_m,
                                   const ContactQuery& query,
                                   const Eigen::Vector3d& center_of_mass_m,
                                   const QualityParams& params, const RobustParams& robust) {
  CheckParams(params);
  if (robust.num_samples < 1) {
    throw std::invalid_argument("robust grasp quality: num_samples must be >= 1");
  }
  CheckSigma(robust.gripper_translation_sigma_m, "gripper_translation_sigma_m");
  CheckSigma(robust.gripper_rotation_sigma_rad, "gripper_rotation_sigma_rad");
  CheckSigma(robust.object_translation_sigma_m, "object_translation_sigma_m");
  CheckSigma(robust.object_rotation_sigma_rad, "object_rotation_sigma_rad");
  CheckSigma(robust.friction_sigma, "friction_sigma");
  const double axis_norm = axis_unit.norm();
  if (!Finite(axis_unit) || !(axis_norm > 0.0) || !std::isfinite(axis_norm)) {
    throw std::invalid_argument("robust grasp quality: axis must be finite and non-zero");
  }
  if (!Finite(center_m) || !Finite(center_of_mass_m)) {
    throw std::invalid_argument("robust grasp quality: centre and centre of mass must be finite");
  }
  if (!query) throw std::invalid_argument("robust grasp quality: no contact query");
  const Eigen::Vector3d axis = axis_unit / axis_norm;
  const Eigen::Vector3d& c = center_of_mass_m;

  std::mt19937_64 rng(robust.seed);
  RobustQuality result;
  result.samples.reserve(static_cast<std::size_t>(robust.num_samples));
  double sum = 0.0;
  for (int i = 0; i < robust.num_samples; ++i) {
    const Eigen::Vector3d xi_g = NormalVector(rng, robust.gripper_rotation_sigma_rad);
    const Eigen::Vector3d t_g = NormalVector(rng, robust.gripper_translation_sigma_m);
    const Eigen::Vector3d xi_o = NormalVector(rng, robust.object_rotation_sigma_rad);
    const Eigen::Vector3d t_o = NormalVector(rng, robust.object_translation_sigma_m);
    const double mu =
        std::max(0.0, params.friction_coefficient + robust.friction_sigma * StandardNormal(rng));

    const Eigen::Matrix3d r_o_inv = ExpMap(xi_o).transpose();
    const Eigen::Vector3d gripper_center = center_m + t_g;
    // c + R^T (x - c - t) written as x + (R^T - I)(x - c) - R^T t, which is exactly x when the
    // object noise is zero.
    const Eigen::Vector3d sample_center =
        gripper_center + (r_o_inv - Eigen::Matrix3d::Identity()) * (gripper_center - c) -
        r_o_inv * t_o;
    const Eigen::Vector3d sample_axis = r_o_inv * (ExpMap(xi_g) * axis);

    double quality = 0.0;
    if (const auto contacts = query(sample_center, sample_axis, max_width_m)) {
      QualityParams sample_params = params;
      sample_params.friction_coefficient = mu;
      quality = FerrariCannyL1(contacts->first, contacts->second, c, sample_params);
    }
    result.samples.push_back(quality);
    sum += quality;
  }
  result.mean = sum / robust.num_samples;
  return result;
}

}  // namespace softgrasp::mesh
