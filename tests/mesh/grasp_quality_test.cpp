// Two-contact grasp quality: force closure at the cone boundary, the grasp matrix, Ferrari-Canny L1
// against a closed form (cube) and an independent brute-force facet enumeration, invariances,
// degenerate input, and the robust mean under pose and friction noise.
#include "service/mesh_grasps/grasp_quality.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

namespace softgrasp::mesh {
namespace {

using Wrenches = Eigen::Matrix<double, 6, Eigen::Dynamic>;

constexpr double kHalfEdge = 0.02;  // cube [-a, a]^3, centre of mass at the origin

/// Contacts of the face-centre antipodal grasp along x on the cube.
std::pair<Contact, Contact> CubeFaceCentres(double a = kHalfEdge) {
  return {Contact{Eigen::Vector3d(a, 0, 0), Eigen::Vector3d(-1, 0, 0)},
          Contact{Eigen::Vector3d(-a, 0, 0), Eigen::Vector3d(1, 0, 0)}};
}

/// A force-closure grasp without symmetry: contacts inside each other's cones, normals not
/// parallel, centre of mass off the contact line.
struct Generic {
  Contact a{Eigen::Vector3d(0.021, 0.003, -0.002), Eigen::Vector3d(-1.0, 0.15, 0.05).normalized()};
  Contact b{Eigen::Vector3d(-0.019, -0.002, 0.004), Eigen::Vector3d(1.0, 0.08, -0.12).normalized()};
  Eigen::Vector3d com{0.001, 0.004, -0.003};
};

/// Jaws closing along the axis line onto the cube [-a, a]^3 from center +- width/2 axis (slab
/// intersection); nullopt when the line misses the cube or a jaw starts inside it.
std::optional<std::pair<Contact, Contact>> CubeQuery(const Eigen::Vector3d& center,
                                                     const Eigen::Vector3d& axis, double width,
                                                     double a = kHalfEdge) {
  double t_min = -std::numeric_limits<double>::infinity();
  double t_max = std::numeric_limits<double>::infinity();
  int face_min = -1;
  int face_max = -1;
  for (int i = 0; i < 3; ++i) {
    if (axis[i] == 0.0) {
      if (std::abs(center[i]) > a) return std::nullopt;
      continue;
    }
    double t0 = (-a - center[i]) / axis[i];
    double t1 = (a - center[i]) / axis[i];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_min) {
      t_min = t0;
      face_min = i;
    }
    if (t1 < t_max) {
      t_max = t1;
      face_max = i;
    }
  }
  if (!(t_min < t_max) || t_max > width / 2 || t_min < -width / 2) return std::nullopt;
  const auto contact = [&](double t, int face) {
    Contact c;
    c.point_m = center + t * axis;
    c.inward_normal = Eigen::Vector3d::Zero();
    c.inward_normal[face] = c.point_m[face] > 0 ? -1.0 : 1.0;
    return c;
  };
  // The jaw at +width/2 meets the surface at t_max, the other at t_min.
  return std::make_pair(contact(t_max, face_max), contact(t_min, face_min));
}

Eigen::Matrix3d RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return q.normalized().toRotationMatrix();
}

