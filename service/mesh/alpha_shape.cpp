// Regularized alpha shapes on CGAL's Delaunay triangulation, made into valid closed meshes.
// CGAL builds the triangulation and decides "circumradius <= alpha" exactly; the triangulation is
// then copied into flat arrays (cell -> 4 point indices, cell -> 4 neighbour cells), on which the
// piece selection and manifold repair run in a fixed order (cell index order), so the result is a
// function of the triangulation alone.
#include "service/mesh/alpha_shape.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_data_structure_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "service/mesh/mesh_check.h"

namespace softgrasp::mesh {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<std::uint32_t, K>;
using Cb = CGAL::Triangulation_cell_base_with_info_3<std::uint32_t, K,
                                                     CGAL::Delaunay_triangulation_cell_base_3<K>>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb, CGAL::Sequential_tag>;
using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;

constexpr std::uint32_t kInfinite = std::numeric_limits<std::uint32_t>::max();

/// Vertices of the facet opposite slot i, ordered so that the right-hand normal points away from
/// the cell (CGAL cells are positively oriented; its vertex_triple_index points inward).
constexpr int kFacetOut[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

core::Error Unprocessable(std::string message) {
  return core::MakeError(core::ErrorCode::kUnprocessable, std::move(message), "points");
}

/// A boundary facet of the solid: point indices ordered outward, and its solid cell.
struct BoundaryFacet {
  std::array<std::uint32_t, 3> v;
  std::uint32_t cell;
};

/// A directed boundary edge a -> b (key a << 32 | b) and the facet it belongs to.
struct DirectedEdge {
  std::uint64_t key;
  std::uint32_t facet;
};

/// The triangulation in flat arrays plus the current solid (which cells are in it).
class Solid {
 public:
  /// Builds the Delaunay triangulation of `points`; an error if it is not 3-dimensional.
  static core::Result<Solid> Build(const std::vector<std::array<double, 3>>& points);

  std::uint32_t num_cells() const { return static_cast<std::uint32_t>(cell_v_.size()); }

  /// Solid = finite cells with circumradius <= alpha (CGAL's exact predicate). Gaps the repair
  /// may fill must have circumradius <= fill_alpha. Clears all repair locks.
  void Classify(double alpha, double fill_alpha);

  struct Pieces {
    double total_volume = 0.0;  ///< of the solid before dropping
    int dropped = 0;
    double dropped_volume = 0.0;
    double largest_volume = 0.0;
  };
  /// Keeps the largest face-connected piece (by volume; ties: the first found).
  Pieces KeepLargestPiece();
  /// Boundary facets in cell order, outward.
  std::vector<BoundaryFacet> BoundaryFacets() const;
  /// Makes the solid's boundary 2-manifold (see the file comment of alpha_shape.h): fills
  /// cavities, keeps the largest solid wedge at each edge and the largest solid fan at each
  /// vertex, closes pinched tunnels. Round 1 checks the whole boundary; later rounds only the
  /// edges and vertices of cells changed in the round before. False if not settled in
  /// max_rounds.
  bool Repair(int max_rounds);
  int removed() const { return removed_; }
  int filled() const { return filled_; }
  int rounds() const { return rounds_; }

 private:
  bool In(std::uint32_t c) const { return solid_[c] != 0; }
  bool IsInfinite(std::uint32_t c) const { return infinite_[c] != 0; }
  /// Repairs change each cell at most once (then it is locked), so they always terminate.
  bool Remove(std::uint32_t c) {
    if (locked_[c] || !In(c)) return false;
    solid_[c] = 0;
    locked_[c] = 1;
    changed_.push_back(c);
    ++removed_;
    return true;
  }
  bool Fill(std::uint32_t c) {
    if (locked_[c] || In(c) || IsInfinite(c)) return false;
    solid_[c] = 1;
    locked_[c] = 1;
    changed_.push_back(c);
    ++filled_;
    return true;
  }
  /// An unlocked finite cell whose circumradius is <= fill_alpha.
  bool Fillable(std::uint32_t c) const;
  int Slot(std::uint32_t c, std::uint32_t v) const {
    for (int k = 0; k < 4; ++k) {
      if (cell_v_[c][static_cast<std::size_t>(k)] == v) return k;
    }
    return -1;
  }
  /// The cells around edge (a, b) in circular order, starting from cell c (which holds a, b).
  void CellsAroundEdge(std::uint32_t c, std::uint32_t a, std::uint32_t b,
                       std::vector<std::uint32_t>& out) const;
  /// The cells holding point v (its star), found from cell c.
  void Star(std::uint32_t c, std::uint32_t v, std::vector<std::uint32_t>& out);
  /// Groups the cells of a star with solid_ == in by connection through facets holding v.
  /// group[i] is the group of star[i], or -1. Returns the number of groups.
  int GroupStar(const std::vector<std::uint32_t>& star, std::uint32_t v, bool in,
                std::vector<int>& group);
  /// Adds exterior cells not reachable from the infinite cells.
  void FillCavities();
  /// Keeps the largest solid wedge around edge (a, b) if it has several; cell holds a and b.
  void FixEdge(std::uint32_t a, std::uint32_t b, std::uint32_t cell);
  /// Makes v manifold: keeps its largest solid fan, or closes pinched tunnels at v.
  void FixVertex(std::uint32_t v, std::uint32_t cell);
  /// Fixes every edge with several solid wedges and every vertex with several boundary fans.
  void FixWholeBoundary();
  /// Fixes the edges and vertices of the given cells.
  void FixAround(const std::vector<std::uint32_t>& cells);

  std::vector<K::Point_3> points_;                    ///< the input, for CGAL's predicates
  std::vector<std::array<std::uint32_t, 4>> cell_v_;  ///< point index per slot, or kInfinite
  std::vector<std::array<std::uint32_t, 4>> cell_n_;  ///< neighbour cell per slot
  std::vector<char> infinite_;
  std::vector<double> volume_;
  std::vector<char> solid_;
  std::vector<char> locked_;
  std::vector<std::uint32_t> changed_;  ///< cells changed since the last round began
  int removed_ = 0, filled_ = 0, rounds_ = 0;
  K::FT fill_alpha2_ = 0.0;
  std::vector<std::uint32_t> stamp_;  ///< visit marks for star searches
  std::uint32_t stamp_now_ = 0;
  std::vector<int> local_index_;  ///< position of a cell in the current star, or -1
};

core::Result<Solid> Solid::Build(const std::vector<std::array<double, 3>>& points) {
  if (points.size() < 4) {
    return Unprocessable("need at least 4 points, got " + std::to_string(points.size()));
  }
  if (points.size() >= kInfinite) return Unprocessable("too many points");
  Solid s;
  std::vector<std::pair<K::Point_3, std::uint32_t>> input;
  input.reserve(points.size());
  s.points_.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) {
      return Unprocessable("point " + std::to_string(i) + " has a non-finite coordinate");
    }
    s.points_.emplace_back(p[0], p[1], p[2]);
    input.emplace_back(s.points_.back(), static_cast<std::uint32_t>(i));
  }
  // The triangulation lives only here: everything after works on the flat copy.
  Delaunay dt;
  dt.insert(input.begin(), input.end());
  if (dt.dimension() < 3) {
    return Unprocessable("the points are coplanar or collinear: no solid can be built");
  }
  std::uint32_t next = 0;
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c) c->info() = next++;
  s.cell_v_.resize(next);
  s.cell_n_.resize(next);
  s.infinite_.assign(next, 0);
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c) {
    const std::uint32_t id = c->info();
    for (int k = 0; k < 4; ++k) {
      const auto v = c->vertex(k);
      const bool inf = dt.is_infinite(v);
      s.cell_v_[id][static_cast<std::size_t>(k)] = inf ? kInfinite : v->info();
      s.cell_n_[id][static_cast<std::size_t>(k)] = c->neighbor(k)->info();
      if (inf) s.infinite_[id] = 1;
    }
  }
  s.volume_.assign(next, 0.0);
  for (std::uint32_t c = 0; c < next; ++c) {
    if (s.infinite_[c]) continue;
    const auto& v = s.cell_v_[c];
    const auto& p0 = points[v[0]];
    const auto& p1 = points[v[1]];
    const auto& p2 = points[v[2]];
    const auto& p3 = points[v[3]];
    const double a[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    const double b[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    const double d[3] = {p3[0] - p0[0], p3[1] - p0[1], p3[2] - p0[2]};
    s.volume_[c] =
        std::abs(a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) +
                 a[2] * (b[0] * d[1] - b[1] * d[0])) /
        6.0;
  }
  s.solid_.assign(next, 0);
  s.locked_.assign(next, 0);
  s.stamp_.assign(next, 0);
  s.local_index_.assign(next, -1);
  return s;
}

