#include "sim/dataset/scene_gen.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <random>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "service/codec/json_codec.h"
#include "service/core/quaternion.h"

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

/// The pixels whose centre rays may hit `placed`: the bounding rectangle of its vertices'
/// projections plus one pixel, clipped to the image (the whole image when a vertex is not in
/// front of the camera; empty when it projects outside). Rays are cast through pixel centres,
/// and the projection of a mesh lies inside the hull of its vertices' projections.
cv::Rect ProjectedBounds(const PlacedObject& placed, const core::Camera& camera,
                         const Eigen::Isometry3d& world_from_camera) {
  const cv::Rect image(0, 0, camera.width, camera.height);
  const Eigen::Isometry3d camera_from_object =
      world_from_camera.inverse() * placed.world_from_object;
  double min_u = std::numeric_limits<double>::infinity(), max_u = -min_u;
  double min_v = min_u, max_v = -min_u;
  for (const auto& vertex : placed.object->mesh_o.vertices) {
    const Eigen::Vector3d c = camera_from_object * Eigen::Vector3d(vertex[0], vertex[1], vertex[2]);
    if (!(c.z() > 1e-6)) return image;
    const double u = camera.fx * c.x() / c.z() + camera.cx;
    const double v = camera.fy * c.y() / c.z() + camera.cy;
    min_u = std::min(min_u, u);
    max_u = std::max(max_u, u);
    min_v = std::min(min_v, v);
    max_v = std::max(max_v, v);
  }
  if (!(min_u <= max_u && min_v <= max_v)) return {};
  // Clamped before the integer conversion so far-off projections cannot overflow.
  const auto to_pixel = [](double x, int size) {
    return static_cast<int>(std::clamp(x, -2.0, static_cast<double>(size) + 1.0));
  };
  const int u0 = std::max(0, to_pixel(std::floor(min_u), camera.width) - 1);
  const int u1 = std::min(camera.width - 1, to_pixel(std::ceil(max_u), camera.width) + 1);
  const int v0 = std::max(0, to_pixel(std::floor(min_v), camera.height) - 1);
  const int v1 = std::min(camera.height - 1, to_pixel(std::ceil(max_v), camera.height) + 1);
  if (u0 > u1 || v0 > v1) return {};
  return {u0, v0, u1 - u0 + 1, v1 - v0 + 1};
}

}  // namespace

