// Items built from grid cells: box, sponge, block, brush (docs/sim-catalogue.md). Faces are
// subdivided so each stiffness field is carried by vertices; region borders get two grid lines
// 1 mm apart so the interpolated field stays sharp there.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "sim/catalogue/builder.h"

namespace softgrasp::sim::catalogue_internal {
namespace {

constexpr double kBorderGapM = 0.001;

// [lo, hi] split into an even number of equal steps no longer than max_step_m, so the middle of
// the range is a grid line (face centres become vertices). Endpoints are exact.
std::vector<double> EvenSteps(double lo, double hi, double max_step_m) {
  int steps = std::max(2, static_cast<int>(std::ceil((hi - lo) / max_step_m - 1e-9)));
  steps += steps % 2;
  std::vector<double> out;
  for (int k = 0; k < steps; ++k) out.push_back(lo + (hi - lo) * k / steps);
  out.push_back(hi);
  return out;
}

bool InBox(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return (p.array() > lo.array()).all() && (p.array() < hi.array()).all();
}

Built UniformCuboid(const Eigen::Vector3d& size_m, double max_step_m, float stiffness,
                    double density_kg_m3) {
  const Eigen::Vector3d half = size_m / 2;
  const CellGrid grid{EvenSteps(-half.x(), half.x(), max_step_m),
                      EvenSteps(-half.y(), half.y(), max_step_m),
                      EvenSteps(-half.z(), half.z(), max_step_m)};
  return {CellSolid(
              grid, [](const Eigen::Vector3d&) { return true; },
              [&](const Eigen::Vector3d&) { return stiffness; }),
          density_kg_m3};
}

}  // namespace

Built BuildBox(ShapeSampler& sampler) {
  // A cardboard carton: folded edges and corners hold their shape, the middle of a face gives.
  // Stiffness falls linearly with the distance from the nearest edge, down to the face level at
  // half the smallest box dimension; corners stiffen further within 15 mm.
  const double length = sampler.HeldOut("length_m", 0.080, 0.200);
  const double width = sampler.Uniform("width_m", 0.030, 0.048);
  const double height = sampler.Uniform("height_m", 0.040, 0.120);
  const Eigen::Vector3d half(length / 2, width / 2, height / 2);
  constexpr double kMaxStepM = 0.0075;
  const CellGrid grid{EvenSteps(-half.x(), half.x(), kMaxStepM),
                      EvenSteps(-half.y(), half.y(), kMaxStepM),
                      EvenSteps(-half.z(), half.z(), kMaxStepM)};
  const double edge_falloff = std::min({length, width, height}) / 2;
  constexpr double kCornerFalloffM = 0.015;
  constexpr double kFace = 0.3, kEdge = 0.8, kCornerExtra = 0.2;
  auto stiffness = [&](const Eigen::Vector3d& p) {
    // Distances to the two slab faces nearest along each axis; on the surface one is zero, the
    // next smallest is the distance to the nearest edge, the largest bounds the nearest corner.
    std::array<double, 3> to_side = {half.x() - std::abs(p.x()), half.y() - std::abs(p.y()),
                                     half.z() - std::abs(p.z())};
    std::sort(to_side.begin(), to_side.end());
    const double edge_weight = 1.0 - std::min(1.0, to_side[1] / edge_falloff);
    const double corner_weight = 1.0 - std::min(1.0, to_side[2] / kCornerFalloffM);
    return static_cast<float>(kFace + (kEdge - kFace) * edge_weight + kCornerExtra * corner_weight);
  };
  return {CellSolid(
              grid, [](const Eigen::Vector3d&) { return true; }, stiffness),
          200.0};
}

Built BuildSponge(ShapeSampler& sampler) {
  // A kitchen sponge: open-cell foam (0.1) with a scouring pad glued on top (0.3).
  const double length = sampler.HeldOut("length_m", 0.070, 0.120);
  const double width = sampler.Uniform("width_m", 0.045, 0.075);
  const double thickness = sampler.Uniform("thickness_m", 0.015, 0.040);
  const double pad = sampler.Uniform("pad_thickness_m", 0.003, 0.008);
  constexpr double kMaxStepM = 0.010;
  constexpr float kFoam = 0.1f, kPad = 0.3f;
  const double z_pad = thickness - pad;
  const CellGrid grid{EvenSteps(-length / 2, length / 2, kMaxStepM),
                      EvenSteps(-width / 2, width / 2, kMaxStepM),
                      Subdivide({0.0, z_pad - kBorderGapM, z_pad, thickness}, kMaxStepM)};
  return {CellSolid(
              grid, [](const Eigen::Vector3d&) { return true; },
              [&](const Eigen::Vector3d& p) { return p.z() >= z_pad - 1e-9 ? kPad : kFoam; }),
          30.0};
}

Built BuildBlock(ShapeSampler& sampler) {
  // A wooden toy block: rigid everywhere.
  const double size_x = sampler.HeldOut("size_x_m", 0.025, 0.050);
  const double size_y = sampler.Uniform("size_y_m", 0.025, 0.050);
  const double size_z = sampler.Uniform("size_z_m", 0.025, 0.050);
  return UniformCuboid({size_x, size_y, size_z}, 0.025, 1.0f, 700.0);
}

Built BuildBrush(ShapeSampler& sampler) {
  // A scrubbing brush lying flat: a rigid plastic handle (0.9) running into a taller, wider head
  // of bristles (0.2). One closed surface: the union of two boxes sharing the z = 0 plane.
  const double handle_length = sampler.HeldOut("handle_length_m", 0.080, 0.155);
  const double handle_width = sampler.Uniform("handle_width_m", 0.015, 0.025);
  const double handle_thickness = sampler.Uniform("handle_thickness_m", 0.010, 0.018);
  const double head_length = sampler.Uniform("head_length_m", 0.040, 0.070);
  const double head_width = sampler.Uniform("head_width_m", 0.030, 0.048);
  const double head_height = sampler.Uniform("head_height_m", 0.025, 0.045);
  constexpr double kMaxStepM = 0.010;
  constexpr float kHandle = 0.9f, kHead = 0.2f;
  const double x_head = handle_length;  // the head starts where the handle ends
  const double x_end = handle_length + head_length;
  const CellGrid grid{
      Subdivide({0.0, x_head - kBorderGapM, x_head, x_end}, kMaxStepM),
      Subdivide({-head_width / 2, -handle_width / 2, handle_width / 2, head_width / 2}, kMaxStepM),
      Subdivide({0.0, handle_thickness, head_height}, kMaxStepM)};
  const Eigen::Vector3d handle_lo(0.0, -handle_width / 2, 0.0);
  const Eigen::Vector3d handle_hi(x_head, handle_width / 2, handle_thickness);
  const Eigen::Vector3d head_lo(x_head, -head_width / 2, 0.0);
  const Eigen::Vector3d head_hi(x_end, head_width / 2, head_height);
  return {CellSolid(
              grid,
              [&](const Eigen::Vector3d& c) {
                return InBox(c, handle_lo, handle_hi) || InBox(c, head_lo, head_hi);
              },
              [&](const Eigen::Vector3d& p) {
                return p.x() <= x_head - kBorderGapM / 2 ? kHandle : kHead;
              }),
          600.0};
}

}  // namespace softgrasp::sim::catalogue_internal
