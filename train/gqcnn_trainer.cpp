#include "train/gqcnn_trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <numeric>
#include <opencv2/imgproc.hpp>

#include "service/gqcnn/clearance.h"
#include "service/models/network.h"
#include "train/loss_plot.h"
#include "train/seed_mix.h"
#include "train/trainer.h"

namespace softgrasp::models {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;
constexpr int kSide = gqcnn::kCropSizePx;
constexpr int kPixels = gqcnn::kCropPixels;

/// Mean of the valid pixels of the 3 x 3 patch at (row, col); NaN when none is valid.
double PatchDepth(const float* crop, int row, int col) {
  double sum = 0;
  int n = 0;
  for (int r = std::max(0, row - 1); r <= std::min(kSide - 1, row + 1); ++r) {
    for (int c = std::max(0, col - 1); c <= std::min(kSide - 1, col + 1); ++c) {
      const float d = crop[r * kSide + c];
      if (std::isfinite(d) && d > 0) {
        sum += d;
        ++n;
      }
    }
  }
  return n > 0 ? sum / n : std::nan("");
}

double Sigmoid(double z) { return 1.0 / (1.0 + std::exp(-z)); }

const char* OptimizerName(GqcnnOptimizer o) { return o == GqcnnOptimizer::kSgd ? "sgd" : "adam"; }
const char* BalanceName(GqcnnBalance b) {
  switch (b) {
    case GqcnnBalance::kNone:
      return "none";
    case GqcnnBalance::kWeightedLoss:
      return "weighted-loss";
    case GqcnnBalance::kBalancedSampling:
      return "balanced-sampling";
  }
  return "?";
}

double BaseLearningRate(const GqcnnTrainOptions& o) {
  if (o.learning_rate > 0) return o.learning_rate;
  return o.optimizer == GqcnnOptimizer::kSgd ? 0.01 : 1e-3;
}

json AugmentationJson(const GqcnnAugmentation& a) {
  return {{"multiplicative", a.multiplicative},
          {"gamma_shape", a.gamma_shape},
          {"gp_rate", a.gp_rate},
          {"gp_sigma_m", a.gp_sigma_m},
          {"gp_grid", a.gp_grid},
          {"symmetries", a.symmetries}};
}

/// What fixes a run's trajectory: a checkpoint written with other values is refused. The total
/// step count is not part of it (the learning rate decays by epochs, not by the run's length), so
/// a finished run can be extended with a larger --steps and --resume.
json RunFingerprint(const GqcnnTrainOptions& o, const GqcnnNormalisation& n,
                    std::size_t train_records) {
  return {{"batch", o.batch},
          {"optimizer", OptimizerName(o.optimizer)},
          {"learning_rate", BaseLearningRate(o)},
          {"momentum", o.momentum},
          {"weight_decay", o.weight_decay},
          {"lr_decay", o.lr_decay},
          {"decay_every_epochs", o.decay_every_epochs},
          {"balance", BalanceName(o.balance)},
          {"validation_fraction", o.validation_fraction},
          {"seed", o.seed},
          {"eval_every", o.eval_every},
          {"network", GqcnnConfigJson(o.network)},
          {"augmentation", AugmentationJson(o.augmentation)},
          {"normalisation", {n.im_mean_m, n.im_std_m, n.pose_mean_m, n.pose_std_m}},
          {"train_records", train_records},
          {"admitted_only", o.admitted_only}};
}

torch::Tensor JsonTensor(const json& j) {
  const std::string text = j.dump();
  torch::Tensor t = torch::empty({static_cast<std::int64_t>(text.size())}, torch::kUInt8);
  std::copy(text.begin(), text.end(), reinterpret_cast<char*>(t.data_ptr<std::uint8_t>()));
  return t;
}

json TensorJson(const torch::Tensor& t) {
  const auto bytes = t.to(torch::kUInt8).contiguous();
  return json::parse(std::string(reinterpret_cast<const char*>(bytes.data_ptr<std::uint8_t>()),
                                 static_cast<std::size_t>(bytes.numel())),
                     nullptr, false);
}

json ValidationJson(const GqcnnValidation& v) {
  return {{"step", v.step},           {"loss", v.loss},
          {"accuracy", v.accuracy},   {"balanced_accuracy", v.balanced_accuracy},
          {"precision", v.precision}, {"recall", v.recall}};
}

GqcnnValidation ValidationFromJson(const json& j) {
  GqcnnValidation v;
  v.step = j.value("step", 0);
  v.loss = j.value("loss", 0.0);
  v.accuracy = j.value("accuracy", 0.0);
  v.balanced_accuracy = j.value("balanced_accuracy", 0.0);
  v.precision = j.value("precision", 0.0);
  v.recall = j.value("recall", 0.0);
  return v;
}

struct State {
  GqcnnNet net;
  std::unique_ptr<torch::optim::Optimizer> opt;
  State(const GqcnnTrainOptions& o) : net(o.network) {
    InitGqcnnWeights(net);
    if (o.optimizer == GqcnnOptimizer::kSgd) {
      opt = std::make_unique<torch::optim::SGD>(net->parameters(),
                                                torch::optim::SGDOptions(BaseLearningRate(o))
                                                    .momentum(o.momentum)
                                                    .weight_decay(o.weight_decay));
    } else {
      opt = std::make_unique<torch::optim::Adam>(
          net->parameters(),
          torch::optim::AdamOptions(BaseLearningRate(o)).weight_decay(o.weight_decay));
    }
  }
};

/// Everything beyond the network and optimiser a resumed run needs.
struct Progress {
  int step = 0;
  double seconds = 0;  ///< training wall time of earlier runs
  std::vector<GqcnnStepRecord> history;
  std::vector<GqcnnValidation> validations;
  GqcnnValidation best;
  bool has_best = false;
};

json ProgressJson(const Progress& p, const json& fingerprint) {
  json history = json::array(), validations = json::array();
  for (const auto& r : p.history) history.push_back({r.step, r.loss, r.accuracy, r.learning_rate});
  for (const auto& v : p.validations) validations.push_back(ValidationJson(v));
  return {{"fingerprint", fingerprint},    {"step", p.step},
          {"seconds", p.seconds},          {"history", history},
          {"validations", validations},    {"has_best", p.has_best},
          {"best", ValidationJson(p.best)}};
}

void SaveCheckpoint(const std::filesystem::path& path, State& s, const Progress& p,
                    const json& fingerprint) {
  torch::serialize::OutputArchive archive;
  // Losses are stored as JSON numbers: nlohmann's dump round-trips doubles exactly.
  archive.write("progress", JsonTensor(ProgressJson(p, fingerprint)));
  torch::serialize::OutputArchive net, opt;
  s.net->save(net);
  s.opt->save(opt);
  archive.write("net", net);
  archive.write("opt", opt);
  const std::filesystem::path tmp = path.string() + ".tmp";
  archive.save_to(tmp.string());
  std::filesystem::rename(tmp, path);
}

core::Result<Progress> LoadCheckpoint(const std::filesystem::path& path, State& s,
                                      const json& fingerprint) {
  auto fail = [&](const std::string& why) {
    return MakeError(ErrorCode::kUnprocessable, "cannot resume from " + path.string() + ": " + why,
                     "resume");
  };
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path.string());
    torch::Tensor progress_t;
    if (!archive.try_read("progress", progress_t)) return fail("not a GQ-CNN checkpoint");
    const json j = TensorJson(progress_t);
    if (j.is_discarded() || !j.is_object()) return fail("unreadable progress record");
    if (j.at("fingerprint") != fingerprint) {
      return fail(
          "it was written by a run with other options or data (steps, batch, optimiser, "
          "network, split or normalisation differ); delete it or train without --resume");
    }
    torch::serialize::InputArchive net, opt;
    archive.read("net", net);
    archive.read("opt", opt);
    s.net->load(net);
    s.opt->load(opt);
    Progress p;
    p.step = j.at("step").get<int>();
    p.seconds = j.at("seconds").get<double>();
    for (const auto& r : j.at("history")) {
      p.history.push_back({r.at(0).get<int>(), r.at(1).get<double>(), r.at(2).get<double>(),
                           r.at(3).get<double>()});
    }
    for (const auto& v : j.at("validations")) p.validations.push_back(ValidationFromJson(v));
    p.has_best = j.at("has_best").get<bool>();
    p.best = ValidationFromJson(j.at("best"));
    return p;
  } catch (const std::exception& e) {
    std::string what = e.what();
    if (const auto nl = what.find('\n'); nl != std::string::npos) what.resize(nl);
    return fail(what);
  }
}

