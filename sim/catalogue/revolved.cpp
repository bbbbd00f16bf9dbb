// Solids of revolution: bottle, can, cup (docs/sim-catalogue.md). Each builder lays out a
// profile in the (r, z) plane from the bottom centre round to the top centre; a ring's stiffness
// follows from the part of the item it belongs to.
#include <cmath>
#include <numbers>
#include <vector>

#include "sim/catalogue/builder.h"

namespace softgrasp::sim::catalogue_internal {
namespace {

constexpr int kSegments = 40;            // vertices per ring: 5.5 mm chords at 70 mm diameter
constexpr double kMaxRingStepM = 0.006;  // rings at most 6 mm apart along side walls
constexpr double kBorderGapM = 0.001;    // two rings this close keep a region border sharp

float F(double s) { return static_cast<float>(s); }

}  // namespace

Built BuildBottle(ShapeSampler& sampler) {
  // A PET bottle: hard screw cap, thick neck finish, shoulder and base ring stiffer than the thin
  // blow-moulded body.
  const double diameter = sampler.HeldOut("body_diameter_m", 0.035, 0.070);
  const double aspect = sampler.Uniform("height_to_diameter", 3.0, 4.0);
  const double cap_diameter = sampler.Uniform("cap_diameter_m", 0.022, 0.030);
  const double cap_height = sampler.Uniform("cap_height_m", 0.010, 0.020);
  const double neck_height = sampler.Uniform("neck_height_m", 0.008, 0.020);
  const double shoulder_height = diameter * sampler.Uniform("shoulder_to_diameter", 0.35, 0.8);
  const double base_ring_height = sampler.Uniform("base_ring_height_m", 0.008, 0.015);
  const double height = diameter * aspect;
  sampler.Record("height_m", height);
  sampler.Record("shoulder_height_m", shoulder_height);

  const double radius = diameter / 2;
  const double cap_radius = cap_diameter / 2;
  const double neck_radius = cap_radius - 0.0015;  // the cap overhangs the neck by 1.5 mm
  const double z_cap = height - cap_height;
  const double z_neck = z_cap - neck_height;
  const double z_shoulder = z_neck - shoulder_height;
  const double z_body_mid = (base_ring_height + z_shoulder) / 2;
  sampler.Record("body_mid_height_m", z_body_mid);
  // Stiffness eases from the stiff rings into the soft body over at most 8 mm.
  const double ramp = std::min(0.008, (z_shoulder - base_ring_height) / 4);
  constexpr double kBase = 0.8, kBody = 0.3, kShoulder = 0.7, kNeck = 0.9, kCap = 1.0;
  auto wall_stiffness = [&](double z) {
    if (z <= base_ring_height) return kBase;
    if (z < base_ring_height + ramp) return Ramp(kBase, kBody, (z - base_ring_height) / ramp);
    if (z < z_shoulder - ramp) return kBody;
    return Ramp(kBody, kShoulder, (z - (z_shoulder - ramp)) / ramp);
  };

  constexpr double kChamfer = 0.003;
  std::vector<ProfilePoint> profile = {
      {0.0, 0.0, F(kBase)}, {radius / 2, 0.0, F(kBase)}, {radius - kChamfer, 0.0, F(kBase)}};
  for (const double z : Subdivide({kChamfer, base_ring_height, base_ring_height + ramp, z_body_mid,
                                   z_shoulder - ramp, z_shoulder},
                                  kMaxRingStepM)) {
    profile.push_back({radius, z, F(wall_stiffness(z))});
  }
  // Shoulder: r = neck + (body - neck) cos(pi t / 2) meets the body wall with a vertical tangent.
  constexpr int kShoulderSteps = 8;
  for (int k = 1; k <= kShoulderSteps; ++k) {
    const double t = static_cast<double>(k) / kShoulderSteps;
    profile.push_back({neck_radius + (radius - neck_radius) * std::cos(std::numbers::pi * t / 2),
                       z_shoulder + shoulder_height * t, F(Ramp(kShoulder, kNeck - 0.1, t))});
  }
  profile.push_back({neck_radius, (z_neck + z_cap - kBorderGapM) / 2, F(kNeck)});
  profile.push_back({neck_radius, z_cap - kBorderGapM, F(kNeck)});
  profile.push_back({neck_radius, z_cap, F(kCap)});
  profile.push_back({cap_radius, z_cap, F(kCap)});
  profile.push_back({cap_radius, height - 0.001, F(kCap)});
  profile.push_back({cap_radius - 0.001, height, F(kCap)});
  profile.push_back({0.0, height, F(kCap)});
  return {Revolve(profile, kSegments), 1000.0};
}

Built BuildCan(ShapeSampler& sampler) {
  // A drink can: rolled seam rim on top and the standing ring below are hard, the lids stiff, the
  // thin side wall dents in its middle.
  const double height = sampler.HeldOut("height_m", 0.060, 0.135);
  const double diameter = sampler.Uniform("diameter_m", 0.040, 0.049);
  const double dome_height = sampler.Uniform("dome_height_m", 0.003, 0.008);
  const double neck_in = sampler.Uniform("neck_in_m", 0.002, 0.005);
  const double radius = diameter / 2;

  constexpr double kRim = 1.0, kLid = 0.9, kWallNearRim = 0.8, kWallMid = 0.5;
  constexpr double kFootInset = 0.003, kFootRise = 0.004;  // standing ring to full radius
  constexpr double kTopTaper = 0.006, kLidRecess = 0.003, kRimWidth = 0.0015;
  constexpr double kWallRamp = 0.015;  // the rims stiffen the wall within 15 mm
  const double z_wall_lo = kFootRise, z_wall_hi = height - kTopTaper;
  const double z_wall_mid = (z_wall_lo + z_wall_hi) / 2;
  sampler.Record("wall_mid_height_m", z_wall_mid);
  auto wall_stiffness = [&](double z) {
    const double from_rim = std::min(z - z_wall_lo, z_wall_hi - z);
    return Ramp(kWallNearRim, kWallMid, from_rim / kWallRamp);
  };

  std::vector<ProfilePoint> profile = {{0.0, dome_height, F(kLid)},
                                       {(radius - kFootInset) / 2, 0.6 * dome_height, F(kLid)},
                                       {radius - kFootInset, 0.0, F(kRim)},
                                       {radius - kFootInset / 3, kFootRise / 2, F(kRim)}};
  const std::vector<double> wall_z =
      Subdivide({z_wall_lo, z_wall_lo + kWallRamp, z_wall_mid, z_wall_hi - kWallRamp, z_wall_hi},
                kMaxRingStepM);
  for (std::size_t i = 0; i < wall_z.size(); ++i) {
    const bool at_rim = i == 0 || i + 1 == wall_z.size();
    profile.push_back({radius, wall_z[i], F(at_rim ? kRim : wall_stiffness(wall_z[i]))});
  }
  const double rim_radius = radius - neck_in;
  profile.push_back({radius - 0.4 * neck_in, height - kTopTaper / 2, F(kRim)});
  profile.push_back({rim_radius, height - kRimWidth, F(kRim)});
  profile.push_back({rim_radius, height, F(kRim)});
  profile.push_back({rim_radius - kRimWidth, height, F(kRim)});
  profile.push_back({rim_radius - kRimWidth - 0.0005, height - kLidRecess, F(kLid)});
  profile.push_back({(rim_radius - kRimWidth) / 2, height - kLidRecess, F(kLid)});
  profile.push_back({0.0, height - kLidRecess, F(kLid)});
  return {Revolve(profile, kSegments), 1000.0};
}

Built BuildCup(ShapeSampler& sampler) {
  // A tapered polypropylene cup: a solid of revolution with a well. The rolled rim and the thick
  // base are stiff, the thin wall flexes most halfway up.
  const double height = sampler.HeldOut("height_m", 0.060, 0.110);
  const double top_diameter = sampler.Uniform("top_outer_diameter_m", 0.055, 0.085);
  const double base_diameter = top_diameter * sampler.Uniform("base_to_top_diameter", 0.65, 0.9);
  const double wall = sampler.Uniform("wall_thickness_m", 0.002, 0.004);
  const double base_thickness = sampler.Uniform("base_thickness_m", 0.004, 0.008);
  sampler.Record("base_outer_diameter_m", base_diameter);

  const double top_radius = top_diameter / 2, base_radius = base_diameter / 2;
  const double z_mid = (base_thickness + height) / 2;  // wall middle, outside and in the well
  sampler.Record("wall_mid_height_m", z_mid);
  constexpr double kRim = 0.8, kBase = 0.8, kWallMid = 0.4;
  const double ramp = std::min(0.010, (height - base_thickness) / 4);
  auto wall_stiffness = [&](double z) {
    const double from_end = std::min(z - base_thickness, height - z);
    return Ramp(z > z_mid ? kRim : kBase, kWallMid, from_end / ramp);
  };
  // Outer wall radius at height z (linear taper), the inner wall parallel to it.
  auto outer_radius = [&](double z) {
    return base_radius + (top_radius - base_radius) * z / height;
  };
  const std::vector<double> wall_z = Subdivide(
      {base_thickness, base_thickness + ramp, z_mid, height - ramp, height}, kMaxRingStepM);

  constexpr double kChamfer = 0.002;
  std::vector<ProfilePoint> profile = {{0.0, 0.0, F(kBase)},
                                       {base_radius / 2, 0.0, F(kBase)},
                                       {base_radius - kChamfer, 0.0, F(kBase)},
                                       {outer_radius(kChamfer), kChamfer, F(kBase)}};
  for (const double z : wall_z) profile.push_back({outer_radius(z), z, F(wall_stiffness(z))});
  profile.push_back({top_radius - wall / 2, height, F(kRim)});  // rim top, middle of the lip
  for (auto it = wall_z.rbegin(); it != wall_z.rend(); ++it) {
    profile.push_back({outer_radius(*it) - wall, *it, F(wall_stiffness(*it))});
  }
  const double floor_radius = outer_radius(base_thickness) - wall;
  profile.push_back({floor_radius / 2, base_thickness, F(kBase)});
  profile.push_back({0.0, base_thickness, F(kBase)});
  return {Revolve(profile, kSegments), 950.0};
}

}  // namespace softgrasp::sim::catalogue_internal
