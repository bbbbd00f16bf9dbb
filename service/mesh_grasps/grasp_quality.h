#pragma once
/// Analytic quality of a two-contact (parallel-jaw) grasp on a rigid object, after Dex-Net 2.0
/// (`PointGraspMetrics3D` in dex-net's quality.py, `RobustPointGraspMetrics3D` and its random
/// variables): force closure, the Ferrari-Canny L1 metric and its mean under pose and friction
/// noise ("robust Ferrari-Canny").
///
/// Units: metres, radians, newtons; all points and directions in one frame (the object's).
/// The functions are pure: no I/O, nothing printed (Qhull's messages go to a private buffer that is
/// thrown away, GLPK's are turned off), deterministic for a given seed.
///
/// Wrenches. At a contact with point p, inward unit normal n and friction coefficient mu the
/// friction cone is linearised into K = `num_cone_faces` unit forces
///   f_k = normalise(n + mu (cos th_k t1 + sin th_k t2)),  th_k = 2 pi k / K,
/// (Dex-Net leaves f_k unnormalised; normalising makes every edge a unit force). Each f_k gives the
/// wrench column [f_k; s (p - c) x f_k] with c the centre of mass and s = `torque_scaling`.
///
/// Tangent basis. t1 is the part of a reference direction orthogonal to n, normalised; the
/// reference is the first of (other contact - p), (c - p), the other contact's normal whose
/// orthogonal part is not negligible, else the coordinate axis least aligned with n. t2 = n x t1.
/// Dex-Net picks t1 from an SVD of n, which is arbitrary; this choice rotates with the
/// configuration, so Q is invariant under rotating contacts, normals and centre of mass together.
///
/// Soft fingers. Two point contacts cannot resist a torque about the line through them: every
/// column has zero moment about that line, so G has rank <= 5 and the origin is never interior of
/// the 6-D hull (Q = 0 for every two-point-contact grasp). Dex-Net therefore evaluates its robust
/// Ferrari-Canny metric with `soft_fingers: 1`: each contact adds two pure-torsion columns
/// [0; +-s pi r^2 mu n] with r = `finger_radius_m` (0.005 m, the code default), i.e. a finger pad
/// of radius r that resists spinning about its normal. `soft_fingers` is therefore on by default.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

