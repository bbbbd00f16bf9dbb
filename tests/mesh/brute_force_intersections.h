#pragma once
// Test-only second opinion on self-intersections, independent of CGAL: every pair of faces is
// looked at (O(n^2), a bounding-box test first) and decided with exact arithmetic: 3D orientations
// in double when a forward error bound proves the sign, otherwise in GMP rationals (every double
// converts to a rational exactly); coplanar cases always in rationals.
//
// Two faces count as intersecting when their closed triangles share a point outside the vertex
// or edge both of them use (same definition as CheckMesh): faces without a common vertex
// intersect iff an edge of one meets the other; faces sharing one vertex iff the edge opposite
// it in one meets the other; faces sharing an edge iff they are coplanar and on the same side of
// it. Faces with three collinear vertices are counted apart and not paired (no normal).

#include <gmpxx.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "service/mesh/mesh.h"

namespace softgrasp::mesh::testing {

struct BruteForceIntersections {
  std::vector<std::array<int, 2>> pairs;  ///< intersecting faces {f, g}, f < g, sorted
  std::vector<int> collinear_faces;       ///< sorted
};

namespace brute_force_detail {

using P = std::array<double, 3>;

inline mpq_class Q(double x) { return mpq_class(x); }  // exact

/// Sign of det[b - a, c - a, d - a], exactly.
inline int Orient3dExact(const P& a, const P& b, const P& c, const P& d) {
  mpq_class m[3][3];
  for (std::size_t k = 0; k < 3; ++k) {
    m[0][k] = Q(b[k]) - Q(a[k]);
    m[1][k] = Q(c[k]) - Q(a[k]);
    m[2][k] = Q(d[k]) - Q(a[k]);
  }
  const mpq_class det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                        m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                        m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  return sgn(det);
}

/// Same sign, with a double-precision fast path: the rounding error of this evaluation is below
/// ~8e-16 times the permanent (Shewchuk's orient3d bound A); 1e-14 leaves a wide margin, and
/// tiny or non-finite permanents (underflow) go to the exact path.
inline int Orient3d(const P& a, const P& b, const P& c, const P& d) {
  const double bx = b[0] - a[0], by = b[1] - a[1], bz = b[2] - a[2];
  const double cx = c[0] - a[0], cy = c[1] - a[1], cz = c[2] - a[2];
  const double dx = d[0] - a[0], dy = d[1] - a[1], dz = d[2] - a[2];
  const double det = bx * (cy * dz - cz * dy) - by * (cx * dz - cz * dx) + bz * (cx * dy - cy * dx);
  const double permanent = std::abs(bx) * (std::abs(cy * dz) + std::abs(cz * dy)) +
                           std::abs(by) * (std::abs(cx * dz) + std::abs(cz * dx)) +
                           std::abs(bz) * (std::abs(cx * dy) + std::abs(cy * dx));
  if (std::isfinite(permanent) && permanent > 1e-250) {
    const double bound = 1e-14 * permanent;
    if (det > bound) return 1;
    if (det < -bound) return -1;
  }
  return Orient3dExact(a, b, c, d);
}

/// Exact normal (b - a) x (c - a).
inline std::array<mpq_class, 3> Normal(const P& a, const P& b, const P& c) {
  const mpq_class ux = Q(b[0]) - Q(a[0]), uy = Q(b[1]) - Q(a[1]), uz = Q(b[2]) - Q(a[2]);
  const mpq_class vx = Q(c[0]) - Q(a[0]), vy = Q(c[1]) - Q(a[1]), vz = Q(c[2]) - Q(a[2]);
  return {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
}

inline bool Collinear(const P& a, const P& b, const P& c) {
  const auto n = Normal(a, b, c);
  return sgn(n[0]) == 0 && sgn(n[1]) == 0 && sgn(n[2]) == 0;
}

/// The plane of coplanar points seen along its dominant normal axis: 2D coordinates (i, j).
struct Projection {
  std::size_t i = 0, j = 1;
};

inline Projection ProjectionFor(const P& a, const P& b, const P& c) {
  const auto n = Normal(a, b, c);
  std::size_t k = 0;
  for (std::size_t m = 1; m < 3; ++m) {
    if (abs(n[m]) > abs(n[k])) k = m;
  }
  return {k == 0 ? std::size_t{1} : 0, k == 2 ? std::size_t{1} : 2};
}

inline int Orient2d(const P& a, const P& b, const P& c, const Projection& pr) {
  const mpq_class d = (Q(b[pr.i]) - Q(a[pr.i])) * (Q(c[pr.j]) - Q(a[pr.j])) -
                      (Q(b[pr.j]) - Q(a[pr.j])) * (Q(c[pr.i]) - Q(a[pr.i]));
  return sgn(d);
}

/// p collinear with segment ab (in the projection): is it on the closed segment?
inline bool OnSegment2d(const P& p, const P& a, const P& b, const Projection& pr) {
  for (const std::size_t k : {pr.i, pr.j}) {
    if (p[k] < std::min(a[k], b[k]) || p[k] > std::max(a[k], b[k])) return false;
  }
  return true;
}

inline bool SegmentsMeet2d(const P& p, const P& q, const P& a, const P& b, const Projection& pr) {
  const int d1 = Orient2d(a, b, p, pr), d2 = Orient2d(a, b, q, pr);
  const int d3 = Orient2d(p, q, a, pr), d4 = Orient2d(p, q, b, pr);
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;
  return (d1 == 0 && OnSegment2d(p, a, b, pr)) || (d2 == 0 && OnSegment2d(q, a, b, pr)) ||
         (d3 == 0 && OnSegment2d(a, p, q, pr)) || (d4 == 0 && OnSegment2d(b, p, q, pr));
}

inline bool InTriangle2d(const P& p, const P& a, const P& b, const P& c, const Projection& pr) {
  const int s1 = Orient2d(a, b, p, pr), s2 = Orient2d(b, c, p, pr), s3 = Orient2d(c, a, p, pr);
  return !((s1 > 0 || s2 > 0 || s3 > 0) && (s1 < 0 || s2 < 0 || s3 < 0));
}

/// Does the closed segment pq meet the closed (non-degenerate) triangle abc?
inline bool SegmentMeetsTriangle(const P& p, const P& q, const P& a, const P& b, const P& c) {
  const int o1 = Orient3d(a, b, c, p), o2 = Orient3d(a, b, c, q);
  if (o1 == o2 && o1 != 0) return false;  // both strictly on one side
  if (o1 == 0 && o2 == 0) {               // in the triangle's plane
    const Projection pr = ProjectionFor(a, b, c);
    return InTriangle2d(p, a, b, c, pr) || InTriangle2d(q, a, b, c, pr) ||
           SegmentsMeet2d(p, q, a, b, pr) || SegmentsMeet2d(p, q, b, c, pr) ||
           SegmentsMeet2d(p, q, c, a, pr);
  }
  // The segment reaches the plane at one point; its line passes through the closed triangle iff
  // the three edge orientations seen from the line do not disagree.
  const int s1 = Orient3d(p, q, a, b), s2 = Orient3d(p, q, b, c), s3 = Orient3d(p, q, c, a);
  return !((s1 > 0 || s2 > 0 || s3 > 0) && (s1 < 0 || s2 < 0 || s3 < 0));
}

inline bool EdgesMeetTriangle(const std::array<P, 3>& t, const std::array<P, 3>& u) {
  for (std::size_t k = 0; k < 3; ++k) {
    if (SegmentMeetsTriangle(t[k], t[(k + 1) % 3], u[0], u[1], u[2])) return true;
  }
  return false;
}

}  // namespace brute_force_detail

/// All intersecting face pairs of `mesh` (valid indices and finite coordinates assumed).
inline BruteForceIntersections BruteForceSelfIntersections(const TriangleMesh& mesh) {
  using namespace brute_force_detail;
  BruteForceIntersections out;
  const std::size_t n = mesh.faces.size();
  std::vector<std::array<P, 3>> tri(n);
  std::vector<std::array<P, 2>> box(n);  // min, max
  std::vector<char> collinear(n, 0);
  for (std::size_t f = 0; f < n; ++f) {
    for (std::size_t k = 0; k < 3; ++k) {
      tri[f][k] = mesh.vertices[static_cast<std::size_t>(mesh.faces[f][k])];
    }
    for (std::size_t k = 0; k < 3; ++k) {
      box[f][0][k] = std::min({tri[f][0][k], tri[f][1][k], tri[f][2][k]});
      box[f][1][k] = std::max({tri[f][0][k], tri[f][1][k], tri[f][2][k]});
    }
    collinear[f] = Collinear(tri[f][0], tri[f][1], tri[f][2]) ? 1 : 0;
    if (collinear[f]) out.collinear_faces.push_back(static_cast<int>(f));
  }
  for (std::size_t f = 0; f < n; ++f) {
    if (collinear[f]) continue;
    for (std::size_t g = f + 1; g < n; ++g) {
      if (collinear[g]) continue;
      bool apart = false;
      for (std::size_t k = 0; k < 3 && !apart; ++k) {
        apart = box[f][1][k] < box[g][0][k] || box[g][1][k] < box[f][0][k];
      }
      if (apart) continue;
      const auto& vf = mesh.faces[f];
      const auto& vg = mesh.faces[g];
      // Local positions of the shared vertices.
      std::vector<std::pair<std::size_t, std::size_t>> shared;
      for (std::size_t a = 0; a < 3; ++a) {
        for (std::size_t b = 0; b < 3; ++b) {
          if (vf[a] == vg[b]) shared.emplace_back(a, b);
        }
      }
      bool hit = false;
      if (shared.size() >= 3) {
        hit = true;  // the same triangle twice
      } else if (shared.size() == 2) {
        // Coplanar and on the same side of the shared edge (seen in their plane).
        const std::size_t fa = 3 - shared[0].first - shared[1].first;
        const std::size_t gb = 3 - shared[0].second - shared[1].second;
        const P& u = tri[f][shared[0].first];
        const P& w = tri[f][shared[1].first];
        if (Orient3d(u, w, tri[f][fa], tri[g][gb]) == 0) {
          const Projection pr = ProjectionFor(tri[f][0], tri[f][1], tri[f][2]);
          hit = Orient2d(u, w, tri[f][fa], pr) == Orient2d(u, w, tri[g][gb], pr);
        }
      } else if (shared.size() == 1) {
        const std::size_t a = shared[0].first, b = shared[0].second;
        hit = SegmentMeetsTriangle(tri[f][(a + 1) % 3], tri[f][(a + 2) % 3], tri[g][0], tri[g][1],
                                   tri[g][2]) ||
              SegmentMeetsTriangle(tri[g][(b + 1) % 3], tri[g][(b + 2) % 3], tri[f][0], tri[f][1],
                                   tri[f][2]);
      } else {
        hit = EdgesMeetTriangle(tri[f], tri[g]) || EdgesMeetTriangle(tri[g], tri[f]);
      }
      if (hit) out.pairs.push_back({static_cast<int>(f), static_cast<int>(g)});
    }
  }
  return out;
}

}  // namespace softgrasp::mesh::testing
