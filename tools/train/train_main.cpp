// softgrasp-train: trains and evaluates the pix2stiffness model (docs/stiffness.md), the
// segmentation model (docs/segmentation.md) and the GQ-CNN (docs/gqcnn.md).
//   softgrasp-train stiffness --data DIR --out MODEL [--steps N] [--seed S] [--batch B]
//                             [--resume] [--checkpoint-every N] [--lambda L] [--lr LR]
//                             [--object-weight W]
//                             [--base-channels C] [--levels L] [--max-scenes N] [--threads T]
//   softgrasp-train evaluate --model MODEL --data VALDIR [--train-data DIR] [--scenes N]
//                            [--grasp-scenes N] [--compare MODEL2] [--threads T]

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "service/cli/args.h"
#include "service/cli/progress.h"
#include "service/models/stiffness_model.h"
#include "service/process/allocator.h"
#include "tools/train/cli_common.h"
#include "tools/train/evaluate.h"
#include "tools/train/evaluate_tasks.h"
#include "tools/train/gqcnn_cli.h"
#include "tools/train/gqcnn_picks.h"
#include "tools/train/segmentation_cli.h"
#include "train/dataset.h"
#include "train/trainer.h"

namespace {

using softgrasp::tools::Fail;
using softgrasp::tools::FailError;
using softgrasp::tools::SecondsSince;
namespace models = softgrasp::models;
namespace cli = softgrasp::cli;

constexpr const char* kUsage =
    "usage: softgrasp-train stiffness --data DIR --out MODEL [--steps N] [--seed S] [--batch B]\n"
    "                                 [--resume] [--checkpoint-every N] [--lambda L] [--lr LR]\n"
    "                                 [--object-weight W]\n"
    "                                 [--base-channels C] [--disc-channels C] [--levels L]\n"
    "                                 [--max-scenes N] [--threads T]\n"
    "  Trains the pix2stiffness generator (pix2pix: U-Net + PatchGAN, GAN + lambda*L1) on a\n"
    "  softgrasp-sim dataset. Writes MODEL, MODEL.ckpt (resumable), MODEL_loss.csv/.png.\n"
    "       softgrasp-train evaluate --model MODEL --data VALDIR [--train-data DIR]\n"
    "                                [--scenes N] [--grasp-scenes N] [--centre-weight W]\n"
    "                                [--per-grasp] [--compare MODEL2] [--threads T]\n"
    "  Prints JSON: RMSE (0-255) and MSSIM of the model and two baselines, and the grasp\n"
    "  metrics (GT mean stiffness in the grasp region; simulated execution) vs classic FGE,\n"
    "  with 95 % bootstrap intervals. --compare runs a second model's planner on the same\n"
    "  scenes and compares it with the first's (paired).\n"
    "       softgrasp-train evaluate-tasks --segmentation-model MODEL [--stiffness-model MODEL]\n"
    "                                [--tasks clutter,brushes,obstacles] [--clutter-scenes N]\n"
    "                                [--brush-scenes N] [--obstacle-scenes N] [--bins N]\n"
    "                                [--max-attempts N] [--stroke-mm MM] [--openings F,F,..]\n"
    "                                [--per-grasp]\n"
    "                                [--seed S] [--threads T] [--out FILE]\n"
    "  The thesis' three tasks in the simulator (docs/deformability.md): fge, stiffness and\n"
    "  deformability (both target policies) on the same scenes; JSON with 95 % intervals.\n"
    "       softgrasp-train gqcnn-picks --model MODEL [--model MODEL2...] [--meshes DIR]\n"
    "                                [--single-scenes N] [--clutter-scenes N] [--seed S]\n"
    "                                [--camera-height M] [--stroke-mm S]\n"
    "                                [--also-without-clearance-check]\n"
    "                                [--also-without-contact-check] [--out FILE]\n"
    "                                [--records FILE]\n"
    "  Simulated picks (docs/gqcnn.md): strategy=gqcnn with each model against classic FGE on\n"
    "  the same scenes, single held-out objects (--meshes, rescaled as Dex-Net does) on a\n"
    "  table and validation catalogue clutter in a bin; JSON with 95 % paired intervals.\n"
    "  --records writes one JSON line per scene and planner: the grasp executed, the\n"
    "  simulator's outcome and its reason. --stroke-mm sets the gripper's opening stroke for\n"
    "  every planner and the simulator (default 50, the datasets' gripper).\n";

// Its messages name no command: "softgrasp-train: MESSAGE".
constexpr std::string_view kCommand = "";

int RunStiffness(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  models::TrainOptions o;
  std::string data, out;
  int threads = 2;
  int max_scenes = 0;
  args.Required("--data", "DIR", &data);
  args.Required("--out", "MODEL", &out);
  o.out = out;
  args.Int("--steps", 1, 10000000, &o.steps);
  args.Int("--seed", 0, cli::kNoLimit, &o.seed);
  args.Int("--batch", 1, 256, &o.batch);
  args.Int("--checkpoint-every", 1, 10000000, &o.checkpoint_every);
  args.Int("--base-channels", 1, 256, &o.network.base_channels);
  args.Int("--disc-channels", 1, 256, &o.network.disc_channels);
  args.Int("--levels", 2, 7, &o.network.levels);
  args.Int("--max-scenes", 1, 10000000, &max_scenes);
  args.Int("--threads", 1, 256, &threads);
  args.Number("--lambda", cli::Bounds::AtLeast(0), &o.lambda_l1);
  args.Number("--object-weight", cli::Bounds::Closed(0, 1000), &o.object_weight);
  args.Number("--lr", cli::Bounds::Above(0), &o.learning_rate);
  o.resume = args.Flag("--resume");
  if (const auto error = args.Finish()) return Fail(kCommand, error->message + "\n" + kUsage);

  models::SetTorchThreads(threads);
  auto dataset = models::SceneDataset::Open(data);
  if (!dataset.ok()) return FailError(kCommand, dataset.error());
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<cli::ProgressBar> load_bar;
  load_bar = std::make_unique<cli::ProgressBar>(
      "loading",
      max_scenes > 0 ? std::min(max_scenes, dataset.value().size()) : dataset.value().size());
  auto set = models::BuildTrainingSet(dataset.value(), o.network.input_size, max_scenes,
                                      [&](int done, int) { load_bar->Update(done); });
  load_bar.reset();
  if (!set.ok()) return FailError(kCommand, set.error());
  const double load_s = SecondsSince(t0);
  std::cout << "loaded " << set.value().size() << " scenes (" << set.value().skipped
            << " skipped) in " << load_s << " s; mean target " << set.value().mean_target
            << "; threads " << threads << std::endl;

  const bool tty = isatty(STDERR_FILENO) != 0;
  cli::ProgressBar bar("training", o.steps);
  const auto t_train = std::chrono::steady_clock::now();
  int first_step = -1;
  auto report = models::Train(o, set.value(), [&](const models::LossRecord& r, int total) {
    if (first_step < 0) first_step = r.step;
    bar.Update(r.step);
    if (!tty && (r.step % 50 == 0 || r.step == total)) {
      const double s = SecondsSince(t_train);
      const double per_step = s / (r.step - first_step + 1);
      std::printf("step %d/%d  D %.4f  G_gan %.4f  L1 %.4f  %.2f s/step  eta %.0f min\n", r.step,
                  total, r.d_loss, r.g_gan, r.g_l1, per_step, per_step * (total - r.step) / 60.0);
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

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return Fail(kCommand, std::string("missing command\n") + kUsage);
  const std::string command = argv[1];
  softgrasp::process::KeepFreedMemoryForReuse();  // training and evaluation allocate per step
  std::vector<std::string> args(argv + 2, argv + argc);
  if (command == "stiffness") return RunStiffness(std::move(args));
  if (command == "evaluate") return softgrasp::tools::RunEvaluate(std::move(args));
  if (command == "evaluate-tasks") return softgrasp::tools::RunEvaluateTasks(std::move(args));
  if (command == "segmentation") return softgrasp::tools::RunSegmentationTrain(std::move(args));
  if (command == "evaluate-segmentation") {
    return softgrasp::tools::RunSegmentationEvaluate(std::move(args));
  }
  if (command == "gqcnn") return softgrasp::tools::RunGqcnnTrain(std::move(args));
  if (command == "gqcnn-eval") return softgrasp::tools::RunGqcnnEvaluate(std::move(args));
  if (command == "gqcnn-calibrate") return softgrasp::tools::RunGqcnnCalibrate(std::move(args));
  if (command == "gqcnn-bench") return softgrasp::tools::RunGqcnnBench(std::move(args));
  if (command == "gqcnn-picks") return softgrasp::tools::RunGqcnnPicks(std::move(args));
  if (command == "--help" || command == "-h") {
    std::cout << kUsage << softgrasp::tools::kSegmentationUsage << softgrasp::tools::kGqcnnUsage;
    return 0;
  }
  return Fail(kCommand, "unknown command " + command + "\n" + kUsage);
}
