#include "sim/catalogue/catalogue.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <string>

#include "service/mesh/mesh_check.h"
#include "tests/sim/test_scenes.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::sim {
namespace {

constexpr int kSeeds = 20;
constexpr ShapeSplit kSplits[] = {ShapeSplit::kTrain, ShapeSplit::kVal};

SimObject Make(const std::string& category, ShapeSplit split, std::uint64_t seed) {
  core::Result<SimObject> r = MakeCatalogueObject(category, split, seed);
  if (!r.ok()) ADD_FAILURE() << category << " seed " << seed << ": " << r.error().message;
  return std::move(r).value();
}

Eigen::Vector3d Vertex(const SimObject& o, std::size_t i) {
  return Eigen::Vector3d(o.mesh_o.vertices[i][0], o.mesh_o.vertices[i][1], o.mesh_o.vertices[i][2]);
}

// Centroid of the enclosed solid, computed independently of the library (tetrahedra from the
// origin).
Eigen::Vector3d Centroid(const mesh::TriangleMesh& m) {
  double six_volume = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& f : m.faces) {
    Eigen::Vector3d p[3];
    for (int k = 0; k < 3; ++k) {
      const auto& v = m.vertices[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])];
      p[k] = Eigen::Vector3d(v[0], v[1], v[2]);
    }
    const double v6 = p[0].dot(p[1].cross(p[2]));
    six_volume += v6;
    sum += v6 * (p[0] + p[1] + p[2]) / 4.0;
  }
  return sum / six_volume;
}

struct Bounds {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
};

Bounds BoundsOf(const SimObject& o) {
  Bounds b;
  for (std::size_t i = 0; i < o.mesh_o.vertices.size(); ++i) {
    b.lo = b.lo.cwiseMin(Vertex(o, i));
    b.hi = b.hi.cwiseMax(Vertex(o, i));
  }
  return b;
}

bool OnLevel(float s) {
  const float tenths = s * 10.0f;
  return std::abs(tenths - std::round(tenths)) < 1e-4f && s >= 0.1f - 1e-6f && s <= 1.0f + 1e-6f;
}

// Stiffness of the vertices selected by `pick`; fails the test when none is selected.
std::vector<float> ScoresWhere(const SimObject& o,
                               const std::function<bool(const Eigen::Vector3d&)>& pick) {
  std::vector<float> out;
  for (std::size_t i = 0; i < o.mesh_o.vertices.size(); ++i) {
    if (pick(Vertex(o, i))) out.push_back(o.vertex_stiffness[i]);
  }
  EXPECT_FALSE(out.empty()) << o.category << ": no vertex selected";
  return out;
}

float MinOf(const std::vector<float>& v) {
  return v.empty() ? 0.0f : *std::min_element(v.begin(), v.end());
}
float MaxOf(const std::vector<float>& v) {
  return v.empty() ? 1.0f : *std::max_element(v.begin(), v.end());
}

double RadiusXY(const Eigen::Vector3d& p) { return std::hypot(p.x(), p.y()); }

TEST(Catalogue, CategoriesInTheDocumentedOrder) {
  EXPECT_EQ(CatalogueCategories(),
            (std::vector<std::string>{"bottle", "box", "can", "cup", "sponge", "block", "brush"}));
  EXPECT_STREQ(ShapeSplitName(ShapeSplit::kTrain), "train");
  EXPECT_STREQ(ShapeSplitName(ShapeSplit::kVal), "val");
}

TEST(Catalogue, EveryObjectIsAValidSolidCentredOnItsCentreOfMass) {
  for (const std::string& category : CatalogueCategories()) {
    for (const ShapeSplit split : kSplits) {
      for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
        SCOPED_TRACE(category + " " + ShapeSplitName(split) + " seed " + std::to_string(seed));
        const SimObject o = Make(category, split, seed);
        EXPECT_EQ(o.category, category);
        const mesh::MeshReport report = mesh::CheckMesh(o.mesh_o);
        ASSERT_TRUE(report.ok()) << report.problems.front();
        EXPECT_EQ(report.euler_characteristic, 2);  // one closed surface of genus 0
        ASSERT_EQ(o.vertex_stiffness.size(), o.mesh_o.vertices.size());
        for (const float s : o.vertex_stiffness) ASSERT_TRUE(OnLevel(s)) << s;
        EXPECT_LT(Centroid(o.mesh_o).norm(), 1e-9);
        // Mass is the enclosed volume times the documented density.
        const double density = o.shape.at("density_kg_m3").get<double>();
        EXPECT_GT(o.mass_kg, 0.0);
        EXPECT_NEAR(o.mass_kg, report.volume * density, 1e-9 * o.mass_kg);
        EXPECT_LT(o.mass_kg, 1.5);
        // Modest meshes, tabletop sizes.
        EXPECT_GE(o.mesh_o.faces.size(), 12u);
        EXPECT_LE(o.mesh_o.faces.size(), 6000u);
        const Bounds b = BoundsOf(o);
        const Eigen::Vector3d extent = b.hi - b.lo;
        EXPECT_GT(extent.minCoeff(), 0.01);
        EXPECT_LT(extent.maxCoeff(), 0.30);
        EXPECT_EQ(o.shape.at("split"), ShapeSplitName(split));
      }
    }
  }
}