struct Counts {
  double tp = 0, fp = 0, tn = 0, fn = 0;
  void Add(bool label, bool predicted) {
    if (label && predicted) tp += 1;
    if (!label && predicted) fp += 1;
    if (!label && !predicted) tn += 1;
    if (label && !predicted) fn += 1;
  }
  double Accuracy() const { return (tp + tn) / std::max(1.0, tp + tn + fp + fn); }
  double Recall() const { return tp + fn > 0 ? tp / (tp + fn) : std::nan(""); }
  double Specificity() const { return tn + fp > 0 ? tn / (tn + fp) : std::nan(""); }
  double Precision() const { return tp + fp > 0 ? tp / (tp + fp) : std::nan(""); }
};

/// Probabilities of `records` (eval mode, no grad), in chunks.
std::vector<float> PredictRecords(GqcnnNet& net, const GqcnnNetConfig& config, const GqcnnSet& set,
                                  const std::vector<std::size_t>& records,
                                  const GqcnnNormalisation& norm, double* mean_loss) {
  torch::NoGradGuard no_grad;
  net->eval();
  constexpr std::size_t kChunk = 1024;
  std::vector<float> probs(records.size());
  std::vector<float> crops, depths, clearances;
  double loss_sum = 0;
  for (std::size_t begin = 0; begin < records.size(); begin += kChunk) {
    const std::size_t n = std::min(kChunk, records.size() - begin);
    crops.resize(n * kPixels);
    depths.resize(n);
    clearances.resize(n * 3);
    std::vector<std::int64_t> labels(n);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = records[begin + k];
      std::copy_n(set.crop(i), kPixels, crops.data() + k * kPixels);
      if (config.clearance_inputs) std::copy_n(set.clearance(i), 3, clearances.data() + k * 3);
      depths[k] = set.grasp_depths_m[i];
      labels[k] = set.labels[i];
    }
    torch::Tensor images, poses;
    NormaliseGqcnnInputs(crops.data(), depths.data(), clearances.data(),
                         static_cast<std::int64_t>(n), config, norm, &images, &poses);
    const torch::Tensor logits = net->forward(images, poses);
    const torch::Tensor target = torch::tensor(labels, torch::kInt64);
    loss_sum += GqcnnSuccessLoss(logits, target, config, {}, /*sum=*/true).item<double>();
    const torch::Tensor p = GqcnnSuccessProbability(logits, config).contiguous();
    std::copy_n(p.data_ptr<float>(), n, probs.begin() + static_cast<std::ptrdiff_t>(begin));
  }
  if (mean_loss) *mean_loss = loss_sum / std::max<std::size_t>(1, records.size());
  net->train();
  return probs;
}

GqcnnValidation Validate(GqcnnNet& net, const GqcnnNetConfig& config, const GqcnnSet& set,
                         const std::vector<std::size_t>& records, const GqcnnNormalisation& norm,
                         int step) {
  GqcnnValidation v;
  v.step = step;
  const std::vector<float> probs = PredictRecords(net, config, set, records, norm, &v.loss);
  Counts c;
  for (std::size_t k = 0; k < records.size(); ++k) {
    c.Add(set.labels[records[k]] != 0, probs[k] >= 0.5f);
  }
  v.accuracy = c.Accuracy();
  v.recall = c.Recall();
  v.precision = c.Precision();
  v.balanced_accuracy = 0.5 * (c.Recall() + c.Specificity());
  return v;
}

