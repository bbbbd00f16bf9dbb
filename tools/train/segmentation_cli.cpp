#include "tools/train/segmentation_cli.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

#include "service/cli/args.h"
#include "service/cli/progress.h"
#include "service/models/segmentation_model.h"
#include "service/models/stiffness_model.h"
#include "tools/train/cli_common.h"
#include "train/dataset.h"
#include "train/segmentation_trainer.h"
#include "train/trainer.h"

namespace softgrasp::tools {

const char* const kSegmentationUsage =
    "       softgrasp-train segmentation --data DIR[,DIR...] --out MODEL [--steps N] [--seed S]\n"
    "                                    [--batch B] [--lr LR] [--resume] [--checkpoint-every N]\n"
    "                                    [--width W] [--height H] [--base-channels C]\n"
    "                                    [--levels L] [--centre-weight W] [--offset-weight W]\n"
    "                                    [--ssim-weight W] [--max-scenes N] [--threads T]\n"
    "                                    [--init MODEL0]\n"
    "  Trains the segmentation U-Net (foreground, centre heatmap, centre offsets,\n"
    "  deformability) on softgrasp-sim datasets. Writes MODEL, MODEL.ckpt (resumable),\n"
    "  MODEL_loss.csv/.png. --init fine-tunes: it starts from MODEL0's weights (same network\n"
    "  size) with a fresh optimiser and learning-rate schedule.\n"
    "       softgrasp-train evaluate-segmentation --model MODEL|none --data DIR[,DIR...]\n"
    "                                    [--scenes N] [--baseline-deformability D] [--threads T]\n"
    "                                    [--foreground-threshold P] [--centre-threshold C]\n"
    "                                    [--peak-window W] [--min-area A]\n"
    "                                    [--max-vote-distance R] [--confident-score S]\n"
    "                                    [--geometry-score S] [--max-covered-fraction F]\n"
    "                                    [--min-model-iou I] [--extend-min-inside-fraction F]\n"
    "  Prints JSON: mask AP (IoU 0.50:0.95), AP50, AP75, AR of the model, the PCL baseline and\n"
    "  the two fused (method=fused, with the precision of the instances the geometry added)\n"
    "  per dataset and over all, per object category, and the deformability map's RMSE (0-255)\n"
    "  and MSSIM against a baseline (PCL masks filled with the constant D, default 0.503 = the\n"
    "  training mean). --foreground-threshold ... --max-vote-distance override the model's\n"
    "  grouping thresholds; the last five override segmentation::FuseParams.\n";

namespace {

// Its messages name no command: "softgrasp-train: MESSAGE".
constexpr std::string_view kCommand = "";

std::vector<std::string> SplitComma(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string part;
  while (std::getline(in, part, ',')) {
    if (!part.empty()) out.push_back(part);
  }
  return out;
}

core::Result<std::vector<models::SceneDataset>> OpenAll(const std::string& dirs) {
  std::vector<models::SceneDataset> out;
  for (const std::string& dir : SplitComma(dirs)) {
    auto d = models::SceneDataset::Open(dir);
    if (!d.ok()) return d.error();
    out.push_back(std::move(d.value()));
  }
  if (out.empty()) return core::MakeError(core::ErrorCode::kInvalidArgument, "no dataset", "data");
  return out;
}

}  // namespace

int RunSegmentationTrain(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  models::SegmentationTrainOptions o;
  std::string data, out;
  int threads = 2, max_scenes = 0;
  args.Required("--data", "DIR", &data);
  args.Required("--out", "MODEL", &out);
  o.out = out;
  args.Int("--steps", 1, 10000000, &o.steps);
  args.Int("--batch", 1, 256, &o.batch);
  args.Int("--checkpoint-every", 1, 10000000, &o.checkpoint_every);
  args.Int("--width", 16, 4096, &o.network.width);
  args.Int("--height", 16, 4096, &o.network.height);
  args.Int("--base-channels", 1, 256, &o.network.base_channels);
  args.Int("--levels", 2, 6, &o.network.levels);
  args.Int("--max-scenes", 1, 10000000, &max_scenes);
  args.Int("--threads", 1, 256, &threads);
  args.Int("--seed", 0, cli::kNoLimit, &o.seed);
  args.Number("--lr", cli::Bounds::Above(0), &o.learning_rate);
  args.Number("--centre-weight", cli::Bounds::AtLeast(0), &o.centre_weight);
  args.Number("--offset-weight", cli::Bounds::AtLeast(0), &o.offset_weight);
  args.Number("--ssim-weight", cli::Bounds::AtLeast(0), &o.ssim_weight);
  o.resume = args.Flag("--resume");
  std::string init;
  if (args.Text("--init", &init)) o.init = init;
  if (const auto error = args.Finish()) return Fail(kCommand, error->message);
  const int div = 1 << o.network.levels;
  if (o.network.width % div != 0 || o.network.height % div != 0) {
    return Fail(kCommand,
                "--width and --height must be multiples of 2^levels = " + std::to_string(div));
  }

  models::SetTorchThreads(threads);
  auto datasets = OpenAll(data);
  if (!datasets.ok()) return FailError(kCommand, datasets.error());
  int total = 0;
  for (const auto& d : datasets.value())
    total += max_scenes > 0 ? std::min(max_scenes, d.size()) : d.size();
  const auto t0 = std::chrono::steady_clock::now();
  auto load_bar = std::make_unique<cli::ProgressBar>("loading", total);
  auto set =
      models::BuildSegmentationSet(datasets.value(), cv::Size(o.network.width, o.network.height),
                                   max_scenes, [&](int done, int) { load_bar->Update(done); });
  load_bar.reset();
  if (!set.ok()) return FailError(kCommand, set.error());
  std::cout << "loaded " << set.value().count() << " scenes (" << set.value().skipped
            << " skipped) in " << SecondsSince(t0) << " s; mean object deformability "
            << set.value().mean_object_deformability << "; threads " << threads << std::endl;

  const bool tty = isatty(STDERR_FILENO) != 0;
  cli::ProgressBar bar("training", o.steps);
  const auto t_train = std::chrono::steady_clock::now();
  int first_step = -1;
  auto report = models::TrainSegmentation(
      o, set.value(), [&](const models::SegmentationLossRecord& r, int steps) {
        if (first_step < 0) first_step = r.step;
        bar.Update(r.step);
        if (!tty && (r.step % 50 == 0 || r.step == steps)) {
          const double s = SecondsSince(t_train);
          const double per_step = s / (r.step - first_step + 1);
          std::printf(
              "step %d/%d  total %.4f  fg %.4f  centre %.5f  offset %.4f  def %.4f  1-ssim %.4f"
              "  %.2f s/step  eta %.0f min\n",
              r.step, steps, r.total, r.foreground, r.centre, r.offset, r.deformability, r.ssim,
              per_step, per_step * (steps - r.step) / 60.0);
          std::fflush(stdout);
        }
      });
  if (!report.ok()) return FailError(kCommand, report.error());
  std::cout << "trained steps " << report.value().start_step << " -> " << report.value().end_step
            << " in " << report.value().seconds << " s; model " << o.out.string() << ", checkpoint "
            << models::CheckpointPath(o.out).string() << ", loss curve "
            << models::LossPngPath(o.out).string() << std::endl;
  return 0;
}

}  // namespace softgrasp::tools