TEST(Catalogue, SameSeedSameBytesOtherSeedOtherShape) {
  for (const std::string& category : CatalogueCategories()) {
    for (const ShapeSplit split : kSplits) {
      std::set<std::string> shapes;
      for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
        const SimObject a = Make(category, split, seed);
        const SimObject b = Make(category, split, seed);
        EXPECT_EQ(a.mesh_o, b.mesh_o) << category;
        EXPECT_EQ(a.vertex_stiffness, b.vertex_stiffness) << category;
        EXPECT_EQ(a.shape, b.shape) << category;
        EXPECT_EQ(a.mass_kg, b.mass_kg) << category;
        shapes.insert(a.shape.dump());
        if (seed > 0) {
          EXPECT_NE(a.mesh_o, Make(category, split, seed - 1).mesh_o) << category << " " << seed;
        }
      }
      EXPECT_EQ(shapes.size(), static_cast<std::size_t>(kSeeds)) << category;
    }
  }
  // The split is part of the stream: the same seed gives other shapes in train and val.
  EXPECT_NE(Make("box", ShapeSplit::kTrain, 3).shape.at("width_m"),
            Make("box", ShapeSplit::kVal, 3).shape.at("width_m"));
}

TEST(Catalogue, ShapeListsParametersInMetres) {
  const SimObject bottle = Make("bottle", ShapeSplit::kTrain, 7);
  for (const char* key : {"body_diameter_m", "height_m", "cap_diameter_m", "cap_height_m",
                          "neck_height_m", "shoulder_height_m", "base_ring_height_m"}) {
    ASSERT_TRUE(bottle.shape.contains(key)) << key;
    EXPECT_GT(bottle.shape[key].get<double>(), 0.0);
    EXPECT_LT(bottle.shape[key].get<double>(), 0.3);
  }
  const Bounds b = BoundsOf(bottle);
  EXPECT_NEAR(b.hi.z() - b.lo.z(), bottle.shape["height_m"].get<double>(), 1e-12);
  EXPECT_NEAR(b.hi.x() - b.lo.x(), bottle.shape["body_diameter_m"].get<double>(), 1e-12);
}

TEST(CatalogueStiffness, BottleCapIsHardAndBodyMiddleSoft) {
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    for (const ShapeSplit split : kSplits) {
      const SimObject o = Make("bottle", split, seed);
      const double z0 = BoundsOf(o).lo.z();
      const double z_cap =
          z0 + o.shape["height_m"].get<double>() - o.shape["cap_height_m"].get<double>();
      EXPECT_GE(MinOf(ScoresWhere(o, [&](const auto& p) { return p.z() >= z_cap - 5e-4; })), 0.9f);
      // The neck just below the cap's sharp border is not the cap, and softer than it.
      EXPECT_LT(
          MaxOf(ScoresWhere(
              o, [&](const auto& p) { return p.z() < z_cap - 5e-4 && p.z() > z_cap - 2e-3; })),
          1.0f);
      const double z_mid = z0 + o.shape["body_mid_height_m"].get<double>();
      const double radius = o.shape["body_diameter_m"].get<double>() / 2;
      const auto middle =
          ScoresWhere(o, [&](const auto& p) { return std::abs(p.z() - z_mid) < 1e-9; });
      EXPECT_LE(MaxOf(middle), 0.5f);
      for (std::size_t i = 0; i < o.mesh_o.vertices.size(); ++i) {
        if (std::abs(Vertex(o, i).z() - z_mid) < 1e-9) {
          EXPECT_NEAR(RadiusXY(Vertex(o, i)), radius, 1e-12);
        }
      }
      // Base ring: the bottom is stiffer than the body.
      EXPECT_GT(MinOf(ScoresWhere(o, [&](const auto& p) { return p.z() < z0 + 1e-9; })),
                MaxOf(middle));
    }
  }
}

