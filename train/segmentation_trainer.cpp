#include "train/segmentation_trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>

#include "service/core/preprocess.h"
#include "service/models/network.h"
#include "service/models/stiffness_model.h"
#include "train/loss_plot.h"
#include "train/seed_mix.h"
#include "train/trainer.h"

namespace softgrasp::models {
namespace {

using core::ErrorCode;
using core::MakeError;

struct State {
  SegmentationNet net;
  torch::optim::Adam opt;
  State(const SegmentationNetConfig& c, double lr)
      : net(c), opt(net->parameters(), torch::optim::AdamOptions(lr)) {}
};

torch::Tensor ConfigTensor(const SegmentationNetConfig& c) {
  return torch::tensor(
      {kSegmentationFormatVersion, static_cast<std::int64_t>(c.width),
       static_cast<std::int64_t>(c.height), static_cast<std::int64_t>(c.base_channels),
       static_cast<std::int64_t>(c.levels)},
      torch::kInt64);
}

constexpr int kHistoryColumns = 7;

torch::Tensor HistoryTensor(const std::vector<SegmentationLossRecord>& h) {
  auto t = torch::empty({static_cast<std::int64_t>(h.size()), kHistoryColumns}, torch::kFloat64);
  auto a = t.accessor<double, 2>();
  for (std::size_t i = 0; i < h.size(); ++i) {
    const auto k = static_cast<std::int64_t>(i);
    a[k][0] = h[i].step;
    a[k][1] = h[i].total;
    a[k][2] = h[i].foreground;
    a[k][3] = h[i].centre;
    a[k][4] = h[i].offset;
    a[k][5] = h[i].deformability;
    a[k][6] = h[i].ssim;
  }
  return t;
}

std::vector<SegmentationLossRecord> HistoryFromTensor(const torch::Tensor& t) {
  std::vector<SegmentationLossRecord> h;
  if (t.dim() != 2 || t.size(1) != kHistoryColumns) return h;
  auto a = t.accessor<double, 2>();
  for (std::int64_t i = 0; i < t.size(0); ++i) {
    h.push_back({static_cast<int>(a[i][0]), a[i][1], a[i][2], a[i][3], a[i][4], a[i][5], a[i][6]});
  }
  return h;
}

void SaveCheckpoint(const std::filesystem::path& path, State& s, const SegmentationNetConfig& c,
                    int step, const std::vector<SegmentationLossRecord>& history) {
  torch::serialize::OutputArchive archive;
  archive.write("config", ConfigTensor(c));
  archive.write("step", torch::tensor({static_cast<std::int64_t>(step)}, torch::kInt64));
  archive.write("history", HistoryTensor(history));
  torch::serialize::OutputArchive net, opt;
  s.net->save(net);
  s.opt.save(opt);
  archive.write("net", net);
  archive.write("opt", opt);
  const std::filesystem::path tmp = path.string() + ".tmp";
  archive.save_to(tmp.string());
  std::filesystem::rename(tmp, path);
}

core::Result<int> LoadCheckpoint(const std::filesystem::path& path, State& s,
                                 const SegmentationNetConfig& c,
                                 std::vector<SegmentationLossRecord>* history) {
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path.string());
    torch::Tensor config, step, hist;
    archive.read("config", config);
    archive.read("step", step);
    archive.read("history", hist);
    if (!config.to(torch::kInt64).equal(ConfigTensor(c))) {
      return MakeError(ErrorCode::kUnprocessable,
                       path.string() + " was written for another network config", "resume");
    }
    torch::serialize::InputArchive net, opt;
    archive.read("net", net);
    archive.read("opt", opt);
    s.net->load(net);
    s.opt.load(opt);
    *history = HistoryFromTensor(hist.to(torch::kFloat64).contiguous());
    return static_cast<int>(step.item<std::int64_t>());
  } catch (const std::exception& e) {
    std::string what = e.what();
    if (const auto nl = what.find('\n'); nl != std::string::npos) what.resize(nl);
    return MakeError(ErrorCode::kUnprocessable, "cannot resume from " + path.string() + ": " + what,
                     "resume");
  }
}