double PositiveRate(const std::vector<std::uint8_t>& labels,
                    const std::vector<std::size_t>& records) {
  double pos = 0;
  for (const std::size_t i : records) pos += labels[i];
  return records.empty() ? 0.0 : pos / static_cast<double>(records.size());
}

/// {w_0, w_1} that make both classes weigh half of the loss.
torch::Tensor BalancedClassWeights(double positive_rate) {
  const double rate = std::clamp(positive_rate, 1e-3, 1.0 - 1e-3);
  return torch::tensor({0.5 / (1.0 - rate), 0.5 / rate}, torch::kFloat32);
}

void WriteCurves(const std::filesystem::path& out, const std::vector<GqcnnStepRecord>& history,
                 const std::vector<GqcnnValidation>& validations) {
  {
    std::ofstream csv(LossCsvPath(out));
    csv << "step,train_loss,train_accuracy,learning_rate,val_loss,val_accuracy,"
           "val_balanced_accuracy,val_precision,val_recall\n";
    std::size_t v = 0;
    for (const auto& r : history) {
      csv << r.step << ',' << r.loss << ',' << r.accuracy << ',' << r.learning_rate;
      while (v < validations.size() && validations[v].step < r.step) ++v;
      if (v < validations.size() && validations[v].step == r.step) {
        const auto& x = validations[v];
        csv << ',' << x.loss << ',' << x.accuracy << ',' << x.balanced_accuracy << ','
            << x.precision << ',' << x.recall;
      } else {
        csv << ",,,,,";
      }
      csv << '\n';
    }
  }
  // Validation figures are held from one validation to the next (a step plot).
  std::vector<int> steps;
  std::vector<LossSeries> loss = {{"train loss", {200, 60, 20}, {}},
                                  {"validation loss", {30, 30, 220}, {}}};
  std::vector<LossSeries> acc = {{"train accuracy (augmented)", {200, 60, 20}, {}},
                                 {"validation accuracy", {30, 30, 220}, {}},
                                 {"validation balanced accuracy", {40, 160, 40}, {}}};
  std::size_t v = 0;
  const GqcnnValidation* last = nullptr;
  for (const auto& r : history) {
    while (v < validations.size() && validations[v].step <= r.step) last = &validations[v++];
    steps.push_back(r.step);
    loss[0].values.push_back(r.loss);
    acc[0].values.push_back(r.accuracy);
    loss[1].values.push_back(last ? last->loss : r.loss);
    acc[1].values.push_back(last ? last->accuracy : 0.5);
    acc[2].values.push_back(last ? last->balanced_accuracy : 0.5);
  }
  PlotLossCurves("GQ-CNN training loss (smoothed)", steps, loss, LossPngPath(out));
  PlotLossCurves("GQ-CNN accuracy (train smoothed)", steps, acc, GqcnnAccuracyPngPath(out));
}

std::optional<core::Error> CheckOptions(const GqcnnTrainOptions& o) {
  auto bad = [](const std::string& field, const std::string& why) {
    return MakeError(ErrorCode::kInvalidArgument, field + " " + why, field);
  };
  if (o.out.empty()) return bad("out", "must name a model file");
  if (o.steps < 0 || (o.steps == 0 && !(o.epochs > 0))) {
    return bad("steps", "must be >= 1 (or epochs > 0)");
  }
  if (o.batch < 1 || o.batch > 4096) return bad("batch", "must be in 1..4096");
  if (!(o.learning_rate >= 0) || !(o.weight_decay >= 0) || !(o.momentum >= 0 && o.momentum < 1)) {
    return bad("lr", "weight decay and momentum must be >= 0 (momentum < 1)");
  }
  if (!(o.lr_decay > 0 && o.lr_decay <= 1) || !(o.decay_every_epochs > 0)) {
    return bad("lr_decay", "must be in (0, 1] with decay_every_epochs > 0");
  }
  if (!(o.validation_fraction > 0 && o.validation_fraction < 1)) {
    return bad("validation_fraction", "must be in (0, 1)");
  }
  if (o.eval_every < 0 || o.checkpoint_every < 0 || o.stop_after_step < 0) {
    return bad("eval_every", "checkpoint_every and stop_after_step must be >= 0");
  }
  const auto& a = o.augmentation;
  if (!(a.gamma_shape > 0) || !(a.gp_rate >= 0 && a.gp_rate <= 1) || !(a.gp_sigma_m >= 0) ||
      a.gp_grid < 2 || a.gp_grid > kSide) {
    return bad("augmentation", "has values out of range");
  }
  return std::nullopt;
}

}  // namespace

std::size_t GqcnnSet::images() const {
  std::uint32_t max_key = 0;
  for (const auto k : image_keys) max_key = std::max(max_key, k + 1);
  return max_key;
}