TEST(CatalogueStiffness, BoxEdgesStifferThanFaceCentres) {
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    const SimObject o = Make("box", ShapeSplit::kTrain, seed);
    const Bounds b = BoundsOf(o);
    const Eigen::Vector3d c = (b.lo + b.hi) / 2;
    auto at = [&](const Eigen::Vector3d& q) {
      return ScoresWhere(o, [&](const auto& p) { return (p - q).norm() < 1e-9; });
    };
    // Face centres of all six faces are vertices (even subdivisions) and soft.
    for (int axis = 0; axis < 3; ++axis) {
      for (const bool high : {false, true}) {
        Eigen::Vector3d q = c;
        q[axis] = high ? b.hi[axis] : b.lo[axis];
        const auto centre = at(q);
        ASSERT_EQ(centre.size(), 1u);
        EXPECT_LE(centre[0], 0.4f) << "axis " << axis;
        // Middle of an edge of that face: stiffer.
        Eigen::Vector3d e = q;
        const int other = (axis + 1) % 3;
        e[other] = b.hi[other];
        const auto edge = at(e);
        ASSERT_EQ(edge.size(), 1u);
        EXPECT_LT(centre[0], edge[0]);
        EXPECT_GE(edge[0], 0.7f);
      }
    }
    EXPECT_FLOAT_EQ(at(b.hi)[0], 1.0f);  // a corner
    // Along the top face from the +y edge to the centre line, stiffness never rises.
    std::vector<std::pair<double, float>> line;
    for (std::size_t i = 0; i < o.mesh_o.vertices.size(); ++i) {
      const Eigen::Vector3d p = Vertex(o, i);
      if (std::abs(p.x() - c.x()) < 1e-9 && std::abs(p.z() - b.hi.z()) < 1e-9 && p.y() >= c.y()) {
        line.emplace_back(b.hi.y() - p.y(), o.vertex_stiffness[i]);
      }
    }
    std::sort(line.begin(), line.end());
    ASSERT_GE(line.size(), 2u);
    for (std::size_t i = 1; i < line.size(); ++i) EXPECT_LE(line[i].second, line[i - 1].second);
  }
}

TEST(CatalogueStiffness, CanRimsHarderThanWallMiddle) {
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    const SimObject o = Make("can", ShapeSplit::kVal, seed);
    const Bounds b = BoundsOf(o);
    const auto top_rim = ScoresWhere(o, [&](const auto& p) { return p.z() > b.hi.z() - 1e-9; });
    const auto bottom_rim = ScoresWhere(o, [&](const auto& p) { return p.z() < b.lo.z() + 1e-9; });
    const double z_mid = b.lo.z() + o.shape["wall_mid_height_m"].get<double>();
    const auto middle =
        ScoresWhere(o, [&](const auto& p) { return std::abs(p.z() - z_mid) < 1e-9; });
    EXPECT_FLOAT_EQ(MinOf(top_rim), 1.0f);
    EXPECT_FLOAT_EQ(MinOf(bottom_rim), 1.0f);
    EXPECT_LT(MaxOf(middle), MinOf(top_rim));
    EXPECT_GE(MinOf(middle), 0.4f);  // metal: moderately stiff even in the middle
    EXPECT_LE(MaxOf(middle), 0.6f);
    EXPECT_LE(b.hi.x() - b.lo.x(), 0.049 + 1e-12);  // fits the 50 mm gripper opening
  }
}

TEST(CatalogueStiffness, CupRimAndBaseHarderThanWallMiddleAndItHasAWell) {
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    const SimObject o = Make("cup", ShapeSplit::kTrain, seed);
    const Bounds b = BoundsOf(o);
    const auto rim = ScoresWhere(o, [&](const auto& p) { return p.z() > b.hi.z() - 1e-9; });
    const auto base = ScoresWhere(o, [&](const auto& p) { return p.z() < b.lo.z() + 1e-9; });
    const double z_mid = b.lo.z() + o.shape["wall_mid_height_m"].get<double>();
    const auto middle =
        ScoresWhere(o, [&](const auto& p) { return std::abs(p.z() - z_mid) < 1e-9; });
    EXPECT_GT(MinOf(rim), MaxOf(middle));
    EXPECT_GT(MinOf(base), MaxOf(middle));
    // The well: the outer and inner walls both pass through the middle height...
    std::set<long> radii_um;
    for (std::size_t i = 0; i < o.mesh_o.vertices.size(); ++i) {
      if (std::abs(Vertex(o, i).z() - z_mid) < 1e-9) {
        radii_um.insert(std::lround(RadiusXY(Vertex(o, i)) * 1e6));
      }
    }
    EXPECT_EQ(radii_um.size(), 2u);
    // ...and the solid holds far less than the frustum it fills.
    const double h = o.shape["height_m"].get<double>();
    const double r_top = o.shape["top_outer_diameter_m"].get<double>() / 2;
    const double r_base = o.shape["base_outer_diameter_m"].get<double>() / 2;
    const double frustum = M_PI * h / 3 * (r_top * r_top + r_top * r_base + r_base * r_base);
    const double volume = mesh::CheckMesh(o.mesh_o).volume;
    EXPECT_LT(volume, 0.5 * frustum);
  }
}

