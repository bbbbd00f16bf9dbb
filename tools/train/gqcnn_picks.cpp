#include "tools/train/gqcnn_picks.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "service/cli/args.h"
#include "service/cli/files.h"
#include "service/engine/engine.h"
#include "service/engine/strategies/gqcnn.h"
#include "service/mesh/mesh_io.h"
#include "service/mesh/mesh_prepare.h"
#include "service/models/gqcnn_model.h"
#include "sim/catalogue/catalogue.h"
#include "sim/dataset/scene_gen.h"
#include "sim/grasp/execute.h"
#include "sim/physics/drop.h"
#include "sim/render/render.h"
#include "tools/train/bootstrap.h"
#include "tools/train/cli_common.h"

namespace softgrasp::tools {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

constexpr int kBootstrapResamples = 2000;
constexpr std::uint64_t kBootstrapSeed = 1;
// Dex-Net's object scale (REFERENCE §1.2): the smallest principal extent becomes 4 cm.
constexpr double kRescaleMinExtentM = 0.04;
constexpr double kObjectDensityKgM3 = 500.0;
// Clutter: grasps stay this far inside the bin's inner walls in the image, as in evaluate-tasks
// (every planner closes on the walls' rims otherwise, and the rims are not objects).
constexpr int kBinMarginPx = 3;

constexpr std::string_view kCommand = "gqcnn-picks";

struct Planner {
  std::string name;              // "fge" or "gqcnn:<model file stem>"
  std::string strategy = "fge";  // a registered strategy: "fge" or "gqcnn"
  engine::Models models;
  bool clearance_check = true;  // gqcnn::PolicyParams::check_clearance
  bool contact_check = true;    // gqcnn::PolicyParams::check_contacts
};

// Per planner, one entry per scene: 1 success, 0 failure (no grasp counts as a failure).
struct Outcomes {
  std::vector<double> success;
  /// One record per scene: what was planned and what the simulator said (--records).
  std::vector<json> records;
  std::map<std::string, int> outcomes;
  std::vector<double> detect_ms;
};

struct SceneSet {
  std::string name;
  std::vector<Outcomes> per_planner;
  std::vector<std::string> scene_objects;
};

core::Result<std::shared_ptr<const sim::SimObject>> HeldOutObject(const fs::path& path) {
  auto bytes = cli::ReadFile(path);
  if (!bytes.ok()) return bytes.error();
  auto decoded = mesh::ReadMesh(bytes.value());
  if (!decoded.ok()) return decoded.error();
  mesh::PrepareOptions prepare;
  prepare.rescale_min_extent_m = kRescaleMinExtentM;
  auto prepared = mesh::PrepareMesh(std::move(decoded).value(), prepare);
  if (!prepared.ok()) return prepared.error();
  auto object = sim::MakeMeshObject(std::move(prepared.value().mesh), {}, 1.0F, kObjectDensityKgM3,
                                    "heldout", {{"file", path.filename().string()}});
  if (!object.ok()) return object.error();
  return std::shared_ptr<const sim::SimObject>(
      std::make_shared<sim::SimObject>(std::move(object).value()));
}

void RunScene(const sim::SimScene& scene, const sim::RenderOptions& render,
              const sim::RenderedViews& views, const cv::Mat1b& workspace,
              const std::vector<Planner>& planners, const core::Gripper& gripper, SceneSet* set) {
  auto raycaster = sim::SceneRaycaster::Build(scene);
  for (std::size_t p = 0; p < planners.size(); ++p) {
    Outcomes& out = set->per_planner[p];
    engine::PlanOptions options;
    options.strategy = planners[p].strategy;
    options.gripper = gripper;
    options.fge.top_k = 1;
    if (planners[p].strategy == "gqcnn") {
      auto gqcnn = std::make_shared<engine::GqcnnOptions>();
      gqcnn->policy.seed = scene.seed;
      gqcnn->policy.check_clearance = planners[p].clearance_check;
      gqcnn->policy.check_contacts = planners[p].contact_check;
      options.strategy_options = std::move(gqcnn);
    }
    options.region_of_interest = workspace;
    auto plan = engine::PlanGrasps(views.depth, render.camera, options, planners[p].models);
    out.success.push_back(0.0);
    json& record = out.records.emplace_back(
        json{{"scene", out.success.size() - 1}, {"planner", planners[p].name}});
    const auto outcome = [&](const std::string& name, const std::string& reason) {
      ++out.outcomes[name];
      record["outcome"] = name;
      record["reason"] = reason;
    };
    if (!plan.ok()) {
      outcome("plan_error", plan.error().message);
      continue;
    }
    out.detect_ms.push_back(plan.value().timing.total_ms);
    record["plan_ms"] = plan.value().timing.total_ms;
    if (plan.value().grasps.empty()) {
      outcome("no_grasp", "");
      continue;
    }
    if (!raycaster.ok()) {
      outcome("error", raycaster.error().message);
      continue;
    }
    const core::Grasp& best = plan.value().grasps.front().grasp;
    record["grasp"] = {{"score", Num(best.score)},
                       {"center_px", {best.center_u_px, best.center_v_px}},
                       {"angle_rad", best.angle_rad},
                       {"p_CG_m", best.p_CG_m},
                       {"grasp_height_m", Num(best.grasp_height_m)}};
    auto exec = sim::ExecuteGrasp(scene, raycaster.value(),
                                  sim::SimGraspFromCamera(best, render.world_from_camera), gripper);
    if (!exec.ok()) {
      outcome("error", exec.error().message);
      continue;
    }
    outcome(sim::GraspOutcomeName(exec.value().outcome), exec.value().reason);
    out.success.back() = exec.value().succeeded() ? 1.0 : 0.0;
  }
}

double MeanOf(std::span<const double> values, std::span<const int> sample) {
  double sum = 0;
  for (int i : sample) sum += values[static_cast<std::size_t>(i)];
  return sample.empty() ? std::nan("") : sum / static_cast<double>(sample.size());
}

json Report(const SceneSet& set, const std::vector<Planner>& planners) {
  const int n = static_cast<int>(set.per_planner.front().success.size());
  std::vector<int> all(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
  json rows = json::array();
  const std::vector<double>& fge = set.per_planner.front().success;
  for (std::size_t p = 0; p < planners.size(); ++p) {
    const std::vector<double>& s = set.per_planner[p].success;
    const Interval ci = BootstrapInterval(
        n, [&](std::span<const int> sample) { return MeanOf(s, sample); }, kBootstrapResamples,
        kBootstrapSeed);
    json row = {{"planner", planners[p].name},
                {"scenes", n},
                {"success_rate", Num(MeanOf(s, all))},
                {"success_rate_95", {Num(ci.low), Num(ci.high)}},
                {"outcomes", set.per_planner[p].outcomes}};
    const std::vector<double>& ms = set.per_planner[p].detect_ms;
    if (!ms.empty()) {
      std::vector<double> sorted = ms;
      std::sort(sorted.begin(), sorted.end());
      row["plan_ms_median"] = sorted[sorted.size() / 2];
    }
    if (p > 0) {
      // Paired: the same scenes for both planners.
      const Interval diff = BootstrapInterval(
          n, [&](std::span<const int> sample) { return MeanOf(s, sample) - MeanOf(fge, sample); },
          kBootstrapResamples, kBootstrapSeed);
      row["minus_fge"] = Num(MeanOf(s, all) - MeanOf(fge, all));
      row["minus_fge_95"] = {Num(diff.low), Num(diff.high)};
    }
    rows.push_back(row);
  }
  return {{"scenes", set.name}, {"objects", set.scene_objects}, {"planners", rows}};
}

/// gqcnn-picks' command line.
struct PicksOptions {
  std::vector<std::string> model_paths;
  std::string meshes_dir, out_path, records_path;
  int single_scenes = 0;
  int clutter_scenes = 0;
  long long seed = 0;
  double camera_height_m = 0.70;
  double stroke_mm = core::Gripper{}.opening_stroke_m * 1000.0;
  bool without_clearance_check = false;
  bool without_contact_check = false;
};

core::Result<PicksOptions> ParsePicksOptions(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  PicksOptions o;
  o.model_paths = args.All("--model");
  args.Text("--meshes", &o.meshes_dir);
  o.without_clearance_check = args.Flag("--also-without-clearance-check");
  o.without_contact_check = args.Flag("--also-without-contact-check");
  args.Count("--single-scenes", &o.single_scenes, 10000);
  args.Count("--clutter-scenes", &o.clutter_scenes, 10000);
  args.Int("--seed", 0, cli::kNoLimit, &o.seed);
  args.Number("--camera-height", cli::Bounds::Closed(0.3, 1.5), &o.camera_height_m);
  args.Number("--stroke-mm", cli::Bounds::Closed(20, 150), &o.stroke_mm);
  args.Text("--out", &o.out_path);
  args.Text("--records", &o.records_path);
  if (auto error = args.Finish()) return *error;
  const auto usage = [](const std::string& message) {
    return core::MakeError(core::ErrorCode::kInvalidArgument, message);
  };
  if (o.model_paths.empty()) {
    return usage("--model FILE is required (repeat it to compare models)");
  }
  if (o.single_scenes > 0 && o.meshes_dir.empty()) {
    return usage("--single-scenes needs --meshes DIR (held-out OBJ/PLY/STL files)");
  }
  if (o.single_scenes + o.clutter_scenes == 0) {
    return usage("nothing to do: give --single-scenes N and/or --clutter-scenes N");
  }
  return o;
}

/// Classic FGE, then per --model strategy=gqcnn with that network (and beside it the same
/// network without the contact check and without the clearance check when asked).
core::Result<std::vector<Planner>> LoadPlanners(const PicksOptions& o) {
  std::vector<Planner> planners = {{"fge", "fge", {}}};
  for (const std::string& path : o.model_paths) {
    auto model = models::GqcnnModel::Load(path);
    if (!model.ok()) return model.error();
    Planner p{"gqcnn:" + fs::path(path).stem().string(), "gqcnn", {}};
    p.models.gqcnn = std::make_shared<const models::GqcnnModel>(std::move(model).value());
    planners.push_back(p);
    if (o.without_contact_check) {  // the same network, contacts not checked
      Planner q = p;
      q.name += ":no-contact-check";
      q.contact_check = false;
      planners.push_back(std::move(q));
    }
    if (o.without_clearance_check) {  // the same network, candidates not checked for the clearance
      p.name += ":no-clearance-check";
      p.clearance_check = false;
      planners.push_back(std::move(p));
    }
  }
  return planners;
}

/// The held-out objects of the single-object scenes, one per usable mesh file, by file name.
struct HeldOutObjects {
  std::vector<std::shared_ptr<const sim::SimObject>> objects;
  std::vector<std::string> names;  ///< file stems
};

/// Every OBJ/PLY/STL file of `dir` in name order, prepared as Dex-Net does (HeldOutObject); a
/// file that cannot be is skipped with a note on stderr.
core::Result<HeldOutObjects> LoadHeldOut(const std::string& dir) {
  std::vector<fs::path> files;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string ext = entry.path().extension().string();
    if (ext == ".obj" || ext == ".ply" || ext == ".stl") files.push_back(entry.path());
  }
  if (error) {
    return core::MakeError(core::ErrorCode::kNotFound,
                           "cannot list " + dir + ": " + error.message());
  }
  std::sort(files.begin(), files.end());
  HeldOutObjects heldout;
  for (const fs::path& file : files) {
    auto object = HeldOutObject(file);
    if (!object.ok()) {
      std::cerr << "gqcnn-picks: skipping " << file.string() << ": " << object.error().message
                << "\n";
      continue;
    }
    heldout.objects.push_back(object.value());
    heldout.names.push_back(file.stem().string());
  }
  if (heldout.objects.empty()) {
    return core::MakeError(core::ErrorCode::kInvalidArgument, "no usable mesh in " + dir);
  }
  return heldout;
}

/// The scenes' camera: Primesense-like (640 x 480, fx 525, the datasets'), looking straight down
/// from `camera_height_m`, with the sensor noise.
sim::RenderOptions PickRender(double camera_height_m) {
  sim::RenderOptions render;
  render.camera = core::Camera{};
  render.world_from_camera = sim::OverheadCameraPose(camera_height_m);
  render.noise.enabled = true;
  return render;
}

/// --single-scenes: each held-out object in turn, dropped alone near the camera axis on a table.
core::Result<SceneSet> SingleObjectScenes(const PicksOptions& o, const HeldOutObjects& heldout,
                                          const sim::RenderOptions& render,
                                          const std::vector<Planner>& planners,
                                          const core::Gripper& gripper) {
  SceneSet set{"single_heldout", std::vector<Outcomes>(planners.size()), {}};
  sim::Support table;
  table.kind = sim::Support::Kind::kTable;
  table.inner_size_x_m = 0.10;  // dropped near the camera axis
  table.inner_size_y_m = 0.10;
  for (int i = 0; i < o.single_scenes; ++i) {
    const std::size_t object = static_cast<std::size_t>(i) % heldout.objects.size();
    const std::uint64_t scene_seed =
        sim::SceneSeed(static_cast<std::uint64_t>(o.seed), i, sim::ShapeSplit::kVal);
    auto dropped = sim::DropObjects(table, {heldout.objects[object]}, scene_seed);
    if (!dropped.ok()) {
      return core::MakeError(dropped.error().code,
                             heldout.names[object] + ": " + dropped.error().message);
    }
    sim::SimScene scene = std::move(dropped.value().scene);
    scene.seed = scene_seed;
    auto raycaster = sim::SceneRaycaster::Build(scene);
    if (!raycaster.ok()) return raycaster.error();
    sim::RenderOptions r = render;
    r.noise.seed = scene_seed;
    const sim::RenderedViews views = sim::Render(raycaster.value(), r);
    set.scene_objects.push_back(heldout.names[object]);
    RunScene(scene, r, views, cv::Mat1b(), planners, gripper, &set);
    std::cerr << "\rgqcnn-picks: single " << (i + 1) << "/" << o.single_scenes << std::flush;
  }
  std::cerr << "\n";
  return set;
}

/// --clutter-scenes: validation catalogue objects (3 to 8) in the default bin, grasps inside its
/// walls.
core::Result<SceneSet> ClutterScenes(const PicksOptions& o, const sim::RenderOptions& render,
                                     const std::vector<Planner>& planners,
                                     const core::Gripper& gripper) {
  SceneSet set{"clutter_catalogue_val", std::vector<Outcomes>(planners.size()), {}};
  sim::SceneSpec spec;
  spec.split = sim::ShapeSplit::kVal;
  spec.min_objects = 3;
  spec.max_objects = 8;
  spec.render = render;
  const cv::Mat1b workspace = sim::BinWorkspaceRoi(spec, spec.render.camera, kBinMarginPx);
  for (int i = 0; i < o.clutter_scenes; ++i) {
    const std::uint64_t scene_seed =
        sim::SceneSeed(static_cast<std::uint64_t>(o.seed) + 1000003u, i, sim::ShapeSplit::kVal);
    auto generated = sim::GenerateScene(spec, scene_seed);
    if (!generated.ok()) return generated.error();
    sim::RenderOptions r = render;
    r.noise.seed = scene_seed;
    set.scene_objects.push_back(std::to_string(generated.value().scene.objects.size()) +
                                " objects");
    RunScene(generated.value().scene, r, generated.value().views, workspace, planners, gripper,
             &set);
    std::cerr << "\rgqcnn-picks: clutter " << (i + 1) << "/" << o.clutter_scenes << std::flush;
  }
  std::cerr << "\n";
  return set;
}

/// --records: one JSON line per scene and planner (scene by scene, planner by planner).
void AppendRecords(const SceneSet& set, std::string* records) {
  for (std::size_t scene = 0; scene < set.scene_objects.size(); ++scene) {
    for (const Outcomes& planner : set.per_planner) {
      json r = planner.records[scene];
      r["set"] = set.name;
      r["objects"] = set.scene_objects[scene];
      *records += r.dump() + "\n";
    }
  }
}

}  // namespace

