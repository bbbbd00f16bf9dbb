#pragma once
/// pix2stiffness training (pix2pix objective: GAN + lambda * L1) on CPU with libtorch.
/// See docs/stiffness.md, "Training".

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "service/core/status.h"
#include "service/models/network.h"
#include "train/dataset.h"

namespace softgrasp::models {

struct TrainOptions {
  std::filesystem::path out;  ///< model file; OUT.ckpt, OUT_loss.csv, OUT_loss.png beside it
  int steps = 6000;           ///< total optimisation steps (a resumed run stops here too)
  std::uint64_t seed = 1;
  int batch = 4;
  double lambda_l1 = 100.0;  ///< pix2pix default
  /// Object pixels (target > 0) weigh 1 + object_weight in the L1 term, background 1 (the mean
  /// is taken with these weights, so the term stays on the [0, 1] scale). Most pixels are
  /// background; a weight puts the generator's effort where grasps land. 0 = plain pix2pix.
  double object_weight = 0.0;
  double learning_rate = 2e-4;  ///< Adam, betas (0.5, 0.999); linear decay to 0 over the 2nd half
  int checkpoint_every = 250;   ///< steps between checkpoints (and loss plots); >= 1
  bool resume = false;          ///< continue from OUT.ckpt if it exists
  /// Stop after this step (checkpointing it) as if interrupted; 0 = run to `steps`. The learning
  /// rate schedule still spans `steps`, so a later --resume continues the same run.
  int stop_after_step = 0;
  NetworkConfig network;
};

struct LossRecord {
  int step = 0;       ///< 1-based step this record closes
  double d_loss = 0;  ///< discriminator BCE, mean of real and fake
  double g_gan = 0;   ///< generator BCE against "real"
  double g_l1 = 0;    ///< mean |G(x) - y| on [0, 1] (not multiplied by lambda)
};

struct TrainReport {
  int start_step = 0;  ///< 0, or the checkpoint's step when resumed
  int end_step = 0;
  double seconds = 0;
  std::vector<LossRecord> history;  ///< every step from 1 to end_step (including resumed ones)
};

/// Called after every step (for progress bars and logs).
using TrainProgress = std::function<void(const LossRecord& record, int total_steps)>;

/// Trains on `set` (BuildTrainingSet). Deterministic given the seed and thread count: batches,
/// flips and dropout masks are drawn from streams seeded with (seed, step), so a resumed run
/// draws what an uninterrupted one would. Errors: kInvalidArgument for bad options,
/// kUnprocessable for an unreadable or mismatched checkpoint.
core::Result<TrainReport> Train(const TrainOptions& options, const TrainingSet& set,
                                const TrainProgress& progress = {});

std::filesystem::path CheckpointPath(const std::filesystem::path& out);
std::filesystem::path LossCsvPath(const std::filesystem::path& out);
std::filesystem::path LossPngPath(const std::filesystem::path& out);

/// Writes the loss history as CSV (step,d_loss,g_gan,g_l1) and draws it as a PNG (OpenCV):
/// L1 (x lambda) and the GAN losses, smoothed over 1 % of the steps, against the step.
void WriteLossCurve(const std::vector<LossRecord>& history, double lambda_l1,
                    const std::filesystem::path& csv, const std::filesystem::path& png);

}  // namespace softgrasp::models