core::Result<GqcnnSet> LoadGqcnnSet(const std::vector<std::filesystem::path>& dirs,
                                    const std::function<void(int, int)>& progress) {
  GqcnnSet set;
  std::vector<gqcnn::DatasetIndex> indices;
  int total_shards = 0;
  for (const auto& dir : dirs) {
    auto index = gqcnn::ReadIndex(dir);
    if (!index.ok()) return index.error();
    total_shards += static_cast<int>(index.value().shards.size());
    indices.push_back(std::move(index.value()));
  }
  std::size_t expected = 0;
  for (const auto& index : indices) expected += index.Datapoints();
  set.crops_depth_m.reserve(expected * kPixels);
  int done = 0;
  for (std::size_t d = 0; d < dirs.size(); ++d) {
    const auto& index = indices[d];
    set.sources.push_back(dirs[d].string());
    const auto object_base = static_cast<std::uint32_t>(set.object_names.size());
    for (const auto& object : index.objects) {
      set.object_names.push_back(dirs[d].filename().string() + ":" + object.name);
      set.object_sources.push_back(static_cast<std::uint32_t>(d));
    }
    std::map<std::uint32_t, std::uint32_t> image_keys;
    const auto image_base = static_cast<std::uint32_t>(set.images());
    for (const auto& shard : index.shards) {
      auto records = gqcnn::ReadShard(dirs[d] / shard.file);
      if (!records.ok()) return records.error();
      for (const auto& r : records.value()) {
        if (r.object_index >= index.objects.size()) {
          return MakeError(ErrorCode::kInvalidArgument,
                           (dirs[d] / shard.file).string() + ": object_index " +
                               std::to_string(r.object_index) + " but the index lists " +
                               std::to_string(index.objects.size()) + " objects",
                           "data");
        }
        set.crops_depth_m.insert(set.crops_depth_m.end(), r.crop_depth_m.begin(),
                                 r.crop_depth_m.end());
        set.grasp_depths_m.push_back(r.grasp_depth_m);
        set.width_px.push_back(r.hand_pose[6]);
        set.labels.push_back(r.label ? 1 : 0);
        set.collision_free.push_back(r.collision_free ? 1 : 0);
        set.quality_labels.push_back(r.robust_ferrari_canny > index.metric_threshold ? 1 : 0);
        const bool measured = std::isfinite(r.jaw_clearance_m) &&
                              std::isfinite(r.palm_clearance_m) &&
                              std::isfinite(r.floor_clearance_m);
        set.clearances_measured = set.clearances_measured && measured;
        for (const double c : {r.jaw_clearance_m, r.palm_clearance_m, r.floor_clearance_m}) {
          set.clearances_m.push_back(static_cast<float>(c));
        }
        set.admitted.push_back(
            !measured || gqcnn::ClearanceRule{}.Admits(gqcnn::StoredClearance(r), core::Gripper{})
                ? 1
                : 0);
        set.positives += r.label ? 1 : 0;
        set.object_keys.push_back(object_base + r.object_index);
        const auto [it, inserted] = image_keys.try_emplace(
            r.image_index, image_base + static_cast<std::uint32_t>(image_keys.size()));
        set.image_keys.push_back(it->second);
      }
      if (progress) progress(++done, total_shards);
    }
  }
  if (set.size() == 0) {
    return MakeError(ErrorCode::kInvalidArgument, "the datasets hold no finished shard records",
                     "data");
  }
  return set;
}

GqcnnSplit SplitByObject(const GqcnnSet& set, double validation_fraction, std::uint64_t seed) {
  std::vector<std::uint32_t> present;
  {
    std::vector<bool> seen(set.object_names.size(), false);
    for (const auto k : set.object_keys) {
      if (!seen[k]) {
        seen[k] = true;
        present.push_back(k);
      }
    }
    std::sort(present.begin(), present.end());
  }
  std::mt19937_64 rng(MixSeed(seed, 0x5B117ull));
  // Fisher-Yates with our own draws: std::shuffle's use of the engine is implementation-defined.
  for (std::size_t i = present.size(); i > 1; --i) {
    const std::size_t j = rng() % i;
    std::swap(present[i - 1], present[j]);
  }
  std::size_t held = static_cast<std::size_t>(
      std::lround(validation_fraction * static_cast<double>(present.size())));
  if (present.size() >= 2) held = std::clamp<std::size_t>(held, 1, present.size() - 1);
  GqcnnSplit split;
  std::vector<bool> validation(set.object_names.size(), false);
  for (std::size_t i = 0; i < held && i < present.size(); ++i) {
    validation[present[i]] = true;
    split.validation_objects.push_back(present[i]);
  }
  std::sort(split.validation_objects.begin(), split.validation_objects.end());
  for (std::size_t i = 0; i < set.size(); ++i) {
    (validation[set.object_keys[i]] ? split.validation : split.train).push_back(i);
  }
  return split;
}

GqcnnNormalisation ComputeNormalisation(const GqcnnSet& set,
                                        const std::vector<std::size_t>& records) {
  double sum = 0, sum2 = 0, n = 0, psum = 0, psum2 = 0;
  for (const std::size_t i : records) {
    const float* crop = set.crop(i);
    for (int k = 0; k < kPixels; ++k) {
      const double d = crop[k];
      if (std::isfinite(d) && d > 0) {
        sum += d;
        sum2 += d * d;
        n += 1;
      }
    }
    const double g = set.grasp_depths_m[i];
    psum += g;
    psum2 += g * g;
  }
  GqcnnNormalisation norm;
  const double m = static_cast<double>(records.size());
  if (n > 0) {
    norm.im_mean_m = sum / n;
    norm.im_std_m = std::sqrt(std::max(0.0, sum2 / n - norm.im_mean_m * norm.im_mean_m));
  }
  if (m > 0) {
    norm.pose_mean_m = psum / m;
    norm.pose_std_m = std::sqrt(std::max(0.0, psum2 / m - norm.pose_mean_m * norm.pose_mean_m));
  }
  // A constant input (one depth everywhere) would divide by 0; 1 mm keeps its scale sane.
  norm.im_std_m = std::max(norm.im_std_m, 1e-3);
  norm.pose_std_m = std::max(norm.pose_std_m, 1e-3);
  return norm;
}

void ApplyCropSymmetries(float* crop, bool rotate_180, bool flip_lr, bool flip_ud) {
  // A 180-degree rotation is both flips; compose into one pair of flips.
  const bool lr = flip_lr != rotate_180;
  const bool ud = flip_ud != rotate_180;
  if (lr) {
    for (int r = 0; r < kSide; ++r) std::reverse(crop + r * kSide, crop + (r + 1) * kSide);
  }
  if (ud) {
    for (int r = 0; r < kSide / 2; ++r) {
      std::swap_ranges(crop + r * kSide, crop + (r + 1) * kSide, crop + (kSide - 1 - r) * kSide);
    }
  }
}