int RunGqcnnPicks(std::vector<std::string> argv) {
  auto options = ParsePicksOptions(std::move(argv));
  if (!options.ok()) return Fail(kCommand, options.error().message);
  const PicksOptions& o = options.value();
  auto planners = LoadPlanners(o);
  if (!planners.ok()) return Fail(kCommand, planners.error().message);
  HeldOutObjects heldout;
  if (o.single_scenes > 0) {
    auto loaded = LoadHeldOut(o.meshes_dir);
    if (!loaded.ok()) return Fail(kCommand, loaded.error().message);
    heldout = std::move(loaded).value();
  }

  core::Gripper gripper;  // the datasets' (a 5 cm stroke) unless --stroke-mm says otherwise
  gripper.opening_stroke_m = o.stroke_mm / 1000.0;
  const sim::RenderOptions render = PickRender(o.camera_height_m);
  json report = {{"models", o.model_paths},
                 {"camera_height_m", o.camera_height_m},
                 {"opening_stroke_m", gripper.opening_stroke_m},
                 {"seed", o.seed},
                 {"bootstrap", {{"resamples", kBootstrapResamples}, {"seed", kBootstrapSeed}}}};
  json sets = json::array();
  std::string records;
  if (o.single_scenes > 0) {
    auto set = SingleObjectScenes(o, heldout, render, planners.value(), gripper);
    if (!set.ok()) return Fail(kCommand, set.error().message);
    sets.push_back(Report(set.value(), planners.value()));
    AppendRecords(set.value(), &records);
  }
  if (o.clutter_scenes > 0) {
    auto set = ClutterScenes(o, render, planners.value(), gripper);
    if (!set.ok()) return Fail(kCommand, set.error().message);
    sets.push_back(Report(set.value(), planners.value()));
    AppendRecords(set.value(), &records);
  }
  report["sets"] = sets;
  if (!o.records_path.empty()) {
    if (auto error = cli::WriteFile(o.records_path, records, cli::Parents::kCreate)) {
      return Fail(kCommand, error->message);
    }
  }
  const std::string text = report.dump(1) + "\n";
  if (o.out_path.empty()) {
    std::cout << text;
  } else if (auto error = cli::WriteFile(o.out_path, text, cli::Parents::kCreate)) {
    return Fail(kCommand, error->message);
  }
  return 0;
}

}  // namespace softgrasp::tools