void Solid::Classify(double alpha, double fill_alpha) {
  const K::FT alpha2 = alpha * alpha;
  fill_alpha2_ = fill_alpha * fill_alpha;
  std::fill(locked_.begin(), locked_.end(), 0);
  changed_.clear();
  removed_ = filled_ = rounds_ = 0;
  const auto compare = K().compare_squared_radius_3_object();
  for (std::uint32_t c = 0; c < num_cells(); ++c) {
    if (IsInfinite(c)) {
      solid_[c] = 0;
      continue;
    }
    const auto& v = cell_v_[c];
    solid_[c] =
        compare(points_[v[0]], points_[v[1]], points_[v[2]], points_[v[3]], alpha2) != CGAL::LARGER;
  }
}

bool Solid::Fillable(std::uint32_t c) const {
  if (IsInfinite(c) || locked_[c]) return false;
  const auto& v = cell_v_[c];
  return K().compare_squared_radius_3_object()(points_[v[0]], points_[v[1]], points_[v[2]],
                                               points_[v[3]], fill_alpha2_) != CGAL::LARGER;
}

Solid::Pieces Solid::KeepLargestPiece() {
  std::vector<int> piece(num_cells(), -1);
  std::vector<double> piece_volume;
  std::vector<std::uint32_t> queue;
  for (std::uint32_t seed = 0; seed < num_cells(); ++seed) {
    if (!In(seed) || piece[seed] >= 0) continue;
    const int id = static_cast<int>(piece_volume.size());
    double volume = 0.0;
    queue.assign(1, seed);
    piece[seed] = id;
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const std::uint32_t c = queue[q];
      volume += volume_[c];
      for (const std::uint32_t n : cell_n_[c]) {
        if (In(n) && piece[n] < 0) {
          piece[n] = id;
          queue.push_back(n);
        }
      }
    }
    piece_volume.push_back(volume);
  }
  Pieces result;
  if (piece_volume.empty()) return result;
  for (const double v : piece_volume) result.total_volume += v;
  const auto best = static_cast<int>(std::max_element(piece_volume.begin(), piece_volume.end()) -
                                     piece_volume.begin());
  result.largest_volume = piece_volume[static_cast<std::size_t>(best)];
  result.dropped = static_cast<int>(piece_volume.size()) - 1;
  if (result.dropped == 0) return result;
  for (std::uint32_t c = 0; c < num_cells(); ++c) {
    if (piece[c] >= 0 && piece[c] != best) {
      solid_[c] = 0;
      result.dropped_volume += volume_[c];
    }
  }
  return result;
}