GqcnnAugmentDraw AugmentCrop(float* crop, const GqcnnAugmentation& a, std::mt19937_64& rng) {
  GqcnnAugmentDraw draw;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (a.multiplicative) {
    std::gamma_distribution<double> gamma(a.gamma_shape, 1.0 / a.gamma_shape);
    draw.gain = gamma(rng);
    const auto g = static_cast<float>(draw.gain);
    for (int k = 0; k < kPixels; ++k) crop[k] *= g;  // 0 stays 0
  }
  draw.gp_noise = unit(rng) < a.gp_rate;
  if (draw.gp_noise && a.gp_sigma_m > 0) {
    cv::Mat1f grid(a.gp_grid, a.gp_grid);
    std::normal_distribution<double> normal(0.0, a.gp_sigma_m);
    for (int r = 0; r < a.gp_grid; ++r) {
      for (int c = 0; c < a.gp_grid; ++c) grid(r, c) = static_cast<float>(normal(rng));
    }
    cv::Mat1f noise;
    cv::resize(grid, noise, cv::Size(kSide, kSide), 0, 0, cv::INTER_CUBIC);
    for (int k = 0; k < kPixels; ++k) {
      if (crop[k] > 0) {
        // Stays valid: a noisy depth never reaches 0 (1 micrometre floor; real depths are
        // tenths of metres and the noise millimetres).
        crop[k] = std::max(crop[k] + noise(k / kSide, k % kSide), 1e-6f);
      }
    }
  }
  if (a.symmetries) {
    draw.rotate_180 = unit(rng) < 0.5;
    draw.flip_lr = unit(rng) < 0.5;
    draw.flip_ud = unit(rng) < 0.5;
    ApplyCropSymmetries(crop, draw.rotate_180, draw.flip_lr, draw.flip_ud);
  }
  return draw;
}

std::array<double, 2> GqcnnHandFeatures(const float* crop, float grasp_depth_m, float width_px) {
  const int centre = kSide / 2;
  // The crop is the 96-pixel crop resized to 32: a third of the full-image opening; 7 px when
  // the record has no width.
  const double half = (std::isfinite(width_px) && width_px > 0) ? width_px / 6.0 : 7.0;
  const int offset = std::clamp(static_cast<int>(std::lround(half)), 1, centre - 1);
  const double dc = PatchDepth(crop, centre, centre);
  const double dl = PatchDepth(crop, centre, centre - offset);
  const double dr = PatchDepth(crop, centre, centre + offset);
  double jaws = std::nan("");
  if (std::isfinite(dl) && std::isfinite(dr))
    jaws = std::min(dl, dr);
  else if (std::isfinite(dl))
    jaws = dl;
  else if (std::isfinite(dr))
    jaws = dr;
  const double f0 = (std::isfinite(jaws) && std::isfinite(dc)) ? jaws - dc : 0.0;
  const double f1 = (std::isfinite(dc) && std::isfinite(grasp_depth_m)) ? grasp_depth_m - dc : 0.0;
  return {f0, f1};
}

double LogisticBaseline::Predict(const std::array<double, 2>& f) const {
  double z = weights[0];
  for (int k = 0; k < 2; ++k) z += weights[k + 1] * (f[k] - feature_mean[k]) / feature_std[k];
  return Sigmoid(z);
}

nlohmann::json LogisticBaseline::ToJson() const {
  return {{"kind", "logistic-regression"},
          {"features",
           {"shallower jaw-tip depth - centre depth (m)", "grasp depth - centre depth (m)"}},
          {"feature_mean", feature_mean},
          {"feature_std", feature_std},
          {"weights", weights},
          {"train_positive_rate", train_positive_rate}};
}

core::Result<LogisticBaseline> LogisticBaseline::FromJson(const nlohmann::json& j) {
  try {
    LogisticBaseline b;
    b.feature_mean = j.at("feature_mean").get<std::array<double, 2>>();
    b.feature_std = j.at("feature_std").get<std::array<double, 2>>();
    b.weights = j.at("weights").get<std::array<double, 3>>();
    b.train_positive_rate = j.at("train_positive_rate").get<double>();
    if (!(b.feature_std[0] > 0) || !(b.feature_std[1] > 0)) throw std::invalid_argument("std");
    return b;
  } catch (const std::exception&) {
    return MakeError(ErrorCode::kUnprocessable, "the model card's baseline is missing or broken",
                     "baseline");
  }
}

