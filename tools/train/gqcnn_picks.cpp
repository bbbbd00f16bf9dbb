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

}  // namespace

int RunGqcnnPicks(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  const std::vector<std::string> model_paths = args.All("--model");
  std::string meshes_dir;
  args.Text("--meshes", &meshes_dir);
  int single_scenes = 0;
  int clutter_scenes = 0;
  long long seed = 0;
  double camera_height_m = 0.70;
  double stroke_mm = core::Gripper{}.opening_stroke_m * 1000.0;
  std::string out_path;
  std::string records_path;
  const bool without_clearance_check = args.Flag("--also-without-clearance-check");
  const bool without_contact_check = args.Flag("--also-without-contact-check");
  args.Count("--single-scenes", &single_scenes, 10000);
  args.Count("--clutter-scenes", &clutter_scenes, 10000);
  args.Int("--seed", 0, cli::kNoLimit, &seed);
  args.Number("--camera-height", cli::Bounds::Closed(0.3, 1.5), &camera_height_m);
  args.Number("--stroke-mm", cli::Bounds::Closed(20, 150), &stroke_mm);
  args.Text("--out", &out_path);
  args.Text("--records", &records_path);
  if (auto error = args.Finish()) return Fail(kCommand, error->message);
  if (model_paths.empty()) {
    return Fail(kCommand, "--model FILE is required (repeat it to compare models)");
  }
  if (single_scenes > 0 && meshes_dir.empty()) {
    return Fail(kCommand, "--single-scenes needs --meshes DIR (held-out OBJ/PLY/STL files)");
  }
  if (single_scenes + clutter_scenes == 0) {
    return Fail(kCommand, "nothing to do: give --single-scenes N and/or --clutter-scenes N");
  }

  std::vector<Planner> planners = {{"fge", "fge", {}}};
  for (const std::string& path : model_paths) {
    auto model = models::GqcnnModel::Load(path);
    if (!model.ok()) return Fail(kCommand, model.error().message);
    Planner p{"gqcnn:" + fs::path(path).stem().string(), "gqcnn", {}};
    p.models.gqcnn = std::make_shared<const models::GqcnnModel>(std::move(model).value());
    planners.push_back(p);
    if (without_contact_check) {  // the same network, contacts not checked
      Planner q = p;
      q.name += ":no-contact-check";
      q.contact_check = false;
      planners.push_back(std::move(q));
    }
    if (without_clearance_check) {  // the same network, candidates not checked for the clearance
      p.name += ":no-clearance-check";
      p.clearance_check = false;
      planners.push_back(std::move(p));
    }
  }

  std::vector<std::shared_ptr<const sim::SimObject>> heldout;
  std::vector<std::string> heldout_names;
  if (single_scenes > 0) {
    std::vector<fs::path> files;
    std::error_code error;
    for (const auto& entry : fs::directory_iterator(meshes_dir, error)) {
      const std::string ext = entry.path().extension().string();
      if (ext == ".obj" || ext == ".ply" || ext == ".stl") files.push_back(entry.path());
    }
    if (error) return Fail(kCommand, "cannot list " + meshes_dir + ": " + error.message());
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
      auto object = HeldOutObject(file);
      if (!object.ok()) {
        std::cerr << "gqcnn-picks: skipping " << file.string() << ": " << object.error().message
                  << "\n";
        continue;
      }
      heldout.push_back(object.value());
      heldout_names.push_back(file.stem().string());
    }
    if (heldout.empty()) return Fail(kCommand, "no usable mesh in " + meshes_dir);
  }

  core::Gripper gripper;  // the datasets' (a 5 cm stroke) unless --stroke-mm says otherwise
  gripper.opening_stroke_m = stroke_mm / 1000.0;
  sim::RenderOptions render;
  render.camera = core::Camera{};  // Primesense-like 640 x 480, fx 525 (the dataset's)
  render.world_from_camera = sim::OverheadCameraPose(camera_height_m);
  render.noise.enabled = true;

  json report = {{"models", model_paths},
                 {"camera_height_m", camera_height_m},
                 {"opening_stroke_m", gripper.opening_stroke_m},
                 {"seed", seed},
                 {"bootstrap", {{"resamples", kBootstrapResamples}, {"seed", kBootstrapSeed}}}};
  json sets = json::array();
  std::string records;  // JSON lines, scene by scene, planner by planner
  const auto add_records = [&](const SceneSet& set) {
    for (std::size_t scene = 0; scene < set.scene_objects.size(); ++scene) {
      for (const Outcomes& planner : set.per_planner) {
        json r = planner.records[scene];
        r["set"] = set.name;
        r["objects"] = set.scene_objects[scene];
        records += r.dump() + "\n";
      }
    }
  };
  if (single_scenes > 0) {
    SceneSet set{"single_heldout", std::vector<Outcomes>(planners.size()), {}};
    sim::Support table;
    table.kind = sim::Support::Kind::kTable;
    table.inner_size_x_m = 0.10;  // dropped near the camera axis
    table.inner_size_y_m = 0.10;
    for (int i = 0; i < single_scenes; ++i) {
      const std::size_t object = static_cast<std::size_t>(i) % heldout.size();
      const std::uint64_t scene_seed =
          sim::SceneSeed(static_cast<std::uint64_t>(seed), i, sim::ShapeSplit::kVal);
      auto dropped = sim::DropObjects(table, {heldout[object]}, scene_seed);
      if (!dropped.ok()) {
        return Fail(kCommand, heldout_names[object] + ": " + dropped.error().message);
      }
      sim::SimScene scene = std::move(dropped.value().scene);
      scene.seed = scene_seed;
      auto raycaster = sim::SceneRaycaster::Build(scene);
      if (!raycaster.ok()) return Fail(kCommand, raycaster.error().message);
      sim::RenderOptions r = render;
      r.noise.seed = scene_seed;
      const sim::RenderedViews views = sim::Render(raycaster.value(), r);
      set.scene_objects.push_back(heldout_names[object]);
      RunScene(scene, r, views, cv::Mat1b(), planners, gripper, &set);
      std::cerr << "\rgqcnn-picks: single " << (i + 1) << "/" << single_scenes << std::flush;
    }
    std::cerr << "\n";
    sets.push_back(Report(set, planners));
    add_records(set);
  }
  if (clutter_scenes > 0) {
    SceneSet set{"clutter_catalogue_val", std::vector<Outcomes>(planners.size()), {}};
    sim::SceneSpec spec;
    spec.split = sim::ShapeSplit::kVal;
    spec.min_objects = 3;
    spec.max_objects = 8;
    spec.render = render;
    const cv::Mat1b workspace = sim::BinWorkspaceRoi(spec, spec.render.camera, kBinMarginPx);
    for (int i = 0; i < clutter_scenes; ++i) {
      const std::uint64_t scene_seed =
          sim::SceneSeed(static_cast<std::uint64_t>(seed) + 1000003u, i, sim::ShapeSplit::kVal);
      auto generated = sim::GenerateScene(spec, scene_seed);
      if (!generated.ok()) return Fail(kCommand, generated.error().message);
      sim::RenderOptions r = render;
      r.noise.seed = scene_seed;
      set.scene_objects.push_back(std::to_string(generated.value().scene.objects.size()) +
                                  " objects");
      RunScene(generated.value().scene, r, generated.value().views, workspace, planners, gripper,
               &set);
      std::cerr << "\rgqcnn-picks: clutter " << (i + 1) << "/" << clutter_scenes << std::flush;
    }
    std::cerr << "\n";
    sets.push_back(Report(set, planners));
    add_records(set);
  }
  report["sets"] = sets;
  if (!records_path.empty()) {
    if (auto error = cli::WriteFile(records_path, records, cli::Parents::kCreate)) {
      return Fail(kCommand, error->message);
    }
  }
  const std::string text = report.dump(1) + "\n";
  if (out_path.empty()) {
    std::cout << text;
  } else if (auto error = cli::WriteFile(out_path, text, cli::Parents::kCreate)) {
    return Fail(kCommand, error->message);
  }
  return 0;
}

}  // namespace softgrasp::tools