/// Independent Ferrari-Canny L1: enumerate every 6-subset of the distinct columns, take the
/// hyperplane through it (when the subset spans one), keep those with every column on one side
/// (supporting hyperplanes; every facet is spanned by some 6 of its vertices) and return the
/// smallest distance from the origin to them, or 0 if the origin is not strictly inside.
double BruteForceFerrariCanny(const Wrenches& g) {
  std::vector<Eigen::Matrix<double, 6, 1>> points;
  for (Eigen::Index j = 0; j < g.cols(); ++j) {
    bool duplicate = false;
    for (const auto& p : points) duplicate = duplicate || (p - g.col(j)).norm() < 1e-14;
    if (!duplicate) points.push_back(g.col(j));
  }
  const int n = static_cast<int>(points.size());
  double scale = 0.0;
  for (const auto& p : points) scale = std::max(scale, p.norm());
  const double tol = 1e-11 * scale;
  double best = std::numeric_limits<double>::infinity();
  int supporting = 0;
  std::vector<int> idx{0, 1, 2, 3, 4, 5};
  while (true) {
    Eigen::Matrix<double, 6, 7> m;
    for (int r = 0; r < 6; ++r) m.row(r) << points[idx[r]].transpose(), 1.0;
    Eigen::FullPivLU<Eigen::Matrix<double, 6, 7>> lu(m);
    lu.setThreshold(1e-10);
    if (lu.rank() == 6) {
      Eigen::Matrix<double, 7, 1> v = lu.kernel().col(0);
      const double normal_norm = v.head<6>().norm();
      if (normal_norm > 0) {
        v /= normal_norm;  // v.head(6) . x + v(6) = 0 on the hyperplane
        bool below = true;
        bool above = true;
        for (const auto& p : points) {
          const double side = v.head<6>().dot(p) + v(6);
          below = below && side <= tol;
          above = above && side >= -tol;
        }
        if (below || above) {
          ++supporting;
          // Value at the origin with the normal pointing away from the hull: must be < 0.
          const double at_origin = below ? v(6) : -v(6);
          if (at_origin >= -tol) return 0.0;
          best = std::min(best, -at_origin);
        }
      }
    }
    int k = 5;
    while (k >= 0 && idx[k] == n - 6 + k) --k;
    if (k < 0) break;
    ++idx[k];
    for (int j = k + 1; j < 6; ++j) idx[j] = idx[j - 1] + 1;
  }
  return supporting > 0 ? best : 0.0;
}

TEST(GraspQualityTest, ForceClosureOnOppositeCubeFaces) {
  const auto [a, b] = CubeFaceCentres();
  EXPECT_TRUE(ForceClosure(a, b, 0.5));
  EXPECT_TRUE(ForceClosure(a, b, 0.0));  // angle 0 <= atan(0)
  // Offset along the faces: the line tilts by atan(h / 2a) from both normals.
  const Contact b_offset{Eigen::Vector3d(-kHalfEdge, 0.015, 0), Eigen::Vector3d(1, 0, 0)};
  EXPECT_TRUE(ForceClosure(a, b_offset, 0.5));   // atan(0.375) < atan(0.5)
  EXPECT_FALSE(ForceClosure(a, b_offset, 0.3));  // atan(0.375) > atan(0.3)
  // Normals pointing out of the object fail.
  const Contact a_out{a.point_m, -a.inward_normal};
  EXPECT_FALSE(ForceClosure(a_out, b, 0.5));
}

TEST(GraspQualityTest, ForceClosureFlipsAtTheConeHalfAngle) {
  const double mu = 0.5;
  const double half_angle = std::atan(mu);
  const Contact other{Eigen::Vector3d(0.05, 0, 0), Eigen::Vector3d(-1, 0, 0)};
  for (const double delta : {1e-6, -1e-6}) {
    const double angle = half_angle + delta;
    const Contact tilted{Eigen::Vector3d::Zero(),
                         Eigen::Vector3d(std::cos(angle), std::sin(angle), 0)};
    EXPECT_EQ(ForceClosure(tilted, other, mu), delta < 0) << delta;
    EXPECT_EQ(ForceClosure(other, tilted, mu), delta < 0) << delta;
  }
}

TEST(GraspQualityTest, ForceClosureRejectsDegenerateInput) {
  const auto [a, b] = CubeFaceCentres();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(ForceClosure(a, a, 0.5));  // coincident
  EXPECT_FALSE(ForceClosure(Contact{Eigen::Vector3d(nan, 0, 0), a.inward_normal}, b, 0.5));
  EXPECT_FALSE(ForceClosure(Contact{a.point_m, Eigen::Vector3d::Zero()}, b, 0.5));
  EXPECT_FALSE(ForceClosure(a, b, -0.1));
  EXPECT_FALSE(ForceClosure(a, b, nan));
}

