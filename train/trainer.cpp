#include "train/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>

#include "service/models/stiffness_model.h"
#include "train/loss_plot.h"
#include "train/seed_mix.h"

namespace softgrasp::models {
namespace {

using core::ErrorCode;
using core::MakeError;

/// The discriminator, both optimisers and the step: everything a resumed run needs.
struct TrainState {
  UNetGenerator generator;
  PatchDiscriminator discriminator;
  torch::optim::Adam opt_g;
  torch::optim::Adam opt_d;

  TrainState(const NetworkConfig& config, double lr)
      : generator(config),
        discriminator(config),
        opt_g(generator->parameters(), torch::optim::AdamOptions(lr).betas({0.5, 0.999})),
        opt_d(discriminator->parameters(), torch::optim::AdamOptions(lr).betas({0.5, 0.999})) {}
};

/// Batch `step` (1-based): indices and flips from a stream of (seed, step).
void MakeBatch(const TrainingSet& set, int batch, std::uint64_t seed, int step, torch::Tensor* x,
               torch::Tensor* y) {
  const int side = set.side;
  *x = torch::empty({batch, 1, side, side}, torch::kFloat32);
  *y = torch::empty({batch, 1, side, side}, torch::kFloat32);
  std::mt19937_64 rng(MixSeed(seed, static_cast<std::uint64_t>(step)));
  std::uniform_int_distribution<int> pick(0, set.size() - 1);
  for (int b = 0; b < batch; ++b) {
    const int i = pick(rng);
    const bool flip_u = (rng() & 1u) != 0;
    const bool flip_v = (rng() & 2u) != 0;
    float* xd = x->data_ptr<float>() + static_cast<std::ptrdiff_t>(b) * side * side;
    float* yd = y->data_ptr<float>() + static_cast<std::ptrdiff_t>(b) * side * side;
    const auto& in = set.inputs[static_cast<std::size_t>(i)];
    const auto& out = set.targets[static_cast<std::size_t>(i)];
    for (int r = 0; r < side; ++r) {
      const int sr = flip_v ? side - 1 - r : r;
      for (int c = 0; c < side; ++c) {
        const int sc = flip_u ? side - 1 - c : c;
        const std::size_t k = static_cast<std::size_t>(sr) * side + sc;
        xd[r * side + c] = in[k] / 32767.0f;
        yd[r * side + c] = out[k] / 255.0f;
      }
    }
  }
}

double LearningRate(const TrainOptions& o, int step) {
  // pix2pix schedule: constant for the first half, then linear decay to 0.
  const double half = o.steps / 2.0;
  if (step <= half) return o.learning_rate;
  return o.learning_rate * std::max(0.0, (o.steps - step + 1) / (o.steps - half + 1));
}

void SetLearningRate(torch::optim::Adam& opt, double lr) {
  for (auto& group : opt.param_groups()) {
    static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
  }
}

torch::Tensor HistoryTensor(const std::vector<LossRecord>& h) {
  auto t = torch::empty({static_cast<std::int64_t>(h.size()), 4}, torch::kFloat64);
  auto a = t.accessor<double, 2>();
  for (std::size_t i = 0; i < h.size(); ++i) {
    const auto k = static_cast<std::int64_t>(i);
    a[k][0] = h[i].step;
    a[k][1] = h[i].d_loss;
    a[k][2] = h[i].g_gan;
    a[k][3] = h[i].g_l1;
  }
  return t;
}

std::vector<LossRecord> HistoryFromTensor(const torch::Tensor& t) {
  std::vector<LossRecord> h;
  if (t.dim() != 2 || t.size(1) != 4) return h;
  auto a = t.accessor<double, 2>();
  for (std::int64_t i = 0; i < t.size(0); ++i) {
    h.push_back({static_cast<int>(a[i][0]), a[i][1], a[i][2], a[i][3]});
  }
  return h;
}

void SaveCheckpoint(const std::filesystem::path& path, TrainState& s, const NetworkConfig& c,
                    int step, const std::vector<LossRecord>& history) {
  torch::serialize::OutputArchive archive;
  archive.write("config",
                torch::tensor({kModelFormatVersion, static_cast<std::int64_t>(c.input_size),
                               static_cast<std::int64_t>(c.base_channels),
                               static_cast<std::int64_t>(c.levels),
                               static_cast<std::int64_t>(c.disc_channels)},
                              torch::kInt64));
  archive.write("step", torch::tensor({static_cast<std::int64_t>(step)}, torch::kInt64));
  archive.write("history", HistoryTensor(history));
  torch::serialize::OutputArchive g, d, og, od;
  s.generator->save(g);
  s.discriminator->save(d);
  s.opt_g.save(og);
  s.opt_d.save(od);
  archive.write("generator", g);
  archive.write("discriminator", d);
  archive.write("opt_g", og);
  archive.write("opt_d", od);
  const std::filesystem::path tmp = path.string() + ".tmp";
  archive.save_to(tmp.string());
  std::filesystem::rename(tmp, path);
}

core::Result<int> LoadCheckpoint(const std::filesystem::path& path, TrainState& s,
                                 const NetworkConfig& c, std::vector<LossRecord>* history) {
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path.string());
    torch::Tensor config;
    torch::Tensor step;
    torch::Tensor hist;
    archive.read("config", config);
    archive.read("step", step);
    archive.read("history", hist);
    const auto v = config.to(torch::kInt64).contiguous();
    const std::int64_t* p = v.data_ptr<std::int64_t>();
    if (v.numel() != 5 || p[0] != kModelFormatVersion || p[1] != c.input_size ||
        p[2] != c.base_channels || p[3] != c.levels || p[4] != c.disc_channels) {
      return MakeError(ErrorCode::kUnprocessable,
                       path.string() + " was written for another network config", "resume");
    }
    torch::serialize::InputArchive g, d, og, od;
    archive.read("generator", g);
    archive.read("discriminator", d);
    archive.read("opt_g", og);
    archive.read("opt_d", od);
    s.generator->load(g);
    s.discriminator->load(d);
    s.opt_g.load(og);
    s.opt_d.load(od);
    *history = HistoryFromTensor(hist);
    return static_cast<int>(step.item<std::int64_t>());
  } catch (const std::exception& e) {
    std::string what = e.what();
    if (const auto nl = what.find('\n'); nl != std::string::npos) what.resize(nl);
    return MakeError(ErrorCode::kUnprocessable, "cannot resume from " + path.string() + ": " + what,
                     "resume");
  }
}