/// Copies the weights of the saved model `path` into `net` (fine-tuning start).
std::optional<core::Error> InitFromModel(const std::filesystem::path& path, SegmentationNet& net,
                                         const SegmentationNetConfig& c) {
  auto loaded = LoadSegmentationNet(path);
  if (!loaded.ok()) return loaded.error();
  if (!ConfigTensor(loaded.value().config).equal(ConfigTensor(c))) {
    return MakeError(ErrorCode::kInvalidArgument,
                     path.string() + " was trained with another network config", "init");
  }
  torch::NoGradGuard no_grad;
  const auto from = loaded.value().net->named_parameters();
  for (auto& p : net->named_parameters()) p.value().copy_(from[p.key()]);
  const auto from_buffers = loaded.value().net->named_buffers();
  for (auto& b : net->named_buffers()) b.value().copy_(from_buffers[b.key()]);
  return std::nullopt;
}

double LearningRate(const SegmentationTrainOptions& o, int step) {
  constexpr int kWarmup = 100;
  if (step <= kWarmup) return o.learning_rate * step / kWarmup;
  const double t =
      std::clamp(static_cast<double>(step - kWarmup) / std::max(1, o.steps - kWarmup), 0.0, 1.0);
  return o.learning_rate * (0.05 + 0.95 * 0.5 * (1.0 + std::cos(std::numbers::pi * t)));
}

/// SSIM (Wang et al. 2004) of maps in [0, 1], 11x11 Gaussian window (sigma 1.5), mean over pixels.
torch::Tensor Ssim(const torch::Tensor& x, const torch::Tensor& y) {
  static const torch::Tensor window = [] {
    auto g = torch::arange(11, torch::kFloat32) - 5.0;
    g = torch::exp(-(g * g) / (2 * 1.5 * 1.5));
    g = g / g.sum();
    return torch::outer(g, g).reshape({1, 1, 11, 11});
  }();
  auto blur = [&](const torch::Tensor& t) { return torch::conv2d(t, window, {}, 1, 5); };
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  const torch::Tensor mx = blur(x), my = blur(y);
  const torch::Tensor sxx = blur(x * x) - mx * mx, syy = blur(y * y) - my * my;
  const torch::Tensor sxy = blur(x * y) - mx * my;
  return ((2 * mx * my + c1) * (2 * sxy + c2) / ((mx * mx + my * my + c1) * (sxx + syy + c2)))
      .mean();
}

struct Batch {
  torch::Tensor input, foreground, centre, offset, object_mask, deformability;
};

Batch MakeBatch(const SegmentationSet& set, int batch, std::uint64_t seed, int step) {
  const int w = set.size.width, h = set.size.height;
  const std::int64_t pixels = static_cast<std::int64_t>(w) * h;
  Batch b;
  b.input = torch::empty({batch, 1, h, w}, torch::kFloat32);
  b.foreground = torch::empty({batch, 1, h, w}, torch::kFloat32);
  b.centre = torch::empty({batch, 1, h, w}, torch::kFloat32);
  b.offset = torch::empty({batch, 2, h, w}, torch::kFloat32);
  b.deformability = torch::empty({batch, 1, h, w}, torch::kFloat32);
  std::mt19937_64 rng(MixSeed(seed, static_cast<std::uint64_t>(step)));
  std::uniform_int_distribution<int> pick(0, set.count() - 1);
  for (int k = 0; k < batch; ++k) {
    const auto i = static_cast<std::size_t>(pick(rng));
    const bool flip_u = (rng() & 1u) != 0;
    const bool flip_v = (rng() & 2u) != 0;
    float* in = b.input.data_ptr<float>() + k * pixels;
    float* def = b.deformability.data_ptr<float>() + k * pixels;
    cv::Mat1w labels(h, w);
    for (int r = 0; r < h; ++r) {
      const int sr = flip_v ? h - 1 - r : r;
      for (int c = 0; c < w; ++c) {
        const int sc = flip_u ? w - 1 - c : c;
        const std::size_t s = static_cast<std::size_t>(sr) * w + sc;
        in[r * w + c] = set.inputs[i][s] / 32767.0f;
        def[r * w + c] = set.deformability[i][s] / 255.0f;
        labels(r, c) = set.labels[i][s];
      }
    }
    const SegmentationTargets t = MakeSegmentationTargets(labels);
    auto copy = [&](const cv::Mat1f& m, torch::Tensor& dst, int channel, int channels) {
      std::copy_n(m.ptr<float>(), pixels,
                  dst.data_ptr<float>() + (k * channels + channel) * pixels);
    };
    copy(t.foreground, b.foreground, 0, 1);
    copy(t.centre, b.centre, 0, 1);
    copy(t.offset_u, b.offset, 0, 2);
    copy(t.offset_v, b.offset, 1, 2);
  }
  b.object_mask = b.foreground.expand({batch, 2, h, w});
  return b;
}

}  // namespace