TEST(GraspQualityTest, GraspMatrixHoldsConeEdgesTorquesAndTorsion) {
  const Generic g;
  QualityParams params;
  params.friction_coefficient = 0.4;
  const Wrenches m = GraspMatrix(g.a, g.b, g.com, params);
  const int k = params.num_cone_faces;
  ASSERT_EQ(m.cols(), 2 * k + 4);
  const Contact* contacts[2] = {&g.a, &g.b};
  for (int c = 0; c < 2; ++c) {
    const Eigen::Vector3d n = contacts[c]->inward_normal.normalized();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int j = 0; j < k; ++j) {
      const Eigen::Vector3d f = m.col(c * k + j).head<3>();
      EXPECT_NEAR(f.norm(), 1.0, 1e-12);
      // Every edge lies on the cone: angle to the normal is atan(mu).
      EXPECT_NEAR(std::atan2(f.cross(n).norm(), f.dot(n)), std::atan(0.4), 1e-12);
      const Eigen::Vector3d torque =
          params.torque_scaling * (contacts[c]->point_m - g.com).cross(f);
      EXPECT_LT((m.col(c * k + j).tail<3>() - torque).norm(), 1e-12);
      sum += f;
    }
    // A regular polygon of edges: they average to cos(atan mu) n.
    EXPECT_LT((sum / k - n / std::sqrt(1 + 0.16)).norm(), 1e-12);
    const double torsion = params.torque_scaling * std::numbers::pi * 0.005 * 0.005 * 0.4;
    EXPECT_LT((m.col(2 * k + c).tail<3>() - torsion * n).norm(), 1e-12);
    EXPECT_LT((m.col(2 * k + 2 + c).tail<3>() + torsion * n).norm(), 1e-12);
    EXPECT_EQ(m.col(2 * k + c).head<3>().norm(), 0.0);
  }
  params.soft_fingers = false;
  EXPECT_EQ(GraspMatrix(g.a, g.b, g.com, params).cols(), 2 * k);
  params.num_cone_faces = 2;
  EXPECT_THROW(GraspMatrix(g.a, g.b, g.com, params), std::invalid_argument);
}

// Without soft fingers two point contacts give Q = 0: for a force f at p_i (i = a, b) the moment
// about the line L through p_a and p_b, d . ((p_i - p_a) x f) with d = p_b - p_a, is 0 because
// p_i - p_a is parallel to d. In terms of the column w = [f; s (p_i - c) x f] that moment is the
// linear functional d . tau / s - d . ((p_a - c) x f), which vanishes on every column: G has rank
// <= 5, the hull is flat and the origin is not in its interior.
TEST(GraspQualityTest, FerrariCannyOfTwoPointContactsIsZero) {
  QualityParams params;
  params.soft_fingers = false;
  const auto [a, b] = CubeFaceCentres();
  EXPECT_EQ(FerrariCannyL1(a, b, Eigen::Vector3d::Zero(), params), 0.0);
  const Generic g;
  EXPECT_EQ(FerrariCannyL1(g.a, g.b, g.com, params), 0.0);
  Eigen::JacobiSVD<Wrenches> svd(GraspMatrix(g.a, g.b, g.com, params));
  EXPECT_LT(svd.singularValues()[5], 1e-12 * svd.singularValues()[0]);
}