void Solid::FillCavities() {
  std::vector<char> outside(num_cells(), 0);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t c = 0; c < num_cells(); ++c) {
    if (IsInfinite(c)) {
      outside[c] = 1;
      queue.push_back(c);
    }
  }
  for (std::size_t q = 0; q < queue.size(); ++q) {
    for (const std::uint32_t n : cell_n_[queue[q]]) {
      if (!In(n) && !outside[n]) {
        outside[n] = 1;
        queue.push_back(n);
      }
    }
  }
  for (std::uint32_t c = 0; c < num_cells(); ++c) {
    if (!In(c) && !outside[c]) Fill(c);
  }
}

std::vector<BoundaryFacet> Solid::BoundaryFacets() const {
  std::vector<BoundaryFacet> facets;
  for (std::uint32_t c = 0; c < num_cells(); ++c) {
    if (!In(c)) continue;
    for (int i = 0; i < 4; ++i) {
      if (In(cell_n_[c][static_cast<std::size_t>(i)])) continue;
      BoundaryFacet f{};
      for (int j = 0; j < 3; ++j) {
        f.v[static_cast<std::size_t>(j)] = cell_v_[c][static_cast<std::size_t>(kFacetOut[i][j])];
      }
      f.cell = c;
      facets.push_back(f);
    }
  }
  return facets;
}

