#include "sim/dataset/scene_gen.h"

#include <algorithm>
#include <memory>
#include <random>

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Uniform integer in [lo, hi] and uniform double in [0, 1) from raw 64-bit draws, spelled out so
// the sequence does not depend on a standard library's distribution algorithms.
int DrawInt(std::mt19937_64& rng, int lo, int hi) {
  return lo + static_cast<int>(rng() % static_cast<std::uint64_t>(hi - lo + 1));
}
double DrawUnit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// The sensor-noise stream of a scene, separate from the scene's own draws.
std::uint64_t NoiseSeed(std::uint64_t scene_seed) {
  return SplitMix64(scene_seed ^ 0x6E6F697365ull);
}

core::Result<SimObject> MakeFractalObject(const SceneSpec& spec, std::uint64_t object_seed,
                                          std::mt19937_64& rng) {
  mesh::FractalParams params = spec.fractal;
  params.seed = object_seed;
  auto model = mesh::GenerateFractal(params);
  if (!model.ok()) return model.error();
  const float stiffness = spec.fractal_stiffness ? *spec.fractal_stiffness
                                                 : static_cast<float>(DrawInt(rng, 1, 10)) / 10.0f;
  const mesh::FractalModel& m = model.value();
  const json shape = {{"seed", object_seed},
                      {"maps", m.ifs.maps.size()},
                      {"alpha_used", m.alpha_used},
                      {"bbox_size_m",
                       {m.bbox_max_m[0] - m.bbox_min_m[0], m.bbox_max_m[1] - m.bbox_min_m[1],
                        m.bbox_max_m[2] - m.bbox_min_m[2]}},
                      {"stiffness", stiffness}};
  return MakeMeshObject(m.mesh, {}, stiffness, spec.fractal_density_kg_m3, "fractal", shape);
}

}  // namespace

std::optional<core::Error> ValidateSceneSpec(const SceneSpec& spec) {
  if (spec.min_objects < 1 || spec.max_objects > 8 || spec.min_objects > spec.max_objects) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "objects must be MIN-MAX with 1 <= MIN <= MAX <= 8", "objects");
  }
  if (!(spec.fractal_probability >= 0.0 && spec.fractal_probability <= 1.0)) {
    return MakeError(ErrorCode::kInvalidArgument, "fractal_probability must be in [0, 1]",
                     "fractal_probability");
  }
  if (spec.fractal_stiffness &&
      !(*spec.fractal_stiffness >= kMinStiffness && *spec.fractal_stiffness <= kMaxStiffness)) {
    return MakeError(ErrorCode::kInvalidArgument, "fractal_stiffness must be in [0.1, 1]",
                     "fractal_stiffness");
  }
  if (spec.fractal_probability > 0.0) {
    if (auto invalid = mesh::ValidateFractalParams(spec.fractal)) return invalid;
  }
  for (const auto& user : spec.user_objects) {
    if (!user) return MakeError(ErrorCode::kInvalidArgument, "null user object", "user_objects");
  }
  const auto& known = CatalogueCategories();
  for (const std::string& c : spec.categories) {
    if (std::find(known.begin(), known.end(), c) == known.end()) {
      return MakeError(ErrorCode::kInvalidArgument, "unknown category '" + c + "'", "categories");
    }
  }
  return std::nullopt;
}

std::uint64_t SceneSeed(std::uint64_t dataset_seed, int index, ShapeSplit split) {
  const std::uint64_t split_salt = split == ShapeSplit::kTrain ? 0x7261696Eull : 0x76616Cull;
  return SplitMix64(SplitMix64(dataset_seed ^ (split_salt << 32)) +
                    static_cast<std::uint64_t>(index));
}

core::Result<GeneratedScene> GenerateScene(const SceneSpec& spec, std::uint64_t scene_seed) {
  if (auto invalid = ValidateSceneSpec(spec)) return *invalid;
  std::mt19937_64 rng(scene_seed);
  const std::vector<std::string>& categories =
      spec.categories.empty() ? CatalogueCategories() : spec.categories;

  const int count = DrawInt(rng, spec.min_objects, spec.max_objects);
  std::vector<std::shared_ptr<const SimObject>> objects;
  for (int i = 0; i < count; ++i) {
    const bool fractal = spec.fractal_probability > 0.0 && DrawUnit(rng) < spec.fractal_probability;
    const int pool = static_cast<int>(categories.size() + spec.user_objects.size());
    const auto pick = static_cast<std::size_t>(DrawInt(rng, 0, pool - 1));
    const std::uint64_t object_seed = rng();
    if (!fractal && pick >= categories.size()) {
      objects.push_back(spec.user_objects[pick - categories.size()]);
      continue;
    }
    auto object = fractal ? MakeFractalObject(spec, object_seed, rng)
                          : MakeCatalogueObject(categories[pick], spec.split, object_seed);
    if (!object.ok()) return object.error();
    objects.push_back(std::make_shared<const SimObject>(std::move(object).value()));
  }

  auto dropped = DropObjects(spec.support, objects, rng(), spec.drop);
  if (!dropped.ok()) return dropped.error();

  GeneratedScene out;
  out.scene_seed = scene_seed;
  out.scene = std::move(dropped.value().scene);
  out.scene.seed = scene_seed;
  out.drop = dropped.value().report;

  auto raycaster = SceneRaycaster::Build(out.scene);
  if (!raycaster.ok()) return raycaster.error();
  RenderOptions render = spec.render;
  render.noise.seed = NoiseSeed(scene_seed);
  out.views = Render(raycaster.value(), render);
  return out;
}

json SceneManifest(const SceneSpec& spec, const GeneratedScene& generated) {
  const core::Camera& cam = spec.render.camera;
  const Eigen::Isometry3d& pose = spec.render.world_from_camera;
  const Eigen::Vector3d t = pose.translation();
  const Eigen::Quaterniond q(pose.rotation());
  const NoiseModel& noise = spec.render.noise;
  json objects = json::array();
  for (const PlacedObject& p : generated.scene.objects) objects.push_back(PlacedObjectToJson(p));
  return {
      {"format_version", 1},
      {"scene_seed", generated.scene_seed},
      {"split", ShapeSplitName(spec.split)},
      {"frames", "W: z up, support top at z = 0; C: OpenCV (x right, y down, z forward)"},
      {"camera",
       {{"fx", cam.fx},
        {"fy", cam.fy},
        {"cx", cam.cx},
        {"cy", cam.cy},
        {"width", cam.width},
        {"height", cam.height},
        {"world_from_camera",
         {{"position_m", {t.x(), t.y(), t.z()}},
          {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}}}}},
      {"noise",
       {{"enabled", noise.enabled},
        {"seed", NoiseSeed(generated.scene_seed)},
        {"grazing_angle_deg", noise.grazing_angle_deg},
        {"edge_jump_m", noise.edge_jump_m},
        {"edge_dropout_probability", noise.edge_dropout_probability},
        {"sigma_base_m", noise.sigma_base_m},
        {"sigma_quadratic_per_m", noise.sigma_quadratic_per_m}}},
      {"support", SupportToJson(generated.scene.support)},
      {"objects", objects},
      {"drop",
       {{"steps", generated.drop.steps},
        {"settled", generated.drop.settled},
        {"lost_instance_ids", generated.drop.lost_instance_ids}}},
  };
}

}  // namespace softgrasp::sim