LogisticBaseline FitLogisticBaseline(const GqcnnSet& set, const std::vector<std::size_t>& records) {
  LogisticBaseline b;
  b.train_positive_rate = PositiveRate(set.labels, records);
  std::vector<std::array<double, 2>> x;
  x.reserve(records.size());
  std::array<double, 2> sum{}, sum2{};
  for (const std::size_t i : records) {
    x.push_back(GqcnnHandFeatures(set.crop(i), set.grasp_depths_m[i], set.width_px[i]));
    for (int k = 0; k < 2; ++k) {
      sum[k] += x.back()[k];
      sum2[k] += x.back()[k] * x.back()[k];
    }
  }
  const double n = std::max<double>(1, static_cast<double>(records.size()));
  for (int k = 0; k < 2; ++k) {
    b.feature_mean[k] = sum[k] / n;
    b.feature_std[k] = std::max(
        1e-9, std::sqrt(std::max(0.0, sum2[k] / n - b.feature_mean[k] * b.feature_mean[k])));
  }
  const double pos = b.train_positive_rate * n, neg = n - pos;
  const double w_pos = pos > 0 ? n / (2 * pos) : 0, w_neg = neg > 0 ? n / (2 * neg) : 0;
  std::array<double, 3> w{};
  for (int iteration = 0; iteration < 50; ++iteration) {
    double g[3] = {0, 0, 0}, h[3][3] = {{1e-3 * n, 0, 0}, {0, 1e-3 * n, 0}, {0, 0, 1e-3 * n}};
    for (int k = 0; k < 3; ++k) g[k] = 1e-3 * n * w[static_cast<std::size_t>(k)];
    for (std::size_t r = 0; r < records.size(); ++r) {
      const double z[3] = {1.0, (x[r][0] - b.feature_mean[0]) / b.feature_std[0],
                           (x[r][1] - b.feature_mean[1]) / b.feature_std[1]};
      const double p = Sigmoid(w[0] * z[0] + w[1] * z[1] + w[2] * z[2]);
      const bool y = set.labels[records[r]] != 0;
      const double weight = y ? w_pos : w_neg;
      for (int a = 0; a < 3; ++a) {
        g[a] += weight * (p - (y ? 1.0 : 0.0)) * z[a];
        for (int c = 0; c < 3; ++c) h[a][c] += weight * p * (1 - p) * z[a] * z[c];
      }
    }
    // Solve h d = g (3 x 3, Gaussian elimination with partial pivoting).
    double m[3][4];
    for (int a = 0; a < 3; ++a) {
      for (int c = 0; c < 3; ++c) m[a][c] = h[a][c];
      m[a][3] = g[a];
    }
    for (int col = 0; col < 3; ++col) {
      int pivot = col;
      for (int r = col + 1; r < 3; ++r) {
        if (std::abs(m[r][col]) > std::abs(m[pivot][col])) pivot = r;
      }
      std::swap(m[col], m[pivot]);
      for (int r = col + 1; r < 3; ++r) {
        const double f = m[r][col] / m[col][col];
        for (int c = col; c < 4; ++c) m[r][c] -= f * m[col][c];
      }
    }
    double d[3];
    for (int r = 2; r >= 0; --r) {
      double s = m[r][3];
      for (int c = r + 1; c < 3; ++c) s -= m[r][c] * d[c];
      d[r] = s / m[r][r];
    }
    double step = 0;
    for (int k = 0; k < 3; ++k) {
      w[static_cast<std::size_t>(k)] -= d[k];
      step = std::max(step, std::abs(d[k]));
    }
    if (!(step > 1e-10)) break;
  }
  b.weights = w;
  return b;
}

std::filesystem::path GqcnnCardPath(const std::filesystem::path& out) {
  return std::filesystem::path(out).replace_extension(".json");
}
std::filesystem::path GqcnnAccuracyPngPath(const std::filesystem::path& out) {
  auto p = out;
  return p.replace_filename(out.stem().string() + "_accuracy.png");
}

namespace {

/// The object-wise split the run trains and validates on, after the checks that the options and
/// the data fit each other (clearances, factored labels, both classes in each part).
core::Result<GqcnnSplit> CheckedSplit(const GqcnnTrainOptions& o, const GqcnnSet& set) {
  if (auto error = CheckOptions(o)) return *error;
  GqcnnSplit split = SplitByObject(set, o.validation_fraction, o.seed);
  if (o.network.clearance_inputs &&
      (!set.clearances_measured || set.clearances_m.size() != 3 * set.size())) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "a network with clearance inputs needs datasets with gripper clearances (made "
                     "by softgrasp-sim gqcnn-dataset since generator version 3)",
                     "data");
  }
  if (o.admitted_only) {
    if (!set.clearances_measured) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "admitted-only training needs datasets with gripper clearances (made by "
                       "softgrasp-sim gqcnn-dataset since generator version 3)",
                       "data");
    }
    for (auto* records : {&split.train, &split.validation}) {
      std::erase_if(*records, [&](std::size_t i) { return set.admitted[i] == 0; });
    }
  }
  auto count_classes = [&](const std::vector<std::size_t>& records,
                           const char* which) -> std::optional<core::Error> {
    const double rate = PositiveRate(set.labels, records);
    if (records.empty() || rate <= 0 || rate >= 1) {
      return MakeError(ErrorCode::kInvalidArgument,
                       std::string("the object-wise split's ") + which +
                           " part needs both positives and negatives (" +
                           std::to_string(records.size()) + " records, positive rate " +
                           std::to_string(rate) + "); use more objects",
                       "data");
    }
    return std::nullopt;
  };
  if (auto e = count_classes(split.train, "training")) return *e;
  if (auto e = count_classes(split.validation, "validation")) return *e;
  if (o.network.factored &&
      (set.collision_free.size() != set.size() || set.quality_labels.size() != set.size())) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "a factored network needs each record's collision and quality labels", "data");
  }
  return split;
}

/// Everything a run fixes from the options and the split before its first step.
struct RunSetup {
  GqcnnSplit split;
  GqcnnTrainOptions opt;  ///< the options with steps, eval_every and checkpoint_every resolved
  double n_train = 0;     ///< training records
  int total_steps = 0;
  int decay_steps = 1;  ///< steps between learning-rate decays
  GqcnnNormalisation norm;
  LogisticBaseline baseline;
  json fingerprint;                               ///< what a checkpoint must match to be resumed
  std::vector<std::size_t> positives, negatives;  ///< training records of each class
  double train_rate = 0;                          ///< positive rate of the training records
  torch::Tensor class_weights, collision_weights, quality_weights;
};