std::vector<DirectedEdge> SortedEdges(const std::vector<BoundaryFacet>& facets) {
  std::vector<DirectedEdge> edges;
  edges.reserve(3 * facets.size());
  for (std::uint32_t f = 0; f < facets.size(); ++f) {
    const auto& v = facets[f].v;
    for (std::size_t j = 0; j < 3; ++j) {
      const std::uint64_t a = v[j], b = v[(j + 1) % 3];
      edges.push_back({a << 32 | b, f});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const DirectedEdge& x, const DirectedEdge& y) {
    return x.key != y.key ? x.key < y.key : x.facet < y.facet;
  });
  return edges;
}

void Solid::CellsAroundEdge(std::uint32_t c, std::uint32_t a, std::uint32_t b,
                            std::vector<std::uint32_t>& out) const {
  // In a cell holding a, b, u, w, the neighbour opposite u holds a, b, w and one more vertex.
  out.clear();
  std::uint32_t u = 0;
  bool found = false;
  for (const std::uint32_t v : cell_v_[c]) {
    if (v != a && v != b) {
      u = v;
      found = true;
      break;
    }
  }
  if (!found) return;
  const std::uint32_t start = c;
  do {
    out.push_back(c);
    std::uint32_t w = u;
    for (const std::uint32_t v : cell_v_[c]) {
      if (v != a && v != b && v != u) w = v;
    }
    const int slot = Slot(c, u);
    if (slot < 0) break;  // cannot happen in a valid triangulation
    c = cell_n_[c][static_cast<std::size_t>(slot)];
    u = w;
  } while (c != start && out.size() <= num_cells());
}

void Solid::FixEdge(std::uint32_t a, std::uint32_t b, std::uint32_t cell) {
  std::vector<std::uint32_t> ring;
  CellsAroundEdge(cell, a, b, ring);
  const std::size_t n = ring.size();
  std::size_t gap = n;
  for (std::size_t k = 0; k < n && gap == n; ++k) {
    if (!In(ring[k])) gap = k;
  }
  if (gap == n) return;  // surrounded by solid
  // Solid wedges: maximal runs of solid cells around the edge, starting after a gap.
  std::vector<std::pair<double, std::vector<std::uint32_t>>> wedges;
  for (std::size_t step = 1; step <= n; ++step) {
    const std::uint32_t c = ring[(gap + step) % n];
    if (!In(c)) continue;
    if (!In(ring[(gap + step - 1) % n])) wedges.emplace_back(0.0, std::vector<std::uint32_t>{});
    wedges.back().first += volume_[c];
    wedges.back().second.push_back(c);
  }
  if (wedges.size() < 2) return;
  std::size_t best = 0;
  for (std::size_t w = 1; w < wedges.size(); ++w) {
    if (wedges[w].first > wedges[best].first) best = w;
  }
  for (std::size_t w = 0; w < wedges.size(); ++w) {
    if (w == best) continue;
    for (const std::uint32_t c : wedges[w].second) Remove(c);
  }
}

void Solid::Star(std::uint32_t c, std::uint32_t v, std::vector<std::uint32_t>& out) {
  out.assign(1, c);
  ++stamp_now_;
  stamp_[c] = stamp_now_;
  for (std::size_t q = 0; q < out.size(); ++q) {
    const std::uint32_t cell = out[q];
    for (std::size_t k = 0; k < 4; ++k) {
      if (cell_v_[cell][k] == v) continue;
      const std::uint32_t n = cell_n_[cell][k];
      if (stamp_[n] != stamp_now_) {
        stamp_[n] = stamp_now_;
        out.push_back(n);
      }
    }
  }
}