std::optional<core::Error> CheckOptions(const TrainOptions& o, const TrainingSet& set) {
  auto bad = [](const std::string& field, const std::string& why) {
    return MakeError(ErrorCode::kInvalidArgument, field + " " + why, field);
  };
  if (o.out.empty()) return bad("out", "must name a model file");
  if (o.steps < 1) return bad("steps", "must be >= 1");
  if (o.batch < 1 || o.batch > 256) return bad("batch", "must be in 1..256");
  if (o.checkpoint_every < 1) return bad("checkpoint_every", "must be >= 1");
  if (!(o.lambda_l1 >= 0) || !(o.learning_rate > 0)) return bad("lambda", "and lr must be > 0");
  if (!(o.object_weight >= 0) || o.object_weight > 1000) {
    return bad("object_weight", "must be in [0, 1000]");
  }
  if (set.size() < 1) return bad("data", "has no training pairs");
  if (set.side != o.network.input_size) return bad("data", "side differs from the network's");
  if ((o.network.input_size >> o.network.levels) < 2) {
    return bad("levels", "too many for the input size (innermost must be >= 2 px)");
  }
  return std::nullopt;
}

}  // namespace

std::filesystem::path CheckpointPath(const std::filesystem::path& out) {
  return std::filesystem::path(out).replace_extension(".ckpt");
}
std::filesystem::path LossCsvPath(const std::filesystem::path& out) {
  auto p = out;
  return p.replace_filename(out.stem().string() + "_loss.csv");
}
std::filesystem::path LossPngPath(const std::filesystem::path& out) {
  auto p = out;
  return p.replace_filename(out.stem().string() + "_loss.png");
}