// Closed form for the face-centre grasp on the cube [-a, a]^3 (centre of mass at the origin) with
// soft fingers and torque scaling s = 1/a. Let m = sqrt(1 + mu^2), u_k the unit cone directions in
// the yz plane, R the rotation by 90 degrees about x (x cross u). Coordinates (fx, fy, fz, tx, ty,
// tz):
//   contact at (+a,0,0), normal -x:  w = (-1/m, mu u_k / m, 0, s a mu (R u_k) / m)
//   contact at (-a,0,0), normal +x:  w = (+1/m, mu u'_k / m, 0, -s a mu (R u'_k) / m)
//   torsion: (0, 0, 0, +-kappa, 0, 0), kappa = s pi r^2 mu.
// With s a = 1 the 4-D parts (u, Ru) and (u', -Ru') span orthogonal planes E1, E2 (their inner
// product is u.u' (1 - s^2 a^2) = 0) and have length sqrt 2: each contact's edges are a regular
// octagon of circumradius alpha = sqrt(2) mu / m in its plane. Q = min over unit d of the support
// function h(d) = 1 / max{|d| : h(d) <= 1}. With d = (x, y, d1 in E1, d2 in E2), r_i = |d_i|,
//   h(d) = max(-x/m + alpha h8(d1), x/m + alpha h8(d2), kappa |y|),
// and h8 (support of the unit octagon) is at least r_i cos(pi/8), reached between two vertices.
// So max |d| is the largest x^2 + y^2 + r1^2 + r2^2 over -x/m + beta r1 <= 1, x/m + beta r2 <= 1,
// kappa |y| <= 1, r_i >= 0 (beta = alpha cos(pi/8)); a convex function on a polytope peaks at a
// vertex: x = m, r1 = 2/beta, r2 = 0, |y| = 1/kappa. Hence Q = (m^2 + 4/beta^2 + 1/kappa^2)^-1/2.
TEST(GraspQualityTest, FerrariCannyMatchesTheCubeClosedForm) {
  for (const double mu : {0.2, 0.5, 0.8, 1.5}) {
    for (const double radius : {0.005, 0.05, 0.2}) {
      QualityParams params;
      params.friction_coefficient = mu;
      params.torque_scaling = 1.0 / kHalfEdge;
      params.finger_radius_m = radius;
      const double m = std::sqrt(1 + mu * mu);
      const double beta = std::sqrt(2.0) * mu / m * std::cos(std::numbers::pi / 8);
      const double kappa = params.torque_scaling * std::numbers::pi * radius * radius * mu;
      const double expected = 1.0 / std::sqrt(m * m + 4 / (beta * beta) + 1 / (kappa * kappa));
      const auto [a, b] = CubeFaceCentres();
      const double q = FerrariCannyL1(a, b, Eigen::Vector3d::Zero(), params);
      EXPECT_NEAR(q, expected, 1e-9 * expected) << "mu " << mu << " r " << radius;
    }
  }
}

TEST(GraspQualityTest, FerrariCannyMatchesBruteForceFacetEnumeration) {
  const Generic g;
  const auto [a, b] = CubeFaceCentres();
  for (const double scaling : {1000.0, 50.0, 10.0}) {
    for (const double mu : {0.3, 0.6}) {
      QualityParams params;
      params.friction_coefficient = mu;
      params.torque_scaling = scaling;
      params.finger_radius_m = 0.01;
      for (const auto& [ca, cb, com] :
           {std::tuple{g.a, g.b, g.com}, std::tuple{a, b, Eigen::Vector3d(0.002, -0.001, 0.003)}}) {
        const Wrenches m = GraspMatrix(ca, cb, com, params);
        const double expected = BruteForceFerrariCanny(m);
        ASSERT_GT(expected, 0.0);
        EXPECT_NEAR(FerrariCannyL1(m), expected, 1e-9 * expected)
            << "scaling " << scaling << " mu " << mu;
        EXPECT_EQ(FerrariCannyL1(ca, cb, com, params), FerrariCannyL1(m));
      }
    }
  }
}

// The cross-polytope conv(+-e_i) in 6-D has 64 facets x . sign = 1, each at distance 1/sqrt(6)
// from the origin. Extra points on its boundary (scaled to |x|_1 = 1) leave the hull unchanged and
// put many points on every facet.
TEST(GraspQualityTest, FerrariCannyOfTheCrossPolytopeIsOneOverRootSix) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Wrenches w = Wrenches::Zero(6, 12 + 60);
  for (int i = 0; i < 6; ++i) {
    w(i, 2 * i) = 1.0;
    w(i, 2 * i + 1) = -1.0;
  }
  for (int j = 12; j < w.cols(); ++j) {
    for (int i = 0; i < 6; ++i) w(i, j) = uniform(rng);
    w.col(j) /= w.col(j).lpNorm<1>();
  }
  EXPECT_NEAR(FerrariCannyL1(w), 1.0 / std::sqrt(6.0), 1e-12);
  // Shifted by 1/sqrt(6) - 0.01 along a facet normal, the nearest facet is 0.01 away.
  const Eigen::Matrix<double, 6, 1> facet_normal =
      Eigen::Matrix<double, 6, 1>::Ones() / std::sqrt(6.0);
  Wrenches shifted = w.colwise() - (1.0 / std::sqrt(6.0) - 0.01) * facet_normal;
  EXPECT_NEAR(FerrariCannyL1(shifted), 0.01, 1e-12);
  // Shifted past it, the origin is outside.
  shifted = w.colwise() - (1.0 / std::sqrt(6.0) + 0.01) * facet_normal;
  EXPECT_EQ(FerrariCannyL1(shifted), 0.0);
}