core::Result<SegmentationSet> BuildSegmentationSet(const std::vector<SceneDataset>& datasets,
                                                   cv::Size size, int max_scenes_per_set,
                                                   const std::function<void(int, int)>& progress) {
  SegmentationSet set;
  set.size = size;
  int total = 0;
  for (const auto& d : datasets) {
    total += max_scenes_per_set > 0 ? std::min(max_scenes_per_set, d.size()) : d.size();
  }
  const std::size_t pixels = static_cast<std::size_t>(size.area());
  double object_sum = 0, object_count = 0;
  int done = 0;
  for (const auto& dataset : datasets) {
    const int n =
        max_scenes_per_set > 0 ? std::min(max_scenes_per_set, dataset.size()) : dataset.size();
    for (int i = 0; i < n; ++i) {
      auto sample = dataset.Load(i);
      if (!sample.ok()) return sample.error();
      auto scene = core::Preprocess(sample.value().depth, sample.value().camera);
      ++done;
      if (!scene.ok()) {
        ++set.skipped;
        if (progress) progress(done, total);
        continue;
      }
      const cv::Mat1f input = MakeModelInput(scene.value(), size);
      const cv::Mat1w& labels_full = sample.value().labels;
      cv::Mat1f def_full(labels_full.size(), 0.0f);
      const cv::Mat1f& stiffness = sample.value().stiffness;
      for (int r = 0; r < def_full.rows; ++r) {
        for (int c = 0; c < def_full.cols; ++c) {
          if (labels_full(r, c) > 0)
            def_full(r, c) = 1.0f - std::clamp(stiffness(r, c), 0.0f, 1.0f);
        }
      }
      cv::Mat1f def;
      cv::resize(def_full, def, size, 0, 0, cv::INTER_AREA);
      cv::Mat1w labels;
      cv::resize(labels_full, labels, size, 0, 0, cv::INTER_NEAREST);
      std::vector<std::int16_t> in(pixels);
      std::vector<std::uint16_t> lab(pixels);
      std::vector<std::uint8_t> d(pixels);
      for (int r = 0; r < size.height; ++r) {
        for (int c = 0; c < size.width; ++c) {
          const std::size_t k = static_cast<std::size_t>(r) * size.width + c;
          in[k] = static_cast<std::int16_t>(std::lround(input(r, c) * 32767.0f));
          lab[k] = labels(r, c);
          d[k] = static_cast<std::uint8_t>(std::lround(std::clamp(def(r, c), 0.0f, 1.0f) * 255.0f));
          if (lab[k] > 0) {
            object_sum += d[k] / 255.0;
            object_count += 1;
          }
        }
      }
      set.inputs.push_back(std::move(in));
      set.labels.push_back(std::move(lab));
      set.deformability.push_back(std::move(d));
      if (progress) progress(done, total);
    }
  }
  if (set.inputs.empty()) {
    return MakeError(ErrorCode::kUnprocessable, "no usable scene (all failed preprocessing)",
                     "data");
  }
  set.mean_object_deformability = object_count > 0 ? object_sum / object_count : 0.0;
  return set;
}

