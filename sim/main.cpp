// softgrasp-sim: the simulator's command line: `generate` (datasets of simulated scenes),
// `fractals` (batches of fractal training meshes), `mesh-grasps` (Dex-Net style grasp analyses
// of mesh files), `gqcnn-dataset` (Dex-Net 2.0 style GQ-CNN training data), `robot` (a
// simulated robot on the DDS bus) and `merge-tasks` (the index of a batch made by array tasks).
// Parsing only; the work is in the libraries.
#include <algorithm>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "service/cli/args.h"
#include "service/cli/files.h"
#include "service/cli/progress.h"
#include "service/io/depth_codec.h"
#include "service/process/allocator.h"
#include "sim/catalogue/catalogue.h"
#include "sim/dataset/dataset.h"
#include "sim/dataset/user_objects.h"
#include "sim/fractal_batch.h"
#include "sim/gqcnn/gqcnn_dataset.h"
#include "sim/mesh_grasps_batch.h"
#include "sim/robot/robot_cli.h"
#include "sim/tasks/array_tasks.h"

namespace {

namespace cli = softgrasp::cli;
namespace mesh = softgrasp::mesh;
namespace io = softgrasp::io;
namespace sim = softgrasp::sim;

constexpr const char* kUsage =
    "usage: softgrasp-sim generate --scenes N --seed S --out DIR [--objects MIN-MAX]\n"
    "                              [--split train|val] [--support bin|table] [--noise on|off]\n"
    "                              [--fractals P] [--fractal-stiffness K] [--shard-size N]\n"
    "                              [--categories C[,C...]]\n"
    "                              [--user-mesh PATH[:K|:STIFFNESS.json]]...\n"
    "                              [--camera-height M] [--intrinsics FILE.intr]\n"
    "                              [--task K --tasks N]\n"
    "  Simulated scenes (catalogue objects dropped with Bullet, rendered with Embree): 16-bit\n"
    "  depth (mm), 8-bit stiffness and deformability, 16-bit instance labels and one JSON\n"
    "  manifest per scene, in shards, plus index.json (docs/simulator.md). Defaults: objects\n"
    "  3-8 (at most 40; 15-30 makes dense bins whose piles reach the walls), split train,\n"
    "  support bin, noise on, fractals 0 (probability that an object is a\n"
    "  fractal mesh), fractal stiffness drawn per object unless K (0.1-1) is given,\n"
    "  every catalogue category drawn alike unless --categories lists the ones to draw from\n"
    "  (a name given twice is drawn twice as often: brush piles, sponge-packed bins). Each\n"
    "  --user-mesh (OBJ/PLY/STL in metres; constant stiffness K, default 0.5, or a JSON file\n"
    "  {\"vertex_stiffness\": [...]}) joins the draw beside the catalogue categories. The\n"
    "  camera looks straight down from M metres (default 0.55) with SR305-like intrinsics\n"
    "  (640x480) unless a GQ-CNN style .intr file gives others.\n"
    "\n"
    "usage: softgrasp-sim fractals --count N --seed S --out DIR [--alpha A] [--sigma S]\n"
    "                              [--points P] [--maps MIN-MAX] [--format F]\n"
    "  F: obj (default), ply, ply_ascii, ply_binary, stl, stl_ascii, stl_binary.\n"
    "                              [--task K --tasks N]\n"
    "  Writes fractal_<seed>.<ext> for seeds S..S+N-1 and index.json (docs/fractals.md).\n"
    "\n"
    "  --task K --tasks N (generate, fractals, gqcnn-dataset): make only part K (0-based) of N\n"
    "  of the batch\n"
    "  and a partial index DIR/index.task-K-of-N.json, for array jobs (Slurm: K =\n"
    "  $SLURM_ARRAY_TASK_ID). Every file is the same bytes whatever the split.\n"
    "\n"
    "usage: softgrasp-sim merge-tasks DIR\n"
    "  Merges the N partial indexes of DIR into DIR/index.json, the same bytes as one process\n"
    "  would write; names the tasks whose index is missing (re-run them alone). docs/slurm.md.\n"
    "\n"
    "usage: softgrasp-sim mesh-grasps MESH... --out DIR [--unit m|mm] [--rescale-mm X]\n"
    "                                 [--grasps N] [--robust-samples N] [--seed S]\n"
    "                                 [--friction MU] [--stroke-mm X] [--png]\n"
    "  Stable poses, antipodal grasps with (robust) Ferrari-Canny quality and per-pose\n"
    "  collision checks of each OBJ/PLY/STL file (docs/mesh-grasps.md): DIR/<stem>.json\n"
    "  per mesh (the answer of POST /v1/meshes/grasps), with --png a preview of the most\n"
    "  probable pose, and DIR/index.json. Defaults: unit m, no rescale (Dex-Net: 40), 100\n"
    "  grasps, 25 robust samples, seed 0, friction 0.5, stroke 50 mm. Exit 1 if a file\n"
    "  could not be analysed (the others are written).\n"
    "\n"
    "usage: softgrasp-sim gqcnn-dataset --out DIR [--source fractal|primitive|catalogue|meshes]\n"
    "                                   [--alpha A] [--split train|val] [--meshes DIR]\n"
    "                                   [--unit m|mm] [--objects N] [--seed S]\n"
    "                                   [--images-per-pose K | --images-per-object K]\n"
    "                                   [--metric-threshold T] [--shard-objects N]\n"
    "                                   [--grasps N] [--robust-samples N] [--noise on|off]\n"
    "                                   [--preview N] [--task K --tasks N]\n"
    "  GQ-CNN training data the Dex-Net 2.0 way (docs/gqcnn-dataset.md): per object its\n"
    "  stable poses, grasps and robust labels, depth renders on a table from random cameras\n"
    "  and one 32x32 grasp-aligned crop per aligned grasp, in shards of N objects with\n"
    "  DIR/index.json. Resumes a killed run (same arguments); refuses a folder made with\n"
    "  other ones. Defaults: source fractal, alpha 0.3, split train, 10 objects (meshes: every\n"
    "  file of --meshes DIR), seed 0, 10 images per pose (Dex-Net: 50; --images-per-object\n"
    "  spreads exactly K images over the poses), label threshold 0.0002 on robust\n"
    "  Ferrari-Canny (0.002 = Dex-Net's literal rule; see the doc), 10 objects per\n"
    "  shard, 100 grasps, 25 robust samples, noise on, no preview (N crops of the first\n"
    "  shard as DIR/previews/crops.png). --task K --tasks N: the tasks split the shards; after\n"
    "  merge-tasks the folder is what one process writes.\n";

// --task K --tasks N: both or neither.
void ParseArrayTask(cli::Args& args, sim::ArrayTask* task) {
  const bool has_task = args.Int("--task", 0, 1000000, &task->index);
  const bool has_tasks = args.Int("--tasks", 1, 1000000, &task->count);
  if (has_task != has_tasks) args.Fail("--task K and --tasks N go together", "--task");
}

// Progress bar length: the items of this task (the batch's whole count without --tasks).
int TaskItemCount(const sim::ArrayTask& task, int items) {
  if (!sim::CheckArrayTask(task, items).empty()) return items;
  const sim::ItemRange range = sim::TaskItems(task, items);
  return range.end - range.first;
}

// Returns an error message, or "" when `params` is filled.
std::string ParseGenerateArgs(std::vector<std::string> argv, sim::DatasetParams* params) {
  cli::Args args(std::move(argv));
  params->spec.render.noise.enabled = true;
  if (!args.Int("--scenes", 1, 10000000, &params->scenes)) {
    args.Fail("--scenes N is required", "--scenes");
  }
  std::string out;
  args.Required("--out", "DIR", &out);
  params->out_dir = out;
  args.Int("--seed", 0, cli::kNoLimit, &params->seed);
  args.Span("--objects", 1, sim::kMaxObjectsPerScene, &params->spec.min_objects,
            &params->spec.max_objects);
  args.Choice<sim::ShapeSplit>("--split",
                               {{"train", sim::ShapeSplit::kTrain}, {"val", sim::ShapeSplit::kVal}},
                               &params->spec.split);
  args.Choice<sim::Support::Kind>(
      "--support", {{"bin", sim::Support::Kind::kBin}, {"table", sim::Support::Kind::kTable}},
      &params->spec.support.kind);
  args.Choice<bool>("--noise", {{"on", true}, {"off", false}}, &params->spec.render.noise.enabled);
  args.Number("--fractals", cli::Bounds::Closed(0, 1), &params->spec.fractal_probability);
  std::string categories;
  if (args.Text("--categories", &categories)) {
    const std::vector<std::string>& known = sim::CatalogueCategories();
    for (std::size_t start = 0, end = 0; end != std::string::npos; start = end + 1) {
      end = categories.find(',', start);
      const std::string name = categories.substr(start, end - start);
      if (std::find(known.begin(), known.end(), name) == known.end()) {
        std::string names;
        for (const std::string& k : known) names += (names.empty() ? "" : ", ") + k;
        args.Fail("--categories: unknown category '" + name + "' (known: " + names + ")",
                  "--categories");
        break;
      }
      params->spec.categories.push_back(name);
    }
  }
  float fractal_stiffness = 0;
  if (args.Number("--fractal-stiffness", cli::Bounds::Closed(0.1, 1), &fractal_stiffness)) {
    params->spec.fractal_stiffness = fractal_stiffness;
  }
  double camera_height = 0;
  if (args.Number("--camera-height", cli::Bounds::LeftOpen(0.05, 5), &camera_height)) {
    params->spec.render.world_from_camera = sim::OverheadCameraPose(camera_height);
  }
  args.Int("--shard-size", 1, 100000, &params->shard_size);
  ParseArrayTask(args, &params->task);
  std::string intrinsics;
  args.Text("--intrinsics", &intrinsics);
  const std::vector<std::string> user_meshes = args.All("--user-mesh");
  if (const auto error = args.Finish()) return error->message;

  // The files named on the command line, read once every argument is known to be well-formed.
  if (!intrinsics.empty()) {
    auto text = cli::ReadFile(intrinsics);
    if (!text.ok()) return "--intrinsics: " + text.error().message;
    auto camera = io::ParseIntrinsicsJson(text.value());
    if (!camera.ok()) return "--intrinsics " + intrinsics + ": " + camera.error().message;
    params->spec.render.camera = camera.value();
  }
  for (const std::string& value : user_meshes) {
    auto user = sim::ParseUserObjectArg(value);
    if (!user.ok()) return "--user-mesh " + value + ": " + user.error().message;
    auto object = sim::LoadUserObject(user.value());
    if (!object.ok()) return "--user-mesh " + value + ": " + object.error().message;
    params->spec.user_objects.push_back(
        std::make_shared<const sim::SimObject>(std::move(object).value()));
  }
  return "";
}

int RunGenerate(const std::vector<std::string>& args) {
  sim::DatasetParams params;
  if (const std::string problem = ParseGenerateArgs(args, &params); !problem.empty()) {
    std::cerr << "softgrasp-sim generate: " << problem << "\n" << kUsage;
    return 2;
  }
  cli::ProgressBar bar("scenes", TaskItemCount(params.task, params.scenes));
  auto index = sim::GenerateDataset(params, [&bar](int done) { bar.Update(done); });
  if (!index.ok()) {
    std::cerr << "softgrasp-sim generate: " << index.error().message << "\n";
    return 1;
  }
  std::cout << index.value().string() << "\n";
  return 0;
}

// Returns an error message, or "" when `params` is filled.
std::string ParseFractalsArgs(std::vector<std::string> argv, sim::FractalBatchParams* params) {
  cli::Args args(std::move(argv));
  std::string out;
  args.Required("--out", "DIR", &out);
  params->out_dir = out;
  args.Int("--count", 1, 1000000, &params->count);
  args.Int("--seed", 0, cli::kNoLimit, &params->seed);
  args.Number("--alpha", cli::Bounds::Any(), &params->model.alpha);
  args.Number("--sigma", cli::Bounds::Any(), &params->model.sigma);
  args.Int("--points", 1, 100000000, &params->model.num_points);
  args.Span("--maps", 1, 32, &params->model.min_maps, &params->model.max_maps);
  ParseArrayTask(args, &params->task);
  std::string format;
  if (args.Text("--format", &format)) {
    if (const auto parsed = mesh::MeshFormatFromName(format)) {
      params->format = *parsed;
    } else {
      args.Fail(
          "--format must be one of obj, ply, ply_ascii, ply_binary, stl, stl_ascii, "
          "stl_binary",
          "--format");
    }
  }
  const auto error = args.Finish();
  return error ? error->message : "";
}

int RunFractals(const std::vector<std::string>& args) {
  sim::FractalBatchParams params;
  if (const std::string problem = ParseFractalsArgs(args, &params); !problem.empty()) {
    std::cerr << "softgrasp-sim fractals: " << problem << "\n" << kUsage;
    return 2;
  }
  cli::ProgressBar bar("fractals", TaskItemCount(params.task, params.count));
  auto index = sim::GenerateFractalBatch(params, [&bar](int done) { bar.Update(done); });
  if (!index.ok()) {
    std::cerr << "softgrasp-sim fractals: " << index.error().message << "\n";
    return 1;
  }
  std::cout << index.value().string() << "\n";
  return 0;
}

int RunMergeTasks(const std::vector<std::string>& args) {
  if (args.size() != 1 || args[0].empty() || args[0][0] == '-') {
    std::cerr << "softgrasp-sim merge-tasks: give the batch's folder, and nothing else\n" << kUsage;
    return 2;
  }
  // A gqcnn-dataset's parts say so in their "task" object; its merge also renumbers images.
  bool gqcnn = false;
  if (auto parts = sim::FindTaskIndexes(args[0]); parts.ok()) {
    if (auto text = cli::ReadFile(parts.value().front()); text.ok()) {
      const auto j = nlohmann::json::parse(text.value(), nullptr, false);
      gqcnn = j.is_object() && j.contains("task") && j["task"].is_object() &&
              j["task"].value("kind", "") == "gqcnn-dataset";
    }
  }
  auto index = gqcnn ? sim::MergeGqcnnDatasetTasks(args[0]) : sim::MergeTaskIndexes(args[0]);
  if (!index.ok()) {
    std::cerr << "softgrasp-sim merge-tasks: " << index.error().message << "\n";
    return 1;
  }
  std::cout << index.value().string() << "\n";
  return 0;
}

// Returns an error message, or "" when `params` is filled.
std::string ParseMeshGraspsArgs(std::vector<std::string> argv, sim::MeshGraspBatchParams* params) {
  cli::Args args(std::move(argv));
  std::string out;
  args.Required("--out", "DIR", &out);
  params->out_dir = out;
  mesh::MeshFileJob& job = params->job;
  args.Choice<double>("--unit", {{"m", 1.0}, {"mm", 0.001}}, &job.prepare.unit_scale_m);
  double rescale_mm = 0;
  if (args.Number("--rescale-mm", cli::Bounds::Above(0), &rescale_mm)) {
    job.prepare.rescale_min_extent_m = rescale_mm * 1e-3;
  }
  args.Int("--grasps", 1, 1000, &job.analysis.num_grasps);
  args.Int("--robust-samples", 0, 200, &job.analysis.robust_samples);
  args.Int("--seed", 0, cli::kNoLimit, &job.analysis.seed);
  args.Number("--friction", cli::Bounds::Closed(0, 5), &job.analysis.friction_coefficient);
  double stroke_mm = 0;
  if (args.Number("--stroke-mm", cli::Bounds::LeftOpen(0, 1000), &stroke_mm)) {
    job.analysis.gripper.opening_m = stroke_mm * 1e-3;
  }
  params->png = args.Flag("--png");
  if (!args.ok()) return args.Finish()->message;
  // What is left: the mesh files, and anything else that looks like an option.
  for (const std::string& token : args.remaining()) {
    if (token.rfind("--", 0) == 0) return "unknown argument " + token;
    params->meshes.emplace_back(token);
  }
  if (params->meshes.empty()) return "at least one MESH file is required";
  return "";
}

int RunMeshGrasps(const std::vector<std::string>& args) {
  sim::MeshGraspBatchParams params;
  if (const std::string problem = ParseMeshGraspsArgs(args, &params); !problem.empty()) {
    std::cerr << "softgrasp-sim mesh-grasps: " << problem << "\n" << kUsage;
    return 2;
  }
  cli::ProgressBar bar("meshes", static_cast<int>(params.meshes.size()));
  auto result = sim::AnalyseMeshBatch(params, [&bar](int done) { bar.Update(done); });
  if (!result.ok()) {
    std::cerr << "softgrasp-sim mesh-grasps: " << result.error().message << "\n";
    return 1;
  }
  for (const std::string& failure : result.value().failures) {
    std::cerr << "softgrasp-sim mesh-grasps: " << failure << "\n";
  }
  std::cout << result.value().index.string() << "\n";
  return result.value().failures.empty() ? 0 : 1;
}

// Returns an error message, or "" when `params` is filled.
std::string ParseGqcnnDatasetArgs(std::vector<std::string> argv, sim::GqcnnDatasetParams* params) {
  cli::Args args(std::move(argv));
  std::string out;
  args.Required("--out", "DIR", &out);
  params->out_dir = out;
  args.Choice<sim::GqcnnMeshSource>("--source",
                                    {{"fractal", sim::GqcnnMeshSource::kFractal},
                                     {"primitive", sim::GqcnnMeshSource::kPrimitive},
                                     {"catalogue", sim::GqcnnMeshSource::kCatalogue},
                                     {"meshes", sim::GqcnnMeshSource::kMeshes}},
                                    &params->source);
  const bool fractal = params->source == sim::GqcnnMeshSource::kFractal;
  const bool catalogue = params->source == sim::GqcnnMeshSource::kCatalogue;
  const bool meshes = params->source == sim::GqcnnMeshSource::kMeshes;
  if (args.Number("--alpha", cli::Bounds::LeftOpen(0, 1000), &params->fractal_alpha) && !fractal) {
    args.Fail("--alpha applies to --source fractal only", "--alpha");
  }
  if (args.Choice<std::string>("--split", {{"train", "train"}, {"val", "val"}},
                               &params->catalogue_split) &&
      !catalogue) {
    args.Fail("--split applies to --source catalogue only", "--split");
  }
  std::string meshes_dir;
  if (args.Text("--meshes", &meshes_dir) && !meshes) {
    args.Fail("--meshes DIR needs --source meshes", "--meshes");
  }
  if (args.Choice<double>("--unit", {{"m", 1.0}, {"mm", 0.001}}, &params->mesh_unit_m) && !meshes) {
    args.Fail("--unit applies to --source meshes only", "--unit");
  }
  if (meshes && args.ok() && meshes_dir.empty()) {
    args.Fail("--source meshes needs --meshes DIR (a folder of OBJ/PLY/STL files)", "--meshes");
  }
  params->meshes_dir = meshes_dir;
  params->objects = 0;  // 0 = the default: 10, or every file of the folder
  args.Int("--objects", 1, 10000000, &params->objects);
  args.Int("--seed", 0, cli::kNoLimit, &params->seed);
  args.Int("--images-per-pose", 1, 10000, &params->images_per_pose);
  args.Int("--images-per-object", 1, 100000, &params->images_per_object);
  args.Number("--metric-threshold", cli::Bounds{0, 1, false, true}, &params->metric_threshold);
  args.Int("--shard-objects", 1, 100000, &params->shard_objects);
  ParseArrayTask(args, &params->task);
  args.Int("--grasps", 1, 1000, &params->analysis.num_grasps);
  args.Int("--robust-samples", 1, 200, &params->analysis.robust_samples);
  args.Choice<bool>("--noise", {{"on", true}, {"off", false}}, &params->noise.enabled);
  args.Int("--preview", 0, 1024, &params->preview_crops);
  if (const auto error = args.Finish()) return error->message;
  if (params->objects == 0 && !meshes) params->objects = 10;
  return "";
}

int RunGqcnnDataset(const std::vector<std::string>& args) {
  sim::GqcnnDatasetParams params = sim::DefaultGqcnnDatasetParams();
  if (const std::string problem = ParseGqcnnDatasetArgs(args, &params); !problem.empty()) {
    std::cerr << "softgrasp-sim gqcnn-dataset: " << problem << "\n" << kUsage;
    return 2;
  }
  if (params.objects == 0) {  // --source meshes without --objects: every file
    std::error_code ec;
    int files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(params.meshes_dir, ec)) {
      std::string ext = entry.path().extension().string();
      for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (entry.is_regular_file() && (ext == ".obj" || ext == ".ply" || ext == ".stl")) ++files;
    }
    params.objects = std::max(files, 1);
  }
  std::unique_ptr<cli::ProgressBar> bar;
  auto result = sim::GenerateGqcnnDataset(params, [&bar](int done, int total) {
    if (!bar) bar = std::make_unique<cli::ProgressBar>("objects", total);
    bar->Update(done);
  });
  bar.reset();
  if (!result.ok()) {
    std::cerr << "softgrasp-sim gqcnn-dataset: " << result.error().message << "\n";
    return result.error().code == softgrasp::core::ErrorCode::kInvalidArgument ? 2 : 1;
  }
  const sim::GqcnnDatasetResult& r = result.value();
  for (const std::string& skipped : r.skipped) {
    std::cerr << "softgrasp-sim gqcnn-dataset: skipped " << skipped << "\n";
  }
  const double datapoints = static_cast<double>(r.index.Datapoints());
  const double images = static_cast<double>(r.images_generated);
  std::cout << (params.out_dir / "index.json").string() << "\n"
            << "objects " << r.index.objects.size() << " (skipped " << r.skipped.size()
            << "), images " << r.index.Images() << ", datapoints " << r.index.Datapoints()
            << ", positives " << r.index.Positives() << " ("
            << (datapoints > 0 ? 100.0 * static_cast<double>(r.index.Positives()) / datapoints
                               : 0.0)
            << " %)\n"
            << "shards generated " << r.shards_generated.size() << ", kept " << r.shards_kept.size()
            << "\n";
  if (images > 0) {
    std::cout << "per image: render " << r.timing.render_ms / images << " ms, crops "
              << r.timing.crop_ms / images << " ms; analysis "
              << r.timing.analysis_ms / std::max(1.0, static_cast<double>(r.objects_generated))
              << " ms per object\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    std::cout << kUsage << "\n" << sim::RobotUsage();
    return args.empty() ? 2 : 0;
  }
  softgrasp::process::KeepFreedMemoryForReuse();  // renders, crops and hulls allocate per image
  if (args[0] == "generate") return RunGenerate({args.begin() + 1, args.end()});
  if (args[0] == "fractals") return RunFractals({args.begin() + 1, args.end()});
  if (args[0] == "merge-tasks") return RunMergeTasks({args.begin() + 1, args.end()});
  if (args[0] == "mesh-grasps") return RunMeshGrasps({args.begin() + 1, args.end()});
  if (args[0] == "gqcnn-dataset") return RunGqcnnDataset({args.begin() + 1, args.end()});
  if (args[0] == "robot") return sim::RunRobotCommand({args.begin() + 1, args.end()});
  std::cerr << "softgrasp-sim: unknown command '" << args[0] << "'\n"
            << kUsage << "\n"
            << sim::RobotUsage();
  return 2;
}