// The vertices of a 6-cube: [-1, 1]^6 holds the origin at distance 1 from every facet;
// [0, 2]^6 has it at a corner (on the boundary, 0), [0.5, 2.5]^6 outside (0). Zeros are proved by
// a separating direction before any hull is built; the interior case still goes through the hull.
TEST(GraspQualityTest, FerrariCannyOfHypercubesAroundOnAndOffTheOrigin) {
  const auto hypercube = [](double lo, double hi) {
    Eigen::Matrix<double, 6, Eigen::Dynamic> w(6, 64);
    for (int j = 0; j < 64; ++j) {
      for (int i = 0; i < 6; ++i) w(i, j) = (j >> i) & 1 ? hi : lo;
    }
    return w;
  };
  EXPECT_NEAR(FerrariCannyL1(hypercube(-1.0, 1.0)), 1.0, 1e-12);
  EXPECT_NEAR(FerrariCannyL1(hypercube(-0.25, 1.75)), 0.25, 1e-12);
  EXPECT_EQ(FerrariCannyL1(hypercube(0.0, 2.0)), 0.0);
  EXPECT_EQ(FerrariCannyL1(hypercube(0.5, 2.5)), 0.0);
  EXPECT_EQ(FerrariCannyL1(hypercube(-2.5, -0.5)), 0.0);
}

TEST(GraspQualityTest, FerrariCannyIsZeroWithoutFrictionOrOutsideTheCones) {
  QualityParams params;
  const auto [a, b] = CubeFaceCentres();
  params.friction_coefficient = 0.0;
  EXPECT_EQ(FerrariCannyL1(a, b, Eigen::Vector3d::Zero(), params), 0.0);
  // Parallel normals +-x, contacts offset along the faces so that the line leaves the cones.
  // Equilibrium needs F_a = -F_b in both cones and (p_a - p_b) x F_a balanced by torsion, which
  // only acts along x; x . (p_a - p_b) != 0, so (p_a - p_b) x F_a = 0: F_a along the line, which is
  // outside the cones. No equilibrium with positive weights: the origin is outside, Q = 0.
  params.friction_coefficient = 0.3;
  const Contact b_offset{Eigen::Vector3d(-kHalfEdge, 0.015, 0), Eigen::Vector3d(1, 0, 0)};
  ASSERT_FALSE(ForceClosure(a, b_offset, 0.3));
  EXPECT_EQ(FerrariCannyL1(a, b_offset, Eigen::Vector3d::Zero(), params), 0.0);
  EXPECT_EQ(BruteForceFerrariCanny(GraspMatrix(a, b_offset, Eigen::Vector3d::Zero(), params)), 0.0);
  // Inside the cones at mu = 0.5 the same contacts hold.
  params.friction_coefficient = 0.5;
  EXPECT_GT(FerrariCannyL1(a, b_offset, Eigen::Vector3d::Zero(), params), 0.0);
}

TEST(GraspQualityTest, FerrariCannyGrowsWithFriction) {
  const auto [a, b] = CubeFaceCentres();
  const Generic g;
  for (const auto& com : {Eigen::Vector3d::Zero().eval(), g.com}) {
    double previous = 0.0;
    for (const double mu : {0.2, 0.5, 0.8}) {
      QualityParams params;  // Dex-Net's robust Ferrari-Canny parameters
      params.friction_coefficient = mu;
      const double q = FerrariCannyL1(a, b, com, params);
      EXPECT_GT(q, previous) << mu;
      previous = q;
    }
  }
}