std::optional<core::Error> ValidateSceneSpec(const SceneSpec& spec) {
  if (spec.min_objects < 1 || spec.max_objects > kMaxObjectsPerScene ||
      spec.min_objects > spec.max_objects) {
    return MakeError(
        ErrorCode::kInvalidArgument,
        "objects must be MIN-MAX with 1 <= MIN <= MAX <= " + std::to_string(kMaxObjectsPerScene),
        "objects");
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
  const core::Camera& cam = spec.render.camera;
  const bool camera_ok = cam.width >= 1 && cam.width <= 8192 && cam.height >= 1 &&
                         cam.height <= 8192 && std::isfinite(cam.fx) && cam.fx > 0 &&
                         std::isfinite(cam.fy) && cam.fy > 0 && std::isfinite(cam.cx) &&
                         std::isfinite(cam.cy) &&
                         spec.render.world_from_camera.matrix().allFinite();
  if (!camera_ok) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "camera: width and height in 1..8192, fx and fy > 0, finite cx, cy and pose",
                     "camera");
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

core::Result<std::vector<ObjectVisibility>> MeasureVisibility(const GeneratedScene& generated,
                                                              const RenderOptions& render) {
  const core::Camera& camera = render.camera;
  const cv::Mat1w& labels = generated.views.labels;
  if (labels.rows != camera.height || labels.cols != camera.width) {
    return MakeError(ErrorCode::kInvalidArgument, "the labels are not the camera's size", "labels");
  }
  std::vector<int> visible_px(std::numeric_limits<std::uint16_t>::max() + 1, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const std::uint16_t* row = labels[v];
    for (int u = 0; u < labels.cols; ++u) ++visible_px[row[u]];
  }
  const Eigen::Matrix3d world_from_camera_rotation = render.world_from_camera.linear();
  const Eigen::Vector3d origin_w = render.world_from_camera.translation();
  constexpr int kTile = 8;  // as in Render: coherent rays for Embree's streams
  constexpr double kUnbounded = std::numeric_limits<double>::infinity();
  std::array<Eigen::Vector3d, kTile * kTile> rays_w;
  std::array<std::optional<RayHit>, kTile * kTile> hits;

  std::vector<ObjectVisibility> out;
  out.reserve(generated.scene.objects.size());
  for (const PlacedObject& placed : generated.scene.objects) {
    const int id = placed.instance_id;
    SimScene alone;
    alone.seed = generated.scene.seed;
    alone.support = generated.scene.support;
    alone.objects = {placed};
    auto raycaster = SceneRaycaster::Build(alone);
    if (!raycaster.ok()) return raycaster.error();
    ObjectVisibility visibility;
    visibility.instance_id = id;
    visibility.visible_px = id >= 0 && id < static_cast<int>(visible_px.size())
                                ? visible_px[static_cast<std::size_t>(id)]
                                : 0;
    const cv::Rect box = ProjectedBounds(placed, camera, render.world_from_camera);
    int amodal_px = 0, visible_in_box_px = 0;
    for (int tile_v = box.y; tile_v < box.y + box.height; tile_v += kTile) {
      for (int tile_u = box.x; tile_u < box.x + box.width; tile_u += kTile) {
        const int rows = std::min(kTile, box.y + box.height - tile_v);
        const int cols = std::min(kTile, box.x + box.width - tile_u);
        for (int i = 0; i < rows * cols; ++i) {
          const int u = tile_u + i % cols;
          const int v = tile_v + i / cols;
          // The same pixel-centre ray as Render casts.
          const Eigen::Vector3d ray_c((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy,
                                      1.0);
          rays_w[static_cast<std::size_t>(i)] = world_from_camera_rotation * ray_c;
        }
        const auto count = static_cast<std::size_t>(rows * cols);
        raycaster.value().CastMany(origin_w, std::span(rays_w.data(), count), kUnbounded,
                                   std::span(hits.data(), count));
        for (int i = 0; i < rows * cols; ++i) {
          const auto& hit = hits[static_cast<std::size_t>(i)];
          const bool shown = labels(tile_v + i / cols, tile_u + i % cols) == id;
          visible_in_box_px += shown ? 1 : 0;
          amodal_px += (shown || (hit && hit->instance_id == id)) ? 1 : 0;
        }
      }
    }
    // Visible pixels outside the box (none unless the projection bound failed) count too.
    visibility.amodal_px = amodal_px + (visibility.visible_px - visible_in_box_px);
    visibility.visible_fraction =
        visibility.amodal_px > 0 ? static_cast<double>(visibility.visible_px) / visibility.amodal_px
                                 : 0.0;
    visibility.mostly_hidden = visibility.visible_fraction < kMostlyHiddenVisibleFraction;
    out.push_back(visibility);
  }
  return out;
}

namespace {

// The noise model as manifests and specs write it.
json NoiseToJson(const NoiseModel& noise) {
  return {{"enabled", noise.enabled},
          {"grazing_angle_deg", noise.grazing_angle_deg},
          {"edge_jump_m", noise.edge_jump_m},
          {"edge_dropout_probability", noise.edge_dropout_probability},
          {"sigma_base_m", noise.sigma_base_m},
          {"sigma_quadratic_per_m", noise.sigma_quadratic_per_m}};
}

}  // namespace

json SceneManifest(const SceneSpec& spec, const GeneratedScene& generated) {
  json camera = codec::ToJson(spec.render.camera);
  camera["world_from_camera"] = TransformToJson(spec.render.world_from_camera);
  json noise = NoiseToJson(spec.render.noise);
  noise["seed"] = NoiseSeed(generated.scene_seed);
  json objects = json::array();
  for (const PlacedObject& p : generated.scene.objects) objects.push_back(PlacedObjectToJson(p));
  return {
      {"format_version", 1},
      {"scene_seed", generated.scene_seed},
      {"split", ShapeSplitName(spec.split)},
      {"frames", "W: z up, support top at z = 0; C: OpenCV (x right, y down, z forward)"},
      {"camera", camera},
      {"noise", noise},
      {"spec", SceneSpecToJson(spec)},
      {"support", SupportToJson(generated.scene.support)},
      {"objects", objects},
      {"drop",
       {{"steps", generated.drop.steps},
        {"settled", generated.drop.settled},
        {"lost_instance_ids", generated.drop.lost_instance_ids}}},
  };
}

json SceneSpecToJson(const SceneSpec& spec) {
  // The camera's intrinsics and its pose in one object: {fx, ..., position_m, quaternion_xyzw}.
  json camera = codec::ToJson(spec.render.camera);
  camera.update(TransformToJson(spec.render.world_from_camera));
  const mesh::FractalParams& f = spec.fractal;
  return {
      {"objects", {spec.min_objects, spec.max_objects}},
      {"split", ShapeSplitName(spec.split)},
      {"support", SupportToJson(spec.support)},
      {"categories", spec.categories},
      {"user_objects", spec.user_objects.size()},
      {"fractal_probability", spec.fractal_probability},
      {"fractal_stiffness", spec.fractal_stiffness ? json(*spec.fractal_stiffness) : json(nullptr)},
      {"fractal_density_kg_m3", spec.fractal_density_kg_m3},
      {"fractal",
       {{"maps", {f.min_maps, f.max_maps}},
        {"points", f.num_points},
        {"burn_in", f.burn_in},
        {"sigma", f.sigma},
        {"alpha", f.alpha},
        {"gripper_opening_m", f.gripper_opening_m},
        {"fit_fraction", f.fit_fraction},
        {"max_attempts", f.max_attempts},
        {"min_piece_volume_fraction", f.min_piece_volume_fraction},
        {"max_alpha_raises", f.max_alpha_raises},
        {"merge_fraction", f.merge_fraction}}},
      {"drop",
       {{"margin_m", spec.drop.margin_m},
        {"drop_height_min_m", spec.drop.drop_height_min_m},
        {"spawn_gap_m", spec.drop.spawn_gap_m},
        {"time_step_s", spec.drop.time_step_s},
        {"max_steps", spec.drop.max_steps},
        {"friction", spec.drop.friction},
        {"restitution", spec.drop.restitution},
        {"sleep_linear_m_s", spec.drop.sleep_linear_m_s},
        {"sleep_angular_rad_s", spec.drop.sleep_angular_rad_s}}},
      {"camera", camera},
      {"noise", NoiseToJson(spec.render.noise)},
  };
}

core::Result<SceneSpec> SceneSpecFromJson(const json& j) {
  // Reads j[a][b]... into `out`; json's own type errors become a clear kInvalidArgument.
  std::string at;
  try {
    auto get = [&](const json& parent, const char* key, auto* out) {
      at = key;
      *out = parent.at(key).get<std::remove_pointer_t<decltype(out)>>();
    };
    if (j.at("user_objects").get<std::size_t>() > 0) {
      return MakeError(ErrorCode::kUnprocessable,
                       "the scene drew from user meshes, which a manifest does not hold",
                       "user_objects");
    }
    SceneSpec spec;
    std::array<int, 2> objects{};
    get(j, "objects", &objects);
    spec.min_objects = objects[0];
    spec.max_objects = objects[1];
    std::string split;
    get(j, "split", &split);
    if (split != "train" && split != "val")
      throw std::invalid_argument("split must be train or val");
    spec.split = split == "train" ? ShapeSplit::kTrain : ShapeSplit::kVal;
    const json& support = j.at("support");
    std::string kind;
    get(support, "kind", &kind);
    if (kind != "table" && kind != "bin") throw std::invalid_argument("kind must be table or bin");
    spec.support.kind = kind == "table" ? Support::Kind::kTable : Support::Kind::kBin;
    std::array<double, 2> inner{};
    get(support, "inner_size_m", &inner);
    spec.support.inner_size_x_m = inner[0];
    spec.support.inner_size_y_m = inner[1];
    get(support, "wall_height_m", &spec.support.wall_height_m);
    get(support, "wall_thickness_m", &spec.support.wall_thickness_m);
    get(support, "thickness_m", &spec.support.thickness_m);
    get(support, "ground_size_m", &spec.support.ground_size_m);
    get(j, "categories", &spec.categories);
    get(j, "fractal_probability", &spec.fractal_probability);
    at = "fractal_stiffness";
    if (!j.at("fractal_stiffness").is_null())
      spec.fractal_stiffness = j.at("fractal_stiffness").get<float>();
    get(j, "fractal_density_kg_m3", &spec.fractal_density_kg_m3);
    const json& f = j.at("fractal");
    std::array<int, 2> maps{};
    get(f, "maps", &maps);
    spec.fractal.min_maps = maps[0];
    spec.fractal.max_maps = maps[1];
    get(f, "points", &spec.fractal.num_points);
    get(f, "burn_in", &spec.fractal.burn_in);
    get(f, "sigma", &spec.fractal.sigma);
    get(f, "alpha", &spec.fractal.alpha);
    get(f, "gripper_opening_m", &spec.fractal.gripper_opening_m);
    get(f, "fit_fraction", &spec.fractal.fit_fraction);
    get(f, "max_attempts", &spec.fractal.max_attempts);
    get(f, "min_piece_volume_fraction", &spec.fractal.min_piece_volume_fraction);
    get(f, "max_alpha_raises", &spec.fractal.max_alpha_raises);
    get(f, "merge_fraction", &spec.fractal.merge_fraction);
    const json& d = j.at("drop");
    get(d, "margin_m", &spec.drop.margin_m);
    get(d, "drop_height_min_m", &spec.drop.drop_height_min_m);
    get(d, "spawn_gap_m", &spec.drop.spawn_gap_m);
    get(d, "time_step_s", &spec.drop.time_step_s);
    get(d, "max_steps", &spec.drop.max_steps);
    get(d, "friction", &spec.drop.friction);
    get(d, "restitution", &spec.drop.restitution);
    get(d, "sleep_linear_m_s", &spec.drop.sleep_linear_m_s);
    get(d, "sleep_angular_rad_s", &spec.drop.sleep_angular_rad_s);
    const json& c = j.at("camera");
    auto camera = codec::CameraFromJson(c, "camera");
    if (!camera) return camera.error();
    spec.render.camera = camera.value();
    std::array<double, 3> position{};
    std::array<double, 4> xyzw{};
    get(c, "position_m", &position);
    get(c, "quaternion_xyzw", &xyzw);
    const core::QuaternionWxyz wxyz = core::WxyzFromXyzw(xyzw);
    const Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
    if (!(std::abs(q.norm() - 1.0) < 1e-6))
      throw std::invalid_argument("quaternion_xyzw must be a unit quaternion");
    spec.render.world_from_camera = Eigen::Isometry3d::Identity();
    spec.render.world_from_camera.linear() = q.toRotationMatrix();
    spec.render.world_from_camera.translation() =
        Eigen::Vector3d(position[0], position[1], position[2]);
    const json& n = j.at("noise");
    get(n, "enabled", &spec.render.noise.enabled);
    get(n, "grazing_angle_deg", &spec.render.noise.grazing_angle_deg);
    get(n, "edge_jump_m", &spec.render.noise.edge_jump_m);
    get(n, "edge_dropout_probability", &spec.render.noise.edge_dropout_probability);
    get(n, "sigma_base_m", &spec.render.noise.sigma_base_m);
    get(n, "sigma_quadratic_per_m", &spec.render.noise.sigma_quadratic_per_m);
    if (auto invalid = ValidateSceneSpec(spec)) return *invalid;
    return spec;
  } catch (const std::exception& e) {
    return MakeError(ErrorCode::kInvalidArgument, "scene spec: '" + at + "': " + e.what(), at);
  }
}

cv::Mat1b BinWorkspaceRoi(const sim::SceneSpec& spec, const core::Camera& cam, int margin_px) {
  cv::Mat1b roi(cam.height, cam.width, static_cast<unsigned char>(0));
  const Eigen::Isometry3d camera_from_world = spec.render.world_from_camera.inverse();
  std::vector<cv::Point> corners;
  for (const auto& [sx, sy] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    const Eigen::Vector3d p =
        camera_from_world * Eigen::Vector3d(sx * spec.support.inner_size_x_m / 2,
                                            sy * spec.support.inner_size_y_m / 2, 0.0);
    corners.emplace_back(static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx)),
                         static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy)));
  }
  cv::fillConvexPoly(roi, corners, cv::Scalar(255));
  if (margin_px > 0) {
    cv::erode(
        roi, roi,
        cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * margin_px + 1, 2 * margin_px + 1)));
  }
  return roi;
}

}  // namespace softgrasp::sim