TEST(CatalogueStiffness, SpongeSoftBlockRigid) {
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    const SimObject sponge = Make("sponge", ShapeSplit::kVal, seed);
    EXPECT_LE(MaxOf(sponge.vertex_stiffness), 0.3f);
    const Bounds b = BoundsOf(sponge);
    EXPECT_FLOAT_EQ(
        MinOf(ScoresWhere(sponge, [&](const auto& p) { return p.z() > b.hi.z() - 1e-9; })),
        0.3f);  // scouring pad
    EXPECT_FLOAT_EQ(
        MaxOf(ScoresWhere(sponge, [&](const auto& p) { return p.z() < b.lo.z() + 1e-9; })),
        0.1f);  // foam
    const SimObject block = Make("block", ShapeSplit::kTrain, seed);
    for (const float s : block.vertex_stiffness) EXPECT_EQ(s, 1.0f);
  }
}

TEST(CatalogueStiffness, BrushHandleHardHeadSoft) {
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    const SimObject o = Make("brush", ShapeSplit::kTrain, seed);
    const double x_head = BoundsOf(o).lo.x() + o.shape["handle_length_m"].get<double>();
    EXPECT_GE(MinOf(ScoresWhere(o, [&](const auto& p) { return p.x() < x_head - 5e-4; })), 0.8f);
    EXPECT_LE(MaxOf(ScoresWhere(o, [&](const auto& p) { return p.x() > x_head - 1e-9; })), 0.3f);
    // The head is the taller part.
    const Bounds b = BoundsOf(o);
    EXPECT_NEAR(b.hi.z() - b.lo.z(), o.shape["head_height_m"].get<double>(), 1e-12);
  }
}

// The documented held-out parameter of each category (docs/sim-catalogue.md): range [lo, hi)
// in five equal bands; val draws from bands 1 and 3, train from 0, 2 and 4.
struct HeldOut {
  const char* category;
  const char* parameter;
  double lo, hi;
};
constexpr HeldOut kHeldOut[] = {
    {"bottle", "body_diameter_m", 0.035, 0.070}, {"box", "length_m", 0.080, 0.200},
    {"can", "height_m", 0.060, 0.135},           {"cup", "height_m", 0.060, 0.110},
    {"sponge", "length_m", 0.070, 0.120},        {"block", "size_x_m", 0.025, 0.050},
    {"brush", "handle_length_m", 0.080, 0.155},
};

TEST(CatalogueSplit, ValidationShapesComeFromHeldOutBands) {
  for (const HeldOut& h : kHeldOut) {
    SCOPED_TRACE(std::string(h.category) + " " + h.parameter);
    const double band = (h.hi - h.lo) / 5;
    for (const ShapeSplit split : kSplits) {
      std::set<int> bands_seen;
      for (std::uint64_t seed = 0; seed < 60; ++seed) {
        const SimObject o = Make(h.category, split, seed);
        const double v = o.shape.at(h.parameter).get<double>();
        ASSERT_GE(v, h.lo);
        ASSERT_LT(v, h.hi);
        // Stay clear of float noise at band edges: a value is in band k when k*band <= v-lo.
        const int k = std::min(4, static_cast<int>((v - h.lo) / band));
        bands_seen.insert(k);
        const bool val_band = k == 1 || k == 3;
        EXPECT_EQ(val_band, split == ShapeSplit::kVal) << v;
      }
      // Every band of the split is used.
      EXPECT_EQ(bands_seen.size(), split == ShapeSplit::kVal ? 2u : 3u);
    }
  }
}

/// A cube of side_m with its lowest corner at lo.
mesh::TriangleMesh Cube(double side_m, const Eigen::Vector3d& lo) {
  const Eigen::Vector3d half = Eigen::Vector3d::Constant(side_m / 2);
  mesh::TriangleMesh m = testing::CentredBoxMesh(half);
  for (auto& v : m.vertices) {
    for (int k = 0; k < 3; ++k) v[k] += lo[k] + half[k];
  }
  return m;
}

void ExpectInvalid(const core::Result<SimObject>& r, const std::string& field) {
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, core::ErrorCode::kInvalidArgument);
  EXPECT_EQ(r.error().field, field);
  EXPECT_FALSE(r.error().message.empty());
}