SegmentationTargets MakeSegmentationTargets(const cv::Mat1w& labels, double sigma) {
  const int w = labels.cols, h = labels.rows;
  SegmentationTargets t;
  t.foreground = cv::Mat1f(h, w, 0.0f);
  t.centre = cv::Mat1f(h, w, 0.0f);
  t.offset_u = cv::Mat1f(h, w, 0.0f);
  t.offset_v = cv::Mat1f(h, w, 0.0f);
  std::uint16_t max_id = 0;
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) max_id = std::max(max_id, labels(r, c));
  }
  std::vector<double> su(max_id + 1u, 0.0), sv(max_id + 1u, 0.0), n(max_id + 1u, 0.0);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const std::uint16_t id = labels(r, c);
      if (id == 0) continue;
      su[id] += c;
      sv[id] += r;
      n[id] += 1;
    }
  }
  const int reach = static_cast<int>(std::ceil(3 * sigma));
  for (std::size_t id = 1; id < n.size(); ++id) {
    if (n[id] == 0) continue;
    su[id] /= n[id];
    sv[id] /= n[id];
    const int cu = static_cast<int>(std::lround(su[id])),
              cv_ = static_cast<int>(std::lround(sv[id]));
    for (int r = std::max(0, cv_ - reach); r <= std::min(h - 1, cv_ + reach); ++r) {
      for (int c = std::max(0, cu - reach); c <= std::min(w - 1, cu + reach); ++c) {
        const double d2 = (c - su[id]) * (c - su[id]) + (r - sv[id]) * (r - sv[id]);
        t.centre(r, c) =
            std::max(t.centre(r, c), static_cast<float>(std::exp(-d2 / (2 * sigma * sigma))));
      }
    }
  }
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const std::uint16_t id = labels(r, c);
      if (id == 0) continue;
      t.foreground(r, c) = 1.0f;
      t.offset_u(r, c) = static_cast<float>((su[id] - c) / kOffsetScalePx);
      t.offset_v(r, c) = static_cast<float>((sv[id] - r) / kOffsetScalePx);
    }
  }
  return t;
}