int Solid::GroupStar(const std::vector<std::uint32_t>& star, std::uint32_t v, bool in,
                     std::vector<int>& group) {
  group.assign(star.size(), -1);
  for (std::size_t i = 0; i < star.size(); ++i) local_index_[star[i]] = static_cast<int>(i);
  int groups = 0;
  std::vector<std::size_t> queue;
  for (std::size_t seed = 0; seed < star.size(); ++seed) {
    if (group[seed] >= 0 || In(star[seed]) != in) continue;
    group[seed] = groups;
    queue.assign(1, seed);
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const std::uint32_t cell = star[queue[q]];
      for (std::size_t k = 0; k < 4; ++k) {
        if (cell_v_[cell][k] == v) continue;
        const int li =
            local_index_[cell_n_[cell][k]];  // neighbours through v's facets are in the star
        if (li < 0) continue;
        const auto sli = static_cast<std::size_t>(li);
        if (group[sli] < 0 && In(star[sli]) == in) {
          group[sli] = groups;
          queue.push_back(sli);
        }
      }
    }
    ++groups;
  }
  for (const std::uint32_t c : star) local_index_[c] = -1;
  return groups;
}

void Solid::FixVertex(std::uint32_t v, std::uint32_t cell) {
  std::vector<std::uint32_t> star;
  std::vector<int> group;
  Star(cell, v, star);
  const int solid_groups = GroupStar(star, v, true, group);
  if (solid_groups > 1) {
    // Several solid fans meet at v: keep the largest, or the one holding cells an earlier fix
    // filled (those are locked). If several hold such cells, join the fans by filling the outside
    // around v when that is a small gap; otherwise leave it to the final check.
    std::vector<double> vol(static_cast<std::size_t>(solid_groups), 0.0);
    std::vector<char> has_locked(static_cast<std::size_t>(solid_groups), 0);
    for (std::size_t i = 0; i < star.size(); ++i) {
      if (group[i] < 0) continue;
      vol[static_cast<std::size_t>(group[i])] += volume_[star[i]];
      if (locked_[star[i]]) has_locked[static_cast<std::size_t>(group[i])] = 1;
    }
    const auto locked_groups = std::count(has_locked.begin(), has_locked.end(), char{1});
    int best = static_cast<int>(std::max_element(vol.begin(), vol.end()) - vol.begin());
    if (locked_groups == 1) {
      best = static_cast<int>(std::find(has_locked.begin(), has_locked.end(), char{1}) -
                              has_locked.begin());
    } else if (locked_groups > 1) {
      bool can_fill = true;
      for (std::size_t i = 0; i < star.size() && can_fill; ++i) {
        if (!In(star[i])) can_fill = Fillable(star[i]);
      }
      for (std::size_t i = 0; i < star.size() && can_fill; ++i) {
        if (!In(star[i])) Fill(star[i]);
      }
      return;
    }
    for (std::size_t i = 0; i < star.size(); ++i) {
      if (group[i] >= 0 && group[i] != best) Remove(star[i]);
    }
    return;
  }
  if (solid_groups == 0) return;
  const int outside_groups = GroupStar(star, v, false, group);
  if (outside_groups <= 1) return;
  // One solid fan, but the outside reaches v in several places (a tunnel pinched to a point).
  // Keep the outside fan that reaches infinity (or the largest); fill the others if they are
  // small gaps (every cell within fill_alpha), else cut the solid away from v.
  std::vector<double> vol(static_cast<std::size_t>(outside_groups), 0.0);
  std::vector<char> reaches_infinity(static_cast<std::size_t>(outside_groups), 0);
  for (std::size_t i = 0; i < star.size(); ++i) {
    if (group[i] < 0) continue;
    const auto g = static_cast<std::size_t>(group[i]);
    vol[g] += volume_[star[i]];
    if (IsInfinite(star[i])) reaches_infinity[g] = 1;
  }
  const auto infinite_groups =
      std::count(reaches_infinity.begin(), reaches_infinity.end(), char{1});
  std::size_t keep = 0;
  if (infinite_groups > 0) {
    keep = static_cast<std::size_t>(
        std::find(reaches_infinity.begin(), reaches_infinity.end(), char{1}) -
        reaches_infinity.begin());
  } else {
    keep = static_cast<std::size_t>(std::max_element(vol.begin(), vol.end()) - vol.begin());
  }
  bool can_fill = infinite_groups <= 1;
  for (std::size_t i = 0; i < star.size() && can_fill; ++i) {
    if (group[i] >= 0 && static_cast<std::size_t>(group[i]) != keep) can_fill = Fillable(star[i]);
  }
  for (std::size_t i = 0; i < star.size(); ++i) {
    if (can_fill && group[i] >= 0 && static_cast<std::size_t>(group[i]) != keep) {
      Fill(star[i]);
    } else if (!can_fill && In(star[i])) {
      Remove(star[i]);
    }
  }
}