TEST(GraspQualityTest, FerrariCannyIsInvariantUnderRotation) {
  std::mt19937_64 rng(11);
  const Generic g;
  const auto [a, b] = CubeFaceCentres();
  QualityParams params;
  params.torque_scaling = 50.0;
  params.finger_radius_m = 0.01;
  for (const auto& [ca, cb, com] :
       {std::tuple{g.a, g.b, g.com}, std::tuple{a, b, Eigen::Vector3d::Zero().eval()},
        std::tuple{a, b, Eigen::Vector3d(0, 0.003, 0)}}) {
    const double q = FerrariCannyL1(ca, cb, com, params);
    ASSERT_GT(q, 0.0);
    for (int i = 0; i < 5; ++i) {
      const Eigen::Matrix3d r = RandomRotation(rng);
      const Eigen::Vector3d shift(0.1 * i, -0.2, 0.05);
      const Contact ra{r * ca.point_m + shift, r * ca.inward_normal};
      const Contact rb{r * cb.point_m + shift, r * cb.inward_normal};
      EXPECT_NEAR(FerrariCannyL1(ra, rb, r * com + shift, params), q, 1e-9 * q);
    }
  }
}

TEST(GraspQualityTest, FerrariCannyOfDegenerateInputIsZeroAndSilent) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto [a, b] = CubeFaceCentres();
  const QualityParams params;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(FerrariCannyL1(Contact{Eigen::Vector3d(nan, 0, 0), a.inward_normal}, b,
                           Eigen::Vector3d::Zero(), params),
            0.0);
  EXPECT_EQ(FerrariCannyL1(a, Contact{b.point_m, Eigen::Vector3d::Zero()}, Eigen::Vector3d::Zero(),
                           params),
            0.0);
  EXPECT_EQ(FerrariCannyL1(a, b, Eigen::Vector3d(0, nan, 0), params), 0.0);
  EXPECT_EQ(FerrariCannyL1(a, a, Eigen::Vector3d::Zero(), params), 0.0);  // one point
  EXPECT_EQ(FerrariCannyL1(Wrenches(6, 3)), 0.0);                         // too few columns
  Wrenches bad = GraspMatrix(a, b, Eigen::Vector3d::Zero(), params);
  EXPECT_EQ(FerrariCannyL1(Wrenches::Zero(6, 12)), 0.0);
  // Thin but full-dimensional (tau_x squeezed by 1e-6) reaches Qhull: the origin stays inside
  // and the ball cannot be wider than the squeezed extent 1e-6 kappa, kappa = s pi r^2 mu.
  Wrenches thin = bad;
  thin.row(3) *= 1e-6;
  const double kappa = params.torque_scaling * std::numbers::pi * 0.005 * 0.005 * 0.5;
  const double q_thin = FerrariCannyL1(thin);
  EXPECT_GT(q_thin, 0.0);
  EXPECT_LE(q_thin, 1e-6 * kappa * (1 + 1e-12));
  // Squeezed by 1e-12 it counts as flat.
  thin.row(3) *= 1e-6;
  EXPECT_EQ(FerrariCannyL1(thin), 0.0);
  bad(2, 3) = nan;
  EXPECT_EQ(FerrariCannyL1(bad), 0.0);
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");

  QualityParams invalid;
  invalid.friction_coefficient = -0.1;
  EXPECT_THROW(FerrariCannyL1(a, b, Eigen::Vector3d::Zero(), invalid), std::invalid_argument);
  invalid = QualityParams{};
  invalid.torque_scaling = 0.0;
  EXPECT_THROW(FerrariCannyL1(a, b, Eigen::Vector3d::Zero(), invalid), std::invalid_argument);
}

ContactQuery Cube() {
  return [](const Eigen::Vector3d& c, const Eigen::Vector3d& axis, double width) {
    return CubeQuery(c, axis, width);
  };
}

