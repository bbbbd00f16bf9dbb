#pragma once
/// The fractal mesh pipeline (thesis ch. 4, see docs/fractals.md): random 3D-IFS -> chaos-game
/// point cloud -> variance check -> alpha shape -> closed mesh scaled to fit the gripper.
/// Same params (seed included) -> the same model, bit for bit, on every run.

#include <array>
#include <cstdint>
#include <optional>

#include "service/core/status.h"
#include "service/mesh/ifs.h"
#include "service/mesh/mesh.h"

namespace softgrasp::mesh {

struct FractalParams {
  std::uint64_t seed = 0;
  int min_maps = 2;  ///< maps per system drawn uniformly in [min_maps, max_maps]; 1..32
  int max_maps = 7;
  int num_points = 10000;           ///< chaos-game points kept; 100..1,000,000
  int burn_in = 100;                ///< chaos-game steps discarded first; 0..1,000,000
  double sigma = 0.05;              ///< keep a cloud only if min axis variance > sigma; [0, 0.2]
  double alpha = 0.3;               ///< alpha-shape ball radius on the normalised cloud; (0, 1000]
  double gripper_opening_m = 0.05;  ///< gripper opening stroke, metres; (0, 2]
  double fit_fraction = 0.8;        ///< smallest bounding-box side = fit_fraction * opening; (0, 1]
  int max_attempts = 100000;        ///< draws before giving up; 1..10,000,000
  double min_piece_volume_fraction = 0.5;  ///< see AlphaShapeOptions; [0, 1]
  int max_alpha_raises = 24;               ///< see AlphaShapeOptions; 0..64
  /// Before triangulating, chaos-game points in the same grid cell of side
  /// min(merge_fraction * alpha, 0.05) (on the normalised cloud) are merged into the first of them
  /// (MergeGridNeighbours): the clustered clouds have far more points than the alpha shape can
  /// resolve, and the triangulation dominates the time. 0 = off; [0, 0.25].
  double merge_fraction = 0.05;
};

/// Why draws were rejected before one was accepted.
struct FractalRejections {
  int expanding = 0;        ///< sum_i p_i log|det A_i| >= 0: cannot contract onto an attractor
  int diverged = 0;         ///< a chaos-game point left the +-1e6 box (or became NaN)
  int low_variance = 0;     ///< min axis variance <= sigma (or <= sigma / 2 on a prefix)
  int no_solid = 0;         ///< no valid alpha shape up to the largest raised alpha
  int float_collision = 0;  ///< two mesh vertices became equal when rounded to float32
  /// After scaling and rounding to float32, two faces cut through each other or a face lost its
  /// area (MeshReport::self_intersection_free): the rounding moves vertices by up to half a
  /// float32 step (~2 nm at 2.5 cm), enough to fold a sliver of the solid that is thinner.
  int self_intersecting = 0;
};

struct FractalModel {
  /// Closed, 2-manifold, connected, outward-oriented; metres; bounding box centred on the origin;
  /// coordinates exactly representable as float32 (so every export format is lossless).
  TriangleMesh mesh;
  Ifs ifs;           ///< the accepted system
  int attempts = 0;  ///< draws until accepted (this one included)
  FractalRejections rejections;
  int num_points = 0;                 ///< points in the cloud
  int points_triangulated = 0;        ///< of those, left after merging (see merge_fraction)
  double merge_cell = 0.0;            ///< merge grid cell side on the normalised cloud (0 = off)
  std::array<double, 3> variances{};  ///< per-axis variance of the normalised cloud
  double alpha_requested = 0.0;       ///< on the normalised cloud (longest side spans [-1, 1])
  double alpha_used = 0.0;            ///< alpha_requested * 1.5^alpha_raises
  bool alpha_raised = false;
  int alpha_raises = 0;
  int pieces_dropped = 0;  ///< alpha-solid pieces not kept (see alpha_shape.h)
  double dropped_volume_fraction = 0.0;
  int cells_removed = 0;  ///< tetrahedra removed / filled by the manifold repair
  int cells_filled = 0;
  std::array<double, 3> bbox_min_m{};
  std::array<double, 3> bbox_max_m{};
  double volume_m3 = 0.0;
  double scale_m_per_unit = 0.0;  ///< metres per unit of the normalised cloud
};

/// The seed of draw `attempt` (1-based): each draw runs its own std::mt19937_64 seeded with
/// SplitMix64(seed + attempt * 0x9E3779B97F4A7C15), so a draw can be replayed on its own.
std::uint64_t DrawSeed(std::uint64_t seed, int attempt);

/// Moves the mesh's bounding-box centre to the origin, scales it so the smallest side is just
/// under `target_m` (1 ppm, so rounding cannot push it over) and rounds every coordinate to
/// float32, in place: the last geometric step of GenerateFractal. Returns the scale (output units
/// per input unit), or 0 if the box is flat or two vertices became equal after rounding (the mesh
/// is then unusable). Does not check the result; GenerateFractal runs CheckMesh on it.
double ScaleToGripper(TriangleMesh& mesh, double target_m);

/// Checks params against the ranges above: a kInvalidArgument error naming the field at fault,
/// or nothing when all are valid.
std::optional<core::Error> ValidateFractalParams(const FractalParams& params);

/// Runs the pipeline. Errors: kInvalidArgument (field = the parameter), kUnprocessable
/// (field "max_attempts") when no draw was accepted within max_attempts.
core::Result<FractalModel> GenerateFractal(const FractalParams& params);

}  // namespace softgrasp::mesh