void Solid::FixWholeBoundary() {
  const std::vector<BoundaryFacet> facets = BoundaryFacets();
  const std::vector<DirectedEdge> edges = SortedEdges(facets);
  // A directed boundary edge that appears twice has several solid wedges around it.
  for (std::size_t i = 0; i + 1 < edges.size(); ++i) {
    if (edges[i].key != edges[i + 1].key) continue;
    if (i > 0 && edges[i - 1].key == edges[i].key) continue;  // once per edge
    FixEdge(static_cast<std::uint32_t>(edges[i].key >> 32),
            static_cast<std::uint32_t>(edges[i].key & 0xffffffffu), facets[edges[i].facet].cell);
  }
  // Corners (facet, slot) of one point joined across each edge; one group per point = one fan.
  std::vector<std::uint32_t> parent(3 * facets.size());
  for (std::uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  auto corner = [&](std::uint32_t f, std::uint32_t point) {
    const auto& v = facets[f].v;
    return 3 * f + (v[0] == point ? 0u : (v[1] == point ? 1u : 2u));
  };
  auto unite = [&](std::uint32_t x, std::uint32_t y) {
    x = find(x);
    y = find(y);
    if (x != y) parent[std::max(x, y)] = std::min(x, y);
  };
  for (const DirectedEdge& e : edges) {
    const auto a = static_cast<std::uint32_t>(e.key >> 32);
    const auto b = static_cast<std::uint32_t>(e.key & 0xffffffffu);
    if (a > b) continue;  // each pair once, from its a < b half
    const std::uint64_t twin_key = static_cast<std::uint64_t>(b) << 32 | a;
    const auto twin =
        std::lower_bound(edges.begin(), edges.end(), twin_key,
                         [](const DirectedEdge& x, std::uint64_t k) { return x.key < k; });
    if (twin == edges.end() || twin->key != twin_key) continue;
    unite(corner(e.facet, a), corner(twin->facet, a));
    unite(corner(e.facet, b), corner(twin->facet, b));
  }
  std::vector<std::uint32_t> root(points_.size(), kInfinite);
  std::vector<std::uint32_t> bad;  // points with several fans, in facet order
  std::vector<char> is_bad(points_.size(), 0);
  for (std::uint32_t f = 0; f < facets.size(); ++f) {
    for (std::uint32_t j = 0; j < 3; ++j) {
      const std::uint32_t p = facets[f].v[j];
      const std::uint32_t r = find(3 * f + j);
      if (root[p] == kInfinite) {
        root[p] = r;
      } else if (root[p] != r && !is_bad[p]) {
        is_bad[p] = 1;
        bad.push_back(p);
      }
    }
  }
  // Any solid cell holding the point starts its star search.
  std::vector<std::uint32_t> seed(points_.size(), kInfinite);
  for (const BoundaryFacet& f : facets) {
    for (const std::uint32_t p : f.v) {
      if (is_bad[p] && seed[p] == kInfinite) seed[p] = f.cell;
    }
  }
  // Detection used the facets from before the edge fixes; FixVertex re-checks the current cells.
  for (const std::uint32_t p : bad) FixVertex(p, seed[p]);
}

void Solid::FixAround(const std::vector<std::uint32_t>& cells) {
  // Edges and vertices of the changed cells, each once, in a fixed order.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> edges;   // (a << 32 | b, cell), a < b
  std::vector<std::pair<std::uint32_t, std::uint32_t>> points;  // (point, cell)
  for (const std::uint32_t c : cells) {
    const auto& v = cell_v_[c];
    for (std::size_t i = 0; i < 4; ++i) {
      if (v[i] == kInfinite) continue;
      points.emplace_back(v[i], c);
      for (std::size_t j = i + 1; j < 4; ++j) {
        if (v[j] == kInfinite) continue;
        const std::uint64_t a = std::min(v[i], v[j]), b = std::max(v[i], v[j]);
        edges.emplace_back(a << 32 | b, c);
      }
    }
  }
  auto by_key = [](const auto& x, const auto& y) { return x.first < y.first; };
  auto same_key = [](const auto& x, const auto& y) { return x.first == y.first; };
  std::stable_sort(edges.begin(), edges.end(), by_key);
  edges.erase(std::unique(edges.begin(), edges.end(), same_key), edges.end());
  std::stable_sort(points.begin(), points.end(), by_key);
  points.erase(std::unique(points.begin(), points.end(), same_key), points.end());
  for (const auto& [key, cell] : edges) {
    FixEdge(static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key & 0xffffffffu),
            cell);
  }
  for (const auto& [point, cell] : points) FixVertex(point, cell);
}