RunSetup SetUpRun(const GqcnnTrainOptions& o, const GqcnnSet& set, GqcnnSplit split) {
  RunSetup r;
  r.split = std::move(split);
  r.n_train = static_cast<double>(r.split.train.size());
  r.total_steps = o.steps > 0
                      ? o.steps
                      : static_cast<int>(std::min(1e8, std::ceil(o.epochs * r.n_train / o.batch)));
  r.opt = o;
  r.opt.steps = r.total_steps;
  if (r.opt.eval_every == 0) r.opt.eval_every = std::max(1, (r.total_steps + 19) / 20);
  if (r.opt.checkpoint_every == 0) r.opt.checkpoint_every = r.opt.eval_every;
  r.decay_steps =
      std::max(1, static_cast<int>(std::lround(o.decay_every_epochs * r.n_train / o.batch)));

  r.norm = ComputeNormalisation(set, r.split.train);
  r.baseline = FitLogisticBaseline(set, r.split.train);
  r.fingerprint = RunFingerprint(r.opt, r.norm, r.split.train.size());
  for (const std::size_t i : r.split.train) {
    (set.labels[i] ? r.positives : r.negatives).push_back(i);
  }
  r.train_rate = PositiveRate(set.labels, r.split.train);
  r.class_weights = BalancedClassWeights(r.train_rate);
  if (o.network.factored) {
    r.collision_weights = BalancedClassWeights(PositiveRate(set.collision_free, r.split.train));
    r.quality_weights = BalancedClassWeights(PositiveRate(set.quality_labels, r.split.train));
  }
  return r;
}

/// The model card written beside the best model: architecture, normalisation, data, split,
/// training settings and progress (`seconds` of training so far), validation, baseline.
json MakeCard(const GqcnnTrainOptions& o, const GqcnnSet& set, const RunSetup& r, GqcnnNet& net,
              const GqcnnValidation& best, int steps_done, double seconds) {
  std::size_t validation_positives = 0;
  for (const std::size_t i : r.split.validation) validation_positives += set.labels[i];
  json validation_objects = json::array();
  for (const auto k : r.split.validation_objects) validation_objects.push_back(set.object_names[k]);
  json card = {
      {"model", "gqcnn"},
      {"format_version", kGqcnnFormatVersion},
      {"architecture", GqcnnConfigJson(r.opt.network)},
      {"parameters", CountParameters(*net)},
      {"normalisation",
       {{"im_mean_m", r.norm.im_mean_m},
        {"im_std_m", r.norm.im_std_m},
        {"pose_mean_m", r.norm.pose_mean_m},
        {"pose_std_m", r.norm.pose_std_m},
        {"missing_pixels", "0 after normalisation (the training mean)"}}},
      {"data",
       {{"dirs", set.sources},
        {"records", set.size()},
        {"positives", set.positives},
        {"positive_rate", static_cast<double>(set.positives) / static_cast<double>(set.size())},
        {"objects", set.object_names.size()},
        {"images", set.images()}}},
      {"split",
       {{"by", "object"},
        {"seed", o.seed},
        {"validation_fraction", o.validation_fraction},
        {"admitted_only", o.admitted_only},
        {"train_records", r.split.train.size()},
        {"validation_records", r.split.validation.size()},
        {"train_positive_rate", r.train_rate},
        {"validation_positive_rate", static_cast<double>(validation_positives) /
                                         static_cast<double>(r.split.validation.size())},
        {"validation_objects", validation_objects}}},
      {"training",
       {{"optimizer", OptimizerName(o.optimizer)},
        {"learning_rate", BaseLearningRate(o)},
        {"momentum", o.optimizer == GqcnnOptimizer::kSgd ? o.momentum : 0.0},
        {"weight_decay", o.weight_decay},
        {"lr_decay", o.lr_decay},
        {"decay_every_steps", r.decay_steps},
        {"batch", o.batch},
        {"balance", BalanceName(o.balance)},
        {"augmentation", AugmentationJson(o.augmentation)},
        {"total_steps", r.total_steps},
        {"epochs", r.total_steps * static_cast<double>(o.batch) / r.n_train},
        {"steps_done", steps_done},
        {"best_step", best.step},
        {"seconds", seconds},
        {"threads", torch::get_num_threads()}}},
      {"validation", ValidationJson(best)},
      {"baseline", r.baseline.ToJson()}};
  return card;
}

/// One step's training batch: crops, grasp depths, clearances and labels (the factored network's
/// two labels too).
struct Batch {
  std::vector<float> crops, depths, clearances;
  std::vector<std::int64_t> labels;
  std::vector<float> collision_free, quality;
  explicit Batch(int size)
      : crops(static_cast<std::size_t>(size) * kPixels),
        depths(static_cast<std::size_t>(size)),
        clearances(static_cast<std::size_t>(size) * 3),
        labels(static_cast<std::size_t>(size)),
        collision_free(static_cast<std::size_t>(size)),
        quality(static_cast<std::size_t>(size)) {}
};

/// Draws step `step`'s records from the stream seeded with (seed, step), balanced by class when
/// the options say so, and augments their crops from the same stream.
void DrawBatch(const GqcnnTrainOptions& o, const GqcnnSet& set, const RunSetup& r, int step,
               Batch* b) {
  std::mt19937_64 rng(MixSeed(o.seed, static_cast<std::uint64_t>(step)));
  std::uniform_int_distribution<std::size_t> pick_train(0, r.split.train.size() - 1);
  std::uniform_int_distribution<std::size_t> pick_pos(0, r.positives.size() - 1);
  std::uniform_int_distribution<std::size_t> pick_neg(0, r.negatives.size() - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < o.batch; ++k) {
    std::size_t i;
    if (o.balance == GqcnnBalance::kBalancedSampling) {
      i = unit(rng) < 0.5 ? r.positives[pick_pos(rng)] : r.negatives[pick_neg(rng)];
    } else {
      i = r.split.train[pick_train(rng)];
    }
    float* crop = b->crops.data() + static_cast<std::size_t>(k) * kPixels;
    std::copy_n(set.crop(i), kPixels, crop);
    AugmentCrop(crop, o.augmentation, rng);
    b->depths[static_cast<std::size_t>(k)] = set.grasp_depths_m[i];
    // The clearances are the least over both fingers, so the crop's symmetries keep them.
    if (o.network.clearance_inputs) {
      std::copy_n(set.clearance(i), 3, b->clearances.data() + static_cast<std::size_t>(k) * 3);
    }
    b->labels[static_cast<std::size_t>(k)] = set.labels[i];
    if (o.network.factored) {
      b->collision_free[static_cast<std::size_t>(k)] = set.collision_free[i];
      b->quality[static_cast<std::size_t>(k)] = set.quality_labels[i];
    }
  }
}

