// softgrasp-train: trains and evaluates the pix2stiffness model (docs/stiffness.md).
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

#include "service/models/dataset.h"
#include "service/models/stiffness_model.h"
#include "service/models/trainer.h"
#include "sim/progress.h"
#include "tools/train/args.h"
#include "tools/train/evaluate.h"
#include "tools/train/evaluate_tasks.h"
#include "tools/train/segmentation_cli.h"

namespace {

using softgrasp::core::Error;
namespace models = softgrasp::models;
using softgrasp::tools::Args;
using softgrasp::tools::ParseDouble;
using softgrasp::tools::ParseInt;

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
    "  deformability (both target policies) on the same scenes; JSON with 95 % intervals.\n";

int Fail(const std::string& message) {
  std::cerr << "softgrasp-train: " << message << "\n";
  return 2;
}

int FailError(const Error& e) {
  return Fail(e.message + (e.field.empty() ? "" : " [" + e.field + "]"));
}

int RunStiffness(Args args) {
  models::TrainOptions o;
  std::string data, out, value;
  long long n = 0;
  int threads = 2;
  int max_scenes = 0;
  if (!args.Take("--data", &data)) return Fail("--data DIR is required\n" + std::string(kUsage));
  if (!args.Take("--out", &out)) return Fail("--out MODEL is required\n" + std::string(kUsage));
  o.out = out;
  if (args.Take("--steps", &value)) {
    if (!ParseInt(value, 1, 10000000, &n)) return Fail("--steps must be an integer >= 1");
    o.steps = static_cast<int>(n);
  }
  if (args.Take("--seed", &value)) {
    if (!ParseInt(value, 0, (1ll << 62), &n)) return Fail("--seed must be an integer >= 0");
    o.seed = static_cast<std::uint64_t>(n);
  }
  if (args.Take("--batch", &value)) {
    if (!ParseInt(value, 1, 256, &n)) return Fail("--batch must be in 1..256");
    o.batch = static_cast<int>(n);
  }
  if (args.Take("--checkpoint-every", &value)) {
    if (!ParseInt(value, 1, 10000000, &n)) return Fail("--checkpoint-every must be >= 1");
    o.checkpoint_every = static_cast<int>(n);
  }
  if (args.Take("--base-channels", &value)) {
    if (!ParseInt(value, 1, 256, &n)) return Fail("--base-channels must be in 1..256");
    o.network.base_channels = static_cast<int>(n);
  }
  if (args.Take("--disc-channels", &value)) {
    if (!ParseInt(value, 1, 256, &n)) return Fail("--disc-channels must be in 1..256");
    o.network.disc_channels = static_cast<int>(n);
  }
  if (args.Take("--levels", &value)) {
    if (!ParseInt(value, 2, 7, &n)) return Fail("--levels must be in 2..7");
    o.network.levels = static_cast<int>(n);
  }
  if (args.Take("--max-scenes", &value)) {
    if (!ParseInt(value, 1, 10000000, &n)) return Fail("--max-scenes must be >= 1");
    max_scenes = static_cast<int>(n);
  }
  if (args.Take("--threads", &value)) {
    if (!ParseInt(value, 1, 256, &n)) return Fail("--threads must be in 1..256");
    threads = static_cast<int>(n);
  }
  if (args.Take("--lambda", &value) && (!ParseDouble(value, &o.lambda_l1) || o.lambda_l1 < 0)) {
    return Fail("--lambda must be a number >= 0");
  }
  if (args.Take("--object-weight", &value) &&
      (!ParseDouble(value, &o.object_weight) || o.object_weight < 0 || o.object_weight > 1000)) {
    return Fail("--object-weight must be a number in [0, 1000]");
  }
  if (args.Take("--lr", &value) &&
      (!ParseDouble(value, &o.learning_rate) || o.learning_rate <= 0)) {
    return Fail("--lr must be a number > 0");
  }
  o.resume = args.Flag("--resume");
  if (!args.rest.empty()) return Fail("unknown argument " + args.rest.front() + "\n" + kUsage);

  models::SetTorchThreads(threads);
  auto dataset = models::SceneDataset::Open(data);
  if (!dataset.ok()) return FailError(dataset.error());
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<softgrasp::sim::ProgressBar> load_bar;
  load_bar = std::make_unique<softgrasp::sim::ProgressBar>(
      "loading",
      max_scenes > 0 ? std::min(max_scenes, dataset.value().size()) : dataset.value().size());
  auto set = models::BuildTrainingSet(dataset.value(), o.network.input_size, max_scenes,
                                      [&](int done, int) { load_bar->Update(done); });
  load_bar.reset();
  if (!set.ok()) return FailError(set.error());
  const double load_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "loaded " << set.value().size() << " scenes (" << set.value().skipped
            << " skipped) in " << load_s << " s; mean target " << set.value().mean_target
            << "; threads " << threads << std::endl;

  const bool tty = isatty(STDERR_FILENO) != 0;
  softgrasp::sim::ProgressBar bar("training", o.steps);
  const auto t_train = std::chrono::steady_clock::now();
  int first_step = -1;
  auto report = models::Train(o, set.value(), [&](const models::LossRecord& r, int total) {
    if (first_step < 0) first_step = r.step;
    bar.Update(r.step);
    if (!tty && (r.step % 50 == 0 || r.step == total)) {
      const double s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_train).count();
      const double per_step = s / (r.step - first_step + 1);
      std::printf("step %d/%d  D %.4f  G_gan %.4f  L1 %.4f  %.2f s/step  eta %.0f min\n", r.step,
                  total, r.d_loss, r.g_gan, r.g_l1, per_step, per_step * (total - r.step) / 60.0);
      std::fflush(stdout);
    }
  });
  if (!report.ok()) return FailError(report.error());
  std::cout << "trained steps " << report.value().start_step << " -> " << report.value().end_step
            << " in " << report.value().seconds << " s; model " << o.out.string() << ", checkpoint "
            << models::CheckpointPath(o.out).string() << ", loss curve "
            << models::LossPngPath(o.out).string() << std::endl;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return Fail(std::string("missing command\n") + kUsage);
  const std::string command = argv[1];
  Args args;
  for (int i = 2; i < argc; ++i) args.rest.emplace_back(argv[i]);
  if (command == "stiffness") return RunStiffness(std::move(args));
  if (command == "evaluate") return softgrasp::tools::RunEvaluate(args.rest);
  if (command == "evaluate-tasks") return softgrasp::tools::RunEvaluateTasks(args.rest);
  if (command == "segmentation") return softgrasp::tools::RunSegmentationTrain(args.rest);
  if (command == "evaluate-segmentation") {
    return softgrasp::tools::RunSegmentationEvaluate(args.rest);
  }
  if (command == "--help" || command == "-h") {
    std::cout << kUsage << softgrasp::tools::kSegmentationUsage;
    return 0;
  }
  return Fail("unknown command " + command + "\n" + kUsage);
}
