#pragma once
/// One simulated scene end to end: draw objects from the catalogue (and optionally fractal
/// meshes), drop them with Bullet, render the views with Embree. Deterministic in
/// (spec, scene_seed). Used by `softgrasp-sim generate` and by anything that needs a scene.

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "service/core/depth.h"
#include "service/core/status.h"
#include "service/mesh/fractal.h"
#include "sim/catalogue/catalogue.h"
#include "sim/physics/drop.h"
#include "sim/render/render.h"
#include "sim/scene/scene.h"

namespace softgrasp::sim {

/// Most objects one scene may hold: dense bins (piles of 15-30 objects that reach the walls).
inline constexpr int kMaxObjectsPerScene = 40;

struct SceneSpec {
  int min_objects =
      3;  ///< objects per scene, drawn uniformly in [min, max]; 1..kMaxObjectsPerScene
  int max_objects = 8;
  ShapeSplit split = ShapeSplit::kTrain;
  Support support;
  /// Categories to draw from (uniformly); empty = every catalogue category.
  std::vector<std::string> categories;
  /// User objects (LoadUserObject) join the draw: each is one more entry beside the categories.
  std::vector<std::shared_ptr<const SimObject>> user_objects;
  /// Probability that an object is a fractal mesh instead of a catalogue item; [0, 1].
  double fractal_probability = 0.0;
  /// Constant stiffness of a fractal object; unset = a level drawn per object from 0.1..1.0.
  std::optional<float> fractal_stiffness;
  double fractal_density_kg_m3 = 500.0;
  mesh::FractalParams fractal;  ///< the seed is replaced per object
  DropOptions drop;
  RenderOptions render;  ///< render.noise.seed is replaced per scene
};

/// Checks ranges; the error names the field ("objects", "fractal_probability", ...).
std::optional<core::Error> ValidateSceneSpec(const SceneSpec& spec);

struct GeneratedScene {
  std::uint64_t scene_seed = 0;
  SimScene scene;  ///< objects at rest (lost objects removed)
  DropReport drop;
  RenderedViews views;
};

/// The seed of scene `index` in a dataset: SplitMix64 of (dataset seed, index, split), so train
/// and val sets made with the same --seed share no scene.
std::uint64_t SceneSeed(std::uint64_t dataset_seed, int index, ShapeSplit split);

/// Builds, settles and renders one scene.
core::Result<GeneratedScene> GenerateScene(const SceneSpec& spec, std::uint64_t scene_seed);

/// An object is "mostly hidden" when less than this fraction of its amodal pixels is visible
/// (e.g. excluded from segmentation metrics like COCO's crowd regions).
inline constexpr double kMostlyHiddenVisibleFraction = 0.10;

/// How much of one object the camera sees, in pixels of the rendered image.
struct ObjectVisibility {
  int instance_id = 0;
  int visible_px = 0;  ///< pixels where the rendered labels show this object
  /// Pixels it covers when rendered alone on the support with the same camera and rays (pixel
  /// centres); always >= visible_px (visible pixels are counted in, guarding against ray ties).
  int amodal_px = 0;
  double visible_fraction = 0;  ///< visible_px / amodal_px in [0, 1]; 0 when amodal_px == 0
  bool mostly_hidden = false;   ///< visible_fraction < kMostlyHiddenVisibleFraction
};

/// Visibility of every object of generated.scene (in the scene's order), generated.views.labels
/// being its labels rendered with `render`'s camera and pose. Each object's amodal mask is ray
/// cast against a scene holding only the support and that object, casting only the pixels
/// inside the projection of the object's vertices. Deterministic. Errors: those of
/// SceneRaycaster::Build; kInvalidArgument when the labels are not camera-sized.
core::Result<std::vector<ObjectVisibility>> MeasureVisibility(const GeneratedScene& generated,
                                                              const RenderOptions& render);

/// The scene's manifest: seed, split, camera (intrinsics and world_from_camera), support,
/// objects (category, shape parameters, mass, pose), noise model, the drop report, and the whole
/// spec ("spec", SceneSpecToJson) so the scene can be rebuilt exactly from the manifest.
nlohmann::json SceneManifest(const SceneSpec& spec, const GeneratedScene& generated);

/// Everything GenerateScene reads from the spec, as JSON (user objects only by count).
nlohmann::json SceneSpecToJson(const SceneSpec& spec);

/// The inverse of SceneSpecToJson. Errors: kInvalidArgument naming the missing or malformed
/// key; kUnprocessable when the spec drew from user objects (their meshes are not in the JSON).
core::Result<SceneSpec> SceneSpecFromJson(const nlohmann::json& json);

/// 255 inside the bin's inner floor area as `cam` sees it from spec.render.world_from_camera
/// (shrunk by `margin_px`): the workspace ROI of a bin-picking cell, given to the planners as
/// their contact region (the walls stay obstacles; FGE alone would grasp their free edges).
cv::Mat1b BinWorkspaceRoi(const SceneSpec& spec, const core::Camera& cam, int margin_px);

}  // namespace softgrasp::sim