bool Solid::Repair(int max_rounds) {
  // Removals never enclose a cavity (a removed cell touches the outside of the solid), so
  // cavities are looked for only at the start and after fills.
  bool look_for_cavities = true;
  std::vector<std::uint32_t> last;
  for (rounds_ = 1; rounds_ <= max_rounds; ++rounds_) {
    const int filled_before = filled_;
    changed_.clear();
    if (look_for_cavities) FillCavities();
    if (rounds_ == 1) {
      FixWholeBoundary();
    } else {
      FixAround(last);
    }
    // Cells filled in cavities are around too.
    if (changed_.empty()) return true;
    look_for_cavities = filled_ != filled_before;
    last = changed_;
  }
  rounds_ = max_rounds;
  return false;
}

/// Faces as point indices -> canonical mesh (see AlphaShapeResult::mesh).
TriangleMesh CanonicalMesh(const std::vector<BoundaryFacet>& facets,
                           const std::vector<std::array<double, 3>>& points) {
  std::vector<std::array<int, 3>> faces;
  faces.reserve(facets.size());
  for (const BoundaryFacet& b : facets) {
    faces.push_back({static_cast<int>(b.v[0]), static_cast<int>(b.v[1]), static_cast<int>(b.v[2])});
  }
  for (auto& f : faces) {
    const auto m = static_cast<std::size_t>(std::min_element(f.begin(), f.end()) - f.begin());
    std::rotate(f.begin(), f.begin() + static_cast<std::ptrdiff_t>(m), f.end());
  }
  std::sort(faces.begin(), faces.end());
  TriangleMesh mesh;
  std::vector<int> renumber(points.size(), -1);
  mesh.faces.reserve(faces.size());
  for (const auto& f : faces) {
    std::array<int, 3> g{};
    for (std::size_t k = 0; k < 3; ++k) {
      int& id = renumber[static_cast<std::size_t>(f[k])];
      if (id < 0) {
        id = static_cast<int>(mesh.vertices.size());
        mesh.vertices.push_back(points[static_cast<std::size_t>(f[k])]);
      }
      g[k] = id;
    }
    mesh.faces.push_back(g);
  }
  return mesh;
}

void CheckOptions(const AlphaShapeOptions& o) {
  if (!(o.alpha > 0.0 && std::isfinite(o.alpha))) {
    throw std::invalid_argument("AlphaShapeOptions: alpha must be finite and > 0");
  }
  if (!(o.raise_factor > 1.0 && std::isfinite(o.raise_factor))) {
    throw std::invalid_argument("AlphaShapeOptions: raise_factor must be > 1");
  }
  if (o.max_raises < 0) throw std::invalid_argument("AlphaShapeOptions: max_raises < 0");
  if (!(o.min_piece_volume_fraction >= 0.0 && o.min_piece_volume_fraction <= 1.0)) {
    throw std::invalid_argument("AlphaShapeOptions: min_piece_volume_fraction outside [0, 1]");
  }
  if (o.max_repair_rounds < 1)
    throw std::invalid_argument("AlphaShapeOptions: max_repair_rounds < 1");
}

}  // namespace