/// One optimiser step on `b` at step `step`'s learning rate; its loss and batch accuracy.
/// kInternal when the loss is not finite.
core::Result<GqcnnStepRecord> OptimiseStep(const GqcnnTrainOptions& o, const RunSetup& r, State& s,
                                           const Batch& b, int step) {
  torch::Tensor images, poses;
  NormaliseGqcnnInputs(b.crops.data(), b.depths.data(), b.clearances.data(), o.batch, o.network,
                       r.norm, &images, &poses);
  const torch::Tensor target = torch::tensor(b.labels, torch::kInt64);
  const double lr =
      BaseLearningRate(o) * std::pow(o.lr_decay, static_cast<double>((step - 1) / r.decay_steps));
  for (auto& group : s.opt->param_groups()) group.options().set_lr(lr);
  s.opt->zero_grad();
  const torch::Tensor logits = s.net->forward(images, poses);
  const bool weighted = o.balance == GqcnnBalance::kWeightedLoss;
  torch::Tensor loss =
      GqcnnSuccessLoss(logits, target, o.network, weighted ? r.class_weights : torch::Tensor());
  if (o.network.factored) {
    // Each factor learns from its own label too: a failure says which part failed.
    auto factor_loss = [&](int column, const std::vector<float>& y, const torch::Tensor& w) {
      const torch::Tensor t = torch::tensor(y, torch::kFloat32);
      const torch::Tensor x = logits.select(1, column);
      if (!weighted) return torch::binary_cross_entropy_with_logits(x, t);
      const torch::Tensor per = w[0] * (1.0 - t) + w[1] * t;
      return (per * torch::binary_cross_entropy_with_logits(x, t, {}, {}, at::Reduction::None))
                 .sum() /
             per.sum();
    };
    loss = loss + factor_loss(0, b.collision_free, r.collision_weights) +
           factor_loss(1, b.quality, r.quality_weights);
  }
  loss.backward();
  s.opt->step();
  const torch::Tensor predicted = GqcnnSuccessProbability(logits, o.network).ge(0.5);
  GqcnnStepRecord record{
      step, loss.item<double>(),
      predicted.eq(target.to(torch::kBool)).to(torch::kFloat64).mean().item<double>(), lr};
  if (!std::isfinite(record.loss)) {
    return MakeError(ErrorCode::kInternal,
                     "training diverged at step " + std::to_string(step) +
                         " (non-finite loss); try a lower --lr",
                     "steps");
  }
  return record;
}

}  // namespace

core::Result<GqcnnTrainReport> TrainGqcnn(const GqcnnTrainOptions& o, const GqcnnSet& set,
                                          const GqcnnProgress& progress) {
  auto split = CheckedSplit(o, set);
  if (!split.ok()) return split.error();
  const RunSetup r = SetUpRun(o, set, std::move(split).value());

  torch::manual_seed(MixSeed(o.seed, 0));
  State s(r.opt);
  Progress p;
  const std::filesystem::path ckpt = CheckpointPath(o.out);
  if (o.resume && std::filesystem::exists(ckpt)) {
    auto loaded = LoadCheckpoint(ckpt, s, r.fingerprint);
    if (!loaded.ok()) return loaded.error();
    p = std::move(loaded.value());
  }
  std::error_code ec;
  if (o.out.has_parent_path()) std::filesystem::create_directories(o.out.parent_path(), ec);

  GqcnnTrainReport report;
  report.start_step = p.step;
  report.total_steps = r.total_steps;
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  auto save_best = [&](const GqcnnValidation& v) {
    json card = MakeCard(o, set, r, s.net, v, v.step, p.seconds + elapsed());
    SaveGqcnnNet(o.out, s.net, r.opt.network, r.norm, card);
    card["model_file_bytes"] = std::filesystem::file_size(o.out);
    std::ofstream(GqcnnCardPath(o.out)) << card.dump(2) << "\n";
    report.card = card;
  };

  s.net->train();
  const int last_step =
      o.stop_after_step > 0 ? std::min(o.stop_after_step, r.total_steps) : r.total_steps;
  const int run_start = p.step;
  Batch batch(o.batch);
  while (p.step < last_step) {
    const int step = ++p.step;
    DrawBatch(o, set, r, step, &batch);
    auto record = OptimiseStep(o, r, s, batch, step);
    if (!record.ok()) return record.error();
    p.history.push_back(record.value());
    const GqcnnValidation* validated = nullptr;
    if (step % r.opt.eval_every == 0 || step == r.total_steps) {
      p.validations.push_back(Validate(s.net, o.network, set, r.split.validation, r.norm, step));
      validated = &p.validations.back();
      if (!p.has_best || validated->balanced_accuracy > p.best.balanced_accuracy) {
        p.best = *validated;
        p.has_best = true;
        save_best(p.best);
      }
    }
    if (progress) progress(record.value(), validated, r.total_steps);
    if (step % r.opt.checkpoint_every == 0 || step == last_step) {
      const double seconds_before = p.seconds;
      p.seconds += elapsed();
      SaveCheckpoint(ckpt, s, p, r.fingerprint);
      p.seconds = seconds_before;
      WriteCurves(o.out, p.history, p.validations);
    }
  }
  report.end_step = p.step;
  report.seconds = elapsed();
  report.crops_per_second =
      report.seconds > 0 ? (p.step - run_start) * static_cast<double>(o.batch) / report.seconds : 0;
  report.history = p.history;
  report.validations = p.validations;
  report.best = p.best;
  if (report.card.is_null() && p.has_best && std::filesystem::exists(GqcnnCardPath(o.out))) {
    std::ifstream in(GqcnnCardPath(o.out));
    report.card = json::parse(in, nullptr, false);
  }
  return report;
}

}  // namespace softgrasp::models