TEST(CatalogueErrors, UnknownCategory) {
  for (const char* name : {"", "Bottle", "fractal", "bottle "}) {
    const auto r = MakeCatalogueObject(name, ShapeSplit::kTrain, 1);
    ExpectInvalid(r, "category");
    EXPECT_NE(r.error().message.find("bottle, box"), std::string::npos);
  }
}

TEST(MakeMeshObject, RejectsBadMeshesScoresAndDensities) {
  const Eigen::Vector3d lo(0.1, -0.2, 0.3);
  mesh::TriangleMesh open = Cube(0.04, lo);
  open.faces.pop_back();
  open.faces.pop_back();
  ExpectInvalid(MakeMeshObject(open, {}, 0.5f, 500.0), "mesh");
  mesh::TriangleMesh inward = Cube(0.04, lo);
  for (auto& f : inward.faces) std::swap(f[1], f[2]);
  ExpectInvalid(MakeMeshObject(inward, {}, 0.5f, 500.0), "mesh");
  ExpectInvalid(MakeMeshObject({}, {}, 0.5f, 500.0), "mesh");

  const mesh::TriangleMesh cube = Cube(0.04, lo);
  ExpectInvalid(MakeMeshObject(cube, std::vector<float>(7, 0.5f), 0.5f, 500.0), "vertex_stiffness");
  std::vector<float> with_nan(8, 0.5f);
  with_nan[3] = std::nanf("");
  ExpectInvalid(MakeMeshObject(cube, with_nan, 0.5f, 500.0), "vertex_stiffness");
  std::vector<float> with_inf(8, 0.5f);
  with_inf[0] = std::numeric_limits<float>::infinity();
  ExpectInvalid(MakeMeshObject(cube, with_inf, 0.5f, 500.0), "vertex_stiffness");
  ExpectInvalid(MakeMeshObject(cube, {}, 0.05f, 500.0), "stiffness");
  ExpectInvalid(MakeMeshObject(cube, {}, 1.5f, 500.0), "stiffness");
  ExpectInvalid(MakeMeshObject(cube, {}, std::nanf(""), 500.0), "stiffness");
  ExpectInvalid(MakeMeshObject(cube, {}, 0.5f, 0.0), "density_kg_m3");
  ExpectInvalid(MakeMeshObject(cube, {}, 0.5f, -3.0), "density_kg_m3");
  ExpectInvalid(MakeMeshObject(cube, {}, 0.5f, 20001.0), "density_kg_m3");
  ExpectInvalid(MakeMeshObject(cube, {}, 0.5f, std::nan("")), "density_kg_m3");
}

TEST(MakeMeshObject, RecentresACubeAndWeighsIt) {
  const double side = 0.04;
  const Eigen::Vector3d lo(0.1, -0.2, 0.3);
  nlohmann::json shape = {{"source", "test"}};
  const auto r = MakeMeshObject(Cube(side, lo), {}, 0.44f, 650.0, "fractal", shape);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const SimObject& o = r.value();
  EXPECT_EQ(o.category, "fractal");
  EXPECT_EQ(o.shape, shape);
  EXPECT_NEAR(o.mass_kg, side * side * side * 650.0, 1e-12);
  ASSERT_EQ(o.vertex_stiffness.size(), 8u);
  for (const float s : o.vertex_stiffness) EXPECT_FLOAT_EQ(s, 0.4f);  // quantised
  for (const auto& v : o.mesh_o.vertices) {
    for (const double c : v) EXPECT_NEAR(std::abs(c), side / 2, 1e-12);  // centred cube
  }
  EXPECT_TRUE(mesh::CheckMesh(o.mesh_o).ok());
  EXPECT_EQ(o.mesh_o.faces, Cube(side, lo).faces);  // same connectivity, only moved

  // Per-vertex scores are quantised and clamped to the levels.
  const std::vector<float> scores = {0.33f, 0.0f, 5.0f, 0.96f, 0.1f, 0.55f, 0.7f, 1.0f};
  const auto r2 = MakeMeshObject(Cube(side, lo), scores, 0.0f, 650.0);
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_EQ(r2.value().category, "user");
  const std::vector<float> expected = {0.3f, 0.1f, 1.0f, 1.0f, 0.1f, 0.6f, 0.7f, 1.0f};
  for (std::size_t i = 0; i < 8; ++i) {
    EXPECT_FLOAT_EQ(r2.value().vertex_stiffness[i], expected[i]) << i;
  }
}

}  // namespace
}  // namespace softgrasp::sim