core::Result<TrainReport> Train(const TrainOptions& options, const TrainingSet& set,
                                const TrainProgress& progress) {
  if (auto error = CheckOptions(options, set)) return *error;
  const auto t0 = std::chrono::steady_clock::now();
  torch::manual_seed(MixSeed(options.seed, 0));
  TrainState s(options.network, options.learning_rate);
  InitWeights(*s.generator);
  InitWeights(*s.discriminator);

  TrainReport report;
  const std::filesystem::path ckpt = CheckpointPath(options.out);
  if (options.resume && std::filesystem::exists(ckpt)) {
    auto step = LoadCheckpoint(ckpt, s, options.network, &report.history);
    if (!step.ok()) return step.error();
    report.start_step = step.value();
    report.history.resize(
        std::min<std::size_t>(report.history.size(), static_cast<std::size_t>(report.start_step)));
  }
  std::error_code ec;
  if (options.out.has_parent_path())
    std::filesystem::create_directories(options.out.parent_path(), ec);

  s.generator->train();
  s.discriminator->train();
  const double lambda = options.lambda_l1;
  int step = report.start_step;
  const int last_step = options.stop_after_step > 0
                            ? std::min(options.stop_after_step, options.steps)
                            : options.steps;
  while (step < last_step) {
    ++step;
    torch::Tensor x;
    torch::Tensor y;
    MakeBatch(set, options.batch, options.seed, step, &x, &y);
    torch::manual_seed(MixSeed(options.seed, 0x5EED0000ull + static_cast<std::uint64_t>(step)));
    SetLearningRate(s.opt_g, LearningRate(options, step));
    SetLearningRate(s.opt_d, LearningRate(options, step));

    const torch::Tensor fake = s.generator->forward(x);
    // Discriminator: real pairs -> 1, generated pairs -> 0.
    s.opt_d.zero_grad();
    const torch::Tensor real_logits = s.discriminator->forward(x, y);
    const torch::Tensor fake_logits = s.discriminator->forward(x, fake.detach());
    const torch::Tensor d_loss =
        0.5 *
        (torch::binary_cross_entropy_with_logits(real_logits, torch::ones_like(real_logits)) +
         torch::binary_cross_entropy_with_logits(fake_logits, torch::zeros_like(fake_logits)));
    d_loss.backward();
    s.opt_d.step();
    // Generator: fool the discriminator and stay close to the target (L1).
    s.opt_g.zero_grad();
    const torch::Tensor judged = s.discriminator->forward(x, fake);
    const torch::Tensor g_gan =
        torch::binary_cross_entropy_with_logits(judged, torch::ones_like(judged));
    const torch::Tensor g_l1 =
        options.object_weight > 0
            ? [&] {
                const torch::Tensor w = 1.0 + options.object_weight * (y > 0).to(torch::kFloat32);
                return (w * (fake - y).abs()).sum() / w.sum();
              }()
            : torch::l1_loss(fake, y);
    const torch::Tensor g_loss = g_gan + lambda * g_l1;
    g_loss.backward();
    s.opt_g.step();

    LossRecord record{step, d_loss.item<double>(), g_gan.item<double>(), g_l1.item<double>()};
    if (!std::isfinite(record.d_loss) || !std::isfinite(record.g_gan) ||
        !std::isfinite(record.g_l1)) {
      return MakeError(ErrorCode::kInternal,
                       "training diverged at step " + std::to_string(step) + " (non-finite loss)",
                       "steps");
    }
    report.history.push_back(record);
    if (progress) progress(record, options.steps);
    if (step % options.checkpoint_every == 0 || step == last_step) {
      SaveCheckpoint(ckpt, s, options.network, step, report.history);
      s.generator->eval();
      SaveGenerator(options.out, s.generator, options.network, kInputHeightRangeM);
      s.generator->train();
      WriteLossCurve(report.history, lambda, LossCsvPath(options.out), LossPngPath(options.out));
    }
  }
  report.end_step = step;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

void WriteLossCurve(const std::vector<LossRecord>& history, double lambda_l1,
                    const std::filesystem::path& csv, const std::filesystem::path& png) {
  {
    std::ofstream out(csv);
    out << "step,d_loss,g_gan,g_l1\n";
    for (const LossRecord& r : history) {
      out << r.step << ',' << r.d_loss << ',' << r.g_gan << ',' << r.g_l1 << '\n';
    }
  }
  std::vector<int> steps;
  std::vector<LossSeries> series = {
      {"lambda*L1", {200, 60, 20}, {}}, {"G GAN", {30, 30, 220}, {}}, {"D", {40, 160, 40}, {}}};
  for (const LossRecord& r : history) {
    steps.push_back(r.step);
    series[0].values.push_back(lambda_l1 * r.g_l1);
    series[1].values.push_back(r.g_gan);
    series[2].values.push_back(r.d_loss);
  }
  PlotLossCurves("pix2stiffness training losses (smoothed)", steps, series, png);
}

}  // namespace softgrasp::models