TEST(GraspQualityTest, RobustQualityWithoutNoiseIsTheNominalQuality) {
  RobustParams robust;
  robust.gripper_translation_sigma_m = 0;
  robust.gripper_rotation_sigma_rad = 0;
  robust.object_translation_sigma_m = 0;
  robust.object_rotation_sigma_rad = 0;
  robust.friction_sigma = 0;
  robust.num_samples = 7;
  const QualityParams params;
  const Eigen::Vector3d com(0.001, -0.002, 0.0);
  for (const auto& [center, axis] : {std::pair{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)},
                                     std::pair{Eigen::Vector3d(0.002, 0.003, -0.004),
                                               Eigen::Vector3d(1, 0.2, -0.1).normalized()}}) {
    const auto contacts = CubeQuery(center, axis, 0.1);
    ASSERT_TRUE(contacts);
    const double nominal = FerrariCannyL1(contacts->first, contacts->second, com, params);
    ASSERT_GT(nominal, 0.0);
    const RobustQuality r = RobustFerrariCannyL1(center, axis, 0.1, Cube(), com, params, robust);
    ASSERT_EQ(r.samples.size(), 7u);
    for (const double q : r.samples) EXPECT_EQ(q, nominal);
    EXPECT_NEAR(r.mean, nominal, 1e-15 * nominal);
  }
}

TEST(GraspQualityTest, RobustQualityUnderDefaultNoiseIsSeededAndBelowTheNominal) {
  const QualityParams params;
  const Eigen::Vector3d center = Eigen::Vector3d::Zero();
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  const auto [a, b] = CubeFaceCentres();
  const double nominal = FerrariCannyL1(a, b, Eigen::Vector3d::Zero(), params);
  RobustParams robust;
  robust.seed = 42;
  const RobustQuality first =
      RobustFerrariCannyL1(center, axis, 0.1, Cube(), Eigen::Vector3d::Zero(), params, robust);
  const RobustQuality again =
      RobustFerrariCannyL1(center, axis, 0.1, Cube(), Eigen::Vector3d::Zero(), params, robust);
  EXPECT_EQ(first.mean, again.mean);
  EXPECT_EQ(first.samples, again.samples);
  ASSERT_EQ(first.samples.size(), 25u);
  // The face-centre grasp with the centre of mass on its line is the best of its neighbours: the
  // noise moves the line off the centre of mass and the contacts off the face centres.
  EXPECT_GT(first.mean, 0.0);
  EXPECT_LT(first.mean, nominal);
  double sum = 0.0;
  for (const double q : first.samples) {
    EXPECT_GE(q, 0.0);
    sum += q;
  }
  EXPECT_NEAR(first.mean, sum / 25, 1e-15);
  robust.seed = 43;
  const RobustQuality other =
      RobustFerrariCannyL1(center, axis, 0.1, Cube(), Eigen::Vector3d::Zero(), params, robust);
  EXPECT_NE(other.mean, first.mean);
  EXPECT_GT(other.mean, 0.0);
}

TEST(GraspQualityTest, RobustQualityIsZeroWhenTheJawsMissEverything) {
  int calls = 0;
  const ContactQuery miss = [&calls](const Eigen::Vector3d&, const Eigen::Vector3d&, double) {
    ++calls;
    return std::optional<std::pair<Contact, Contact>>{};
  };
  RobustParams robust;
  robust.num_samples = 9;
  const RobustQuality r = RobustFerrariCannyL1(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                               0.1, miss, Eigen::Vector3d::Zero(), {}, robust);
  EXPECT_EQ(calls, 9);
  EXPECT_EQ(r.mean, 0.0);
  EXPECT_EQ(r.samples, std::vector<double>(9, 0.0));
}

TEST(GraspQualityTest, RobustQualityRejectsInvalidArguments) {
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  RobustParams robust;
  robust.num_samples = 0;
  EXPECT_THROW(RobustFerrariCannyL1(zero, x, 0.1, Cube(), zero, {}, robust), std::invalid_argument);
  robust = RobustParams{};
  robust.friction_sigma = -1;
  EXPECT_THROW(RobustFerrariCannyL1(zero, x, 0.1, Cube(), zero, {}, robust), std::invalid_argument);
  EXPECT_THROW(RobustFerrariCannyL1(zero, zero, 0.1, Cube(), zero, {}, {}), std::invalid_argument);
  EXPECT_THROW(RobustFerrariCannyL1(zero, x, 0.1, ContactQuery{}, zero, {}, {}),
               std::invalid_argument);
}

}  // namespace
}  // namespace softgrasp::mesh