core::Result<SegmentationTrainReport> TrainSegmentation(const SegmentationTrainOptions& o,
                                                        const SegmentationSet& set,
                                                        const SegmentationProgress& progress) {
  if (o.steps < 1 || o.batch < 1 || o.checkpoint_every < 1 || !(o.learning_rate > 0) ||
      o.out.empty() || o.stop_after_step < 0) {
    return MakeError(ErrorCode::kInvalidArgument, "bad training options", "options");
  }
  if (set.count() == 0 || set.size != cv::Size(o.network.width, o.network.height)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "the training set's size differs from the network's input", "options");
  }
  const auto t0 = std::chrono::steady_clock::now();
  torch::manual_seed(MixSeed(o.seed, 0));
  State s(o.network, o.learning_rate);
  SegmentationTrainReport report;
  const std::filesystem::path ckpt = CheckpointPath(o.out);
  if (o.resume && std::filesystem::exists(ckpt)) {
    auto step = LoadCheckpoint(ckpt, s, o.network, &report.history);
    if (!step.ok()) return step.error();
    report.start_step = step.value();
    report.history.resize(
        std::min<std::size_t>(report.history.size(), static_cast<std::size_t>(report.start_step)));
  } else if (!o.init.empty()) {
    if (auto error = InitFromModel(o.init, s.net, o.network)) return *error;
  }
  std::error_code ec;
  if (o.out.has_parent_path()) std::filesystem::create_directories(o.out.parent_path(), ec);
  s.net->train();
  int step = report.start_step;
  const int last_step = o.stop_after_step > 0 ? std::min(o.stop_after_step, o.steps) : o.steps;
  while (step < last_step) {
    ++step;
    const Batch b = MakeBatch(set, o.batch, o.seed, step);
    for (auto& group : s.opt.param_groups()) {
      static_cast<torch::optim::AdamOptions&>(group.options()).lr(LearningRate(o, step));
    }
    s.opt.zero_grad();
    const torch::Tensor y = s.net->forward(b.input);
    const torch::Tensor fg_loss =
        torch::binary_cross_entropy_with_logits(y.narrow(1, kHeadForeground, 1), b.foreground);
    const torch::Tensor centre_loss = torch::mse_loss(y.narrow(1, kHeadCentre, 1), b.centre);
    const torch::Tensor offset_loss =
        ((y.narrow(1, kHeadOffsetU, 2) - b.offset).abs() * b.object_mask).sum() /
        (b.object_mask.sum() + 1.0);
    const torch::Tensor def = torch::sigmoid(y.narrow(1, kHeadDeformability, 1));
    const torch::Tensor def_l1 = torch::l1_loss(def, b.deformability);
    const torch::Tensor ssim_loss = 1.0 - Ssim(def, b.deformability);
    const torch::Tensor loss = fg_loss + o.centre_weight * centre_loss +
                               o.offset_weight * offset_loss + def_l1 + o.ssim_weight * ssim_loss;
    loss.backward();
    s.opt.step();
    SegmentationLossRecord r{step,
                             loss.item<double>(),
                             fg_loss.item<double>(),
                             centre_loss.item<double>(),
                             offset_loss.item<double>(),
                             def_l1.item<double>(),
                             ssim_loss.item<double>()};
    if (!std::isfinite(r.total)) {
      return MakeError(ErrorCode::kInternal,
                       "training diverged at step " + std::to_string(step) + " (non-finite loss)",
                       "steps");
    }
    report.history.push_back(r);
    if (progress) progress(r, o.steps);
    if (step % o.checkpoint_every == 0 || step == last_step) {
      SaveCheckpoint(ckpt, s, o.network, step, report.history);
      SaveSegmentationNet(o.out, s.net, o.network, kInputHeightRangeM);
      s.net->train();
      WriteSegmentationLossCurve(report.history, o, LossCsvPath(o.out), LossPngPath(o.out));
    }
  }
  report.end_step = step;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

void WriteSegmentationLossCurve(const std::vector<SegmentationLossRecord>& history,
                                const SegmentationTrainOptions& o, const std::filesystem::path& csv,
                                const std::filesystem::path& png) {
  {
    std::ofstream out(csv);
    out << "step,total,foreground_bce,centre_mse,offset_l1,deformability_l1,one_minus_ssim\n";
    for (const auto& r : history) {
      out << r.step << ',' << r.total << ',' << r.foreground << ',' << r.centre << ',' << r.offset
          << ',' << r.deformability << ',' << r.ssim << '\n';
    }
  }
  std::vector<int> steps;
  std::vector<LossSeries> series = {{"total", {0, 0, 0}, {}},
                                    {"foreground BCE", {200, 60, 20}, {}},
                                    {"centre MSE x w", {30, 30, 220}, {}},
                                    {"offset L1 x w", {40, 160, 40}, {}},
                                    {"deform. L1", {160, 40, 160}, {}},
                                    {"1 - SSIM x w", {20, 140, 200}, {}}};
  for (const auto& r : history) {
    steps.push_back(r.step);
    series[0].values.push_back(r.total);
    series[1].values.push_back(r.foreground);
    series[2].values.push_back(o.centre_weight * r.centre);
    series[3].values.push_back(o.offset_weight * r.offset);
    series[4].values.push_back(r.deformability);
    series[5].values.push_back(o.ssim_weight * r.ssim);
  }
  PlotLossCurves("segmentation training losses (smoothed)", steps, series, png);
}

}  // namespace softgrasp::models