core::Result<AlphaShapeResult> ReconstructAlphaShape(
    const std::vector<std::array<double, 3>>& points, const AlphaShapeOptions& options) {
  CheckOptions(options);
  auto built = Solid::Build(points);
  if (!built.ok()) return built.error();
  Solid& solid = built.value();

  AlphaShapeResult result;
  result.alpha_requested = options.alpha;
  std::string last_reason = "no alpha tried";
  for (int raise = 0; raise <= options.max_raises; ++raise) {
    const double alpha = options.alpha * std::pow(options.raise_factor, raise);
    solid.Classify(alpha, alpha * options.raise_factor);
    Solid::Pieces pieces = solid.KeepLargestPiece();
    const double raw_volume = pieces.total_volume;
    if (raw_volume <= 0.0) {
      last_reason = "no tetrahedron fits at alpha " + std::to_string(alpha);
      continue;
    }
    if (pieces.largest_volume < options.min_piece_volume_fraction * raw_volume) {
      last_reason = "the largest piece holds only " +
                    std::to_string(pieces.largest_volume / raw_volume) + " of the solid";
      continue;
    }
    if (!solid.Repair(options.max_repair_rounds)) {
      last_reason = "the manifold repair did not settle at alpha " + std::to_string(alpha);
      continue;
    }
    if (solid.removed() > 0) {
      // Pieces cut off by removals go last: a settled solid has no pieces touching each other
      // (that would be a non-manifold edge or vertex), so dropping whole pieces keeps it valid.
      const Solid::Pieces more = solid.KeepLargestPiece();
      pieces.dropped += more.dropped;
      pieces.dropped_volume += more.dropped_volume;
    }
    if (pieces.dropped_volume > (1.0 - options.min_piece_volume_fraction) * raw_volume) {
      last_reason = "the repair dropped " + std::to_string(pieces.dropped_volume / raw_volume) +
                    " of the solid";
      continue;
    }
    TriangleMesh mesh = CanonicalMesh(solid.BoundaryFacets(), points);
    // The facets belong to one Delaunay triangulation of the exact input points, so they cannot
    // cross each other: the (costlier) self-intersection test is left to callers that move the
    // vertices afterwards (GenerateFractal, after rounding to float32).
    MeshCheckOptions check_options;
    check_options.self_intersections = false;
    const MeshReport report = CheckMesh(mesh, check_options);
    if (!report.ok()) {
      last_reason = "invalid mesh at alpha " + std::to_string(alpha) + ": " +
                    (report.problems.empty() ? std::string() : report.problems.front());
      continue;
    }
    result.mesh = std::move(mesh);
    result.alpha_used = alpha;
    result.raises = raise;
    result.pieces_dropped = pieces.dropped;
    result.dropped_volume_fraction = std::min(1.0, pieces.dropped_volume / raw_volume);
    result.cells_removed = solid.removed();
    result.cells_filled = solid.filled();
    result.repair_rounds = solid.rounds();
    result.volume = report.volume;
    return result;
  }
  return Unprocessable(
      "no closed 2-manifold alpha shape up to alpha " +
      std::to_string(options.alpha * std::pow(options.raise_factor, options.max_raises)) + " (" +
      last_reason + ")");
}

core::Result<std::vector<std::array<int, 3>>> RawAlphaShapeFacets(
    const std::vector<std::array<double, 3>>& points, double alpha) {
  if (!(alpha > 0.0 && std::isfinite(alpha))) {
    throw std::invalid_argument("RawAlphaShapeFacets: alpha must be finite and > 0");
  }
  auto built = Solid::Build(points);
  if (!built.ok()) return built.error();
  built.value().Classify(alpha, alpha);
  std::vector<std::array<int, 3>> faces;
  for (const BoundaryFacet& f : built.value().BoundaryFacets()) {
    faces.push_back({static_cast<int>(f.v[0]), static_cast<int>(f.v[1]), static_cast<int>(f.v[2])});
  }
  return faces;
}

}  // namespace softgrasp::mesh