namespace softgrasp::mesh {

/// A point contact on the object surface.
struct Contact {
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d inward_normal = Eigen::Vector3d::UnitZ();  ///< into the object; normalised here
};

/// Parameters of the deterministic metric (Dex-Net's `robust_ferrari_canny` quality config).
struct QualityParams {
  double friction_coefficient = 0.5;  ///< mu >= 0
  int num_cone_faces = 8;             ///< K >= 3 edges of the linearised friction cone
  double torque_scaling = 1000.0;     ///< s > 0, multiplies every torque row (1/m)
  bool soft_fingers = true;           ///< add the +-torsion columns (see the file comment)
  double finger_radius_m = 0.005;     ///< r >= 0 of the soft-finger torsion
};

/// Noise of the robust metric (Dex-Net `test/config.yaml`). Standard deviations, per axis.
struct RobustParams {
  int num_samples = 25;  ///< >= 1; the estimate is the sample mean
  std::uint64_t seed = 0;
  double gripper_translation_sigma_m = 0.005;
  double gripper_rotation_sigma_rad = 0.001;
  double object_translation_sigma_m = 0.01;
  double object_rotation_sigma_rad = 0.01;
  /// mu_i = max(0, mu + friction_sigma * z). Dex-Net's config says `sigma_friction_coef: 0.1` but
  /// the code passes it to multivariate_normal as the covariance, so the standard deviation it
  /// really uses is sqrt(0.1) ~= 0.316: that is the default here.
  double friction_sigma = 0.316;
};

/// The caller's surface query: the two contacts where jaws closing along `axis_unit` through
/// `center_m` from a width of `max_width_m` (jaws at center +- max_width/2 axis) first touch the
/// object, or nullopt when they touch nothing. Object frame.
using ContactQuery = std::function<std::optional<std::pair<Contact, Contact>>(
    const Eigen::Vector3d& center_m, const Eigen::Vector3d& axis_unit, double max_width_m)>;

/// Dex-Net's `force_closure`: true when at both contacts the angle between the inward normal and
/// the contact line (pointing from that contact to the other) is <= atan(mu). Unlike Dex-Net's
/// default (`use_abs_value=True`), a normal pointing away from the other contact fails.
/// False for coincident points, zero or non-finite input, or mu < 0.
bool ForceClosure(const Contact& a, const Contact& b, double friction_coefficient);

/// The 6 x M grasp matrix: K cone-edge wrenches of `a`, then K of `b`, then with soft fingers the
/// torsion columns +t_a, +t_b, -t_a, -t_b (Dex-Net's order). Rows: force (N), scaled torque.
/// @pre finite input, non-zero normals, valid params.  @throws std::invalid_argument otherwise.
Eigen::Matrix<double, 6, Eigen::Dynamic> GraspMatrix(const Contact& a, const Contact& b,
                                                     const Eigen::Vector3d& center_of_mass_m,
                                                     const QualityParams& params);

/// Ferrari-Canny L1 of a wrench set: 0 unless the origin lies strictly inside the convex hull of
/// the columns (hull of full dimension 6 and every facet at a positive distance), else the
/// smallest distance from the origin to a facet hyperplane (the radius of the largest ball about
/// the origin inside the hull). 0 for fewer than 7 columns or non-finite entries, and for a set
/// that is flat to within 1e-10 (smallest over largest singular value of the centred columns).
/// The origin counts as inside when every facet is farther than 1e-12 times the largest column
/// norm. Before the hull, a linear programme (GLPK) looks for a direction u with w_j . u <= 0 for
/// every column; one that checks out on the columns proves the value 0 without a hull (most noisy
/// samples of a grasp end here). Dex-Net instead tests the origin with a min-norm QP against
/// `wrench_norm_thresh` 0.001 and takes each facet's min-norm point; for an interior origin both
/// give the same minimum.
double FerrariCannyL1(const Eigen::Matrix<double, 6, Eigen::Dynamic>& wrenches);

/// Ferrari-Canny L1 of the grasp on contacts `a`, `b`: FerrariCannyL1(GraspMatrix(...)).
/// Degenerate geometry (non-finite points or normals, zero normals) gives 0.
/// @throws std::invalid_argument for invalid params (mu < 0, K < 3, s <= 0, r < 0, non-finite).
double FerrariCannyL1(const Contact& a, const Contact& b, const Eigen::Vector3d& center_of_mass_m,
                      const QualityParams& params);

/// Result of the robust metric: the mean and each sample's quality, in drawing order.
struct RobustQuality {
  double mean = 0.0;
  std::vector<double> samples;
};

/// Robust Ferrari-Canny: the mean of FerrariCannyL1 over `num_samples` perturbed grasps.
///
/// Per sample, from std::mt19937_64(seed), standard normals z (Box-Muller on two 53-bit uniforms,
/// two engine outputs each, so the draws are the same on every platform) are taken in the order:
/// gripper rotation xi_g (3), gripper translation t_g (3), object rotation xi_o (3), object
/// translation t_o (3), friction (1); each scaled by its sigma.
///  - Gripper: centre' = centre + t_g, axis' = exp([xi_g]x) axis (rotation about the grasp centre,
///    Dex-Net's ParallelJawGraspPoseGaussianRV).
///  - Object: T_o(x) = R_o (x - c) + c + t_o with R_o = exp([xi_o]x), c the centre of mass.
///    Dex-Net rotates about the object frame origin, the centre of its preprocessed meshes;
///    rotating about c keeps the noise independent of where the caller's frame is.
///  - The grasp is evaluated relative to the object: the contacts of the perturbed gripper on the
///    perturbed object are T_o of the contacts of T_o^-1(gripper) on the nominal object, and Q is
///    invariant under a rigid motion of contacts and centre of mass together. So the query is
///    called with centre'' = c + R_o^T (centre' - c - t_o), axis'' = R_o^T axis' and `max_width_m`,
///    and Q is evaluated on its contacts with centre of mass c and mu_i = max(0, mu + sigma z).
///    A sample whose query returns nullopt has quality 0.
/// With every sigma 0, each sample evaluates exactly the nominal grasp.
/// @throws std::invalid_argument for num_samples < 1, negative or non-finite sigmas, invalid
/// params or a non-finite or zero axis; whatever `query` throws.
RobustQuality RobustFerrariCannyL1(const Eigen::Vector3d& center_m,
                                   const Eigen::Vector3d& axis_unit, double max_width_m,
                                   const ContactQuery& query,
                                   const Eigen::Vector3d& center_of_mass_m,
                                   const QualityParams& params, const RobustParams& robust);

}  // namespace softgrasp::mesh
