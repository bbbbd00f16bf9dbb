#include "tools/train/gqcnn_cli.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <random>
#include <span>

#include "service/cli/args.h"
#include "service/cli/files.h"
#include "service/cli/progress.h"
#include "service/gqcnn/clearance.h"
#include "service/models/gqcnn_model.h"
#include "service/models/gqcnn_network.h"
#include "service/models/network.h"
#include "service/models/stiffness_model.h"
#include "tools/train/cli_common.h"
#include "tools/train/gqcnn_metrics.h"
#include "train/gqcnn_trainer.h"
#include "train/trainer.h"

namespace softgrasp::tools {

const char* const kGqcnnUsage =
    "       softgrasp-train gqcnn --data DIR [--data DIR2 ...] --out MODEL.pt\n"
    "                             [--steps N | --epochs E] [--batch B] [--lr LR]\n"
    "                             [--optimizer adam|sgd] [--balance weight|sample|none]\n"
    "                             [--seed S] [--resume] [--eval-every N] [--checkpoint-every N]\n"
    "                             [--validation-fraction F] [--conv1-channels C]\n"
    "                             [--conv2-channels C] [--fc-units U] [--no-augmentation]\n"
    "                             [--no-gain] [--factored] [--clearance-inputs]\n"
    "                             [--admitted-only] [--threads T]\n"
    "  Trains the GQ-CNN on softgrasp-sim gqcnn-dataset directories (object-wise 80/20 split,\n"
    "  Dex-Net 2.0 augmentations). Writes MODEL.pt (best validation balanced accuracy), its card\n"
    "  MODEL.json, MODEL.ckpt (resumable), MODEL_loss.csv/.png and MODEL_accuracy.png.\n"
    "  --clearance-inputs feeds the stored gripper clearances (jaws, palm, floor) to the pose\n"
    "  stream besides the grasp depth.\n"
    "  --admitted-only trains and validates on the grasps whose stored gripper clearance the\n"
    "  planner admits (the ones strategy=gqcnn lets the network score).\n"
    "       softgrasp-train gqcnn-eval --model MODEL.pt --data DIR [--data DIR2 ...]\n"
    "                                  [--json OUT] [--threshold P] [--resamples N] [--threads T]\n"
    "                                  [--predictions OUT.csv]\n"
    "                                  [--calibrate-on DIR ... | --cross-calibrate]\n"
    "  Accuracy, balanced accuracy, precision, recall and precision of the top-ranked grasp per\n"
    "  image, with 95 % intervals resampling objects, for the model and two baselines (majority\n"
    "  class; logistic regression on two hand features fitted on the model's training split).\n"
    "  On datasets with gripper clearances, also as strategy=gqcnn classifies: a grasp is\n"
    "  positive when the clearance check admits it and P >= threshold (gqcnn_with_clearance),\n"
    "  against the check alone.\n"
    "  --calibrate-on chooses the threshold (instead of --threshold) where the network's balanced\n"
    "  accuracy is highest on other labelled objects, e.g. real meshes apart from --data.\n"
    "  --cross-calibrate classifies each --data set at the threshold chosen so on the other\n"
    "  --data sets, and reports the figures of all of them together.\n"
    "  --predictions writes one row per grasp (record, object, image, label, both probabilities)\n"
    "  in the order the records are read (shard by shard).\n"
    "       softgrasp-train gqcnn-calibrate --model MODEL.pt --data DIR [--data DIR2 ...]\n"
    "                                       --out OUT.pt [--threads T]\n"
    "  Chooses the decision threshold on labelled objects of the kind the network will be used\n"
    "  on (as gqcnn-eval --calibrate-on does) and writes the model with it in its card\n"
    "  (OUT.pt and OUT.json; the service reports each grasp's predicted_success with it).\n"
    "       softgrasp-train gqcnn-bench [--model MODEL.pt] [--conv1-channels C]\n"
    "                                   [--conv2-channels C] [--fc-units U] [--threads T]\n"
    "  Measures Predict for 250 and 1000 crops and training throughput (crops/s).\n";

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Its messages name no command: "softgrasp-train: MESSAGE".
constexpr std::string_view kCommand = "";

void ReadNetworkOptions(cli::Args& args, models::GqcnnNetConfig* c) {
  args.Int("--conv1-channels", 1, 1024, &c->conv1_channels);
  args.Int("--conv2-channels", 1, 1024, &c->conv2_channels);
  args.Int("--conv1-1-kernel", 1, 15, &c->conv1_1_kernel);
  args.Int("--conv1-2-kernel", 1, 15, &c->conv1_2_kernel);
  int fc = 0;
  if (args.Int("--fc-units", 1, 1024, &fc)) c->fc3_units = c->fc4_units = fc;
  if (args.Flag("--no-lrn")) c->local_response_norm = false;
  if (args.Flag("--factored")) c->factored = true;
  if (args.Flag("--clearance-inputs")) c->clearance_inputs = true;
  if ((c->conv1_1_kernel % 2) == 0 || (c->conv1_2_kernel % 2) == 0) {
    args.Fail("--conv1-1-kernel and --conv1-2-kernel must be odd", "--conv1-1-kernel");
  }
}

core::Result<models::GqcnnSet> Load(const std::vector<std::string>& dirs) {
  std::vector<fs::path> paths(dirs.begin(), dirs.end());
  std::unique_ptr<cli::ProgressBar> bar;
  auto set = models::LoadGqcnnSet(paths, [&](int done, int total) {
    if (!bar) bar = std::make_unique<cli::ProgressBar>("loading shards", total);
    bar->Update(done);
  });
  bar.reset();
  return set;
}

}  // namespace

int RunGqcnnTrain(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  models::GqcnnTrainOptions o;
  std::string out;
  int threads = 2;
  const std::vector<std::string> data = args.All("--data");
  args.Required("--out", "MODEL", &out);
  const bool has_steps = args.Int("--steps", 1, 100000000, &o.steps);
  const bool has_epochs = args.Number("--epochs", cli::Bounds::Above(0), &o.epochs);
  args.Int("--batch", 1, 4096, &o.batch);
  args.Number("--lr", cli::Bounds::Above(0), &o.learning_rate);
  args.Choice<models::GqcnnOptimizer>(
      "--optimizer",
      {{"adam", models::GqcnnOptimizer::kAdam}, {"sgd", models::GqcnnOptimizer::kSgd}},
      &o.optimizer);
  args.Choice<models::GqcnnBalance>("--balance",
                                    {{"weight", models::GqcnnBalance::kWeightedLoss},
                                     {"sample", models::GqcnnBalance::kBalancedSampling},
                                     {"none", models::GqcnnBalance::kNone}},
                                    &o.balance);
  args.Int("--seed", 0, cli::kNoLimit, &o.seed);
  args.Int("--eval-every", 1, 100000000, &o.eval_every);
  args.Int("--checkpoint-every", 1, 100000000, &o.checkpoint_every);
  args.Number("--validation-fraction", cli::Bounds{0, 1, true, true}, &o.validation_fraction);
  ReadNetworkOptions(args, &o.network);
  if (args.Flag("--no-augmentation")) {
    o.augmentation.multiplicative = false;
    o.augmentation.gp_rate = 0;
    o.augmentation.symmetries = false;
  }
  if (args.Flag("--no-gain")) o.augmentation.multiplicative = false;
  o.admitted_only = args.Flag("--admitted-only");
  args.Int("--threads", 1, 256, &threads);
  o.resume = args.Flag("--resume");
  if (data.empty()) args.Fail("--data DIR is required (repeat it for more datasets)", "--data");
  if (has_steps && has_epochs) args.Fail("give --steps or --epochs, not both", "--steps");
  if (const auto error = args.Finish()) return Fail(kCommand, error->message);
  if (has_steps) o.epochs = 0;
  o.out = out;

  models::SetTorchThreads(threads);
  const auto t0 = std::chrono::steady_clock::now();
  auto set = Load(data);
  if (!set.ok()) return FailError(kCommand, set.error());
  std::cout << "loaded " << set.value().size() << " grasps (" << set.value().positives
            << " positive), " << set.value().images() << " images, "
            << set.value().object_names.size() << " objects in " << SecondsSince(t0)
            << " s; threads " << threads << std::endl;

  const bool tty = isatty(STDERR_FILENO) != 0;
  std::unique_ptr<cli::ProgressBar> bar;
  const auto t_train = std::chrono::steady_clock::now();
  int first_step = -1;
  auto report = models::TrainGqcnn(
      o, set.value(),
      [&](const models::GqcnnStepRecord& r, const models::GqcnnValidation* v, int total) {
        if (!bar) bar = std::make_unique<cli::ProgressBar>("training", total);
        if (first_step < 0) first_step = r.step;
        bar->Update(r.step);
        const double s = SecondsSince(t_train);
        const double per_step = s / (r.step - first_step + 1);
        if ((!tty && (r.step % 100 == 0 || r.step == total)) || v != nullptr) {
          std::printf("step %d/%d  loss %.4f  acc %.3f  lr %.2e  %.0f crops/s  eta %.1f min",
                      r.step, total, r.loss, r.accuracy, r.learning_rate, o.batch / per_step,
                      per_step * (total - r.step) / 60.0);
          if (v != nullptr) {
            std::printf("  | val loss %.4f  acc %.3f  bal.acc %.3f  prec %.3f  rec %.3f", v->loss,
                        v->accuracy, v->balanced_accuracy, v->precision, v->recall);
          }
          std::printf("\n");
          std::fflush(stdout);
        }
      });
  bar.reset();
  if (!report.ok()) return FailError(kCommand, report.error());
  const auto& rep = report.value();
  std::cout << "trained steps " << rep.start_step << " -> " << rep.end_step << " of "
            << rep.total_steps << " in " << rep.seconds << " s (" << rep.crops_per_second
            << " crops/s); best validation balanced accuracy " << rep.best.balanced_accuracy
            << " at step " << rep.best.step << "; model " << o.out.string() << ", card "
            << models::GqcnnCardPath(o.out).string() << ", checkpoint "
            << models::CheckpointPath(o.out).string() << ", curves "
            << models::LossPngPath(o.out).string() << std::endl;
  return 0;
}

namespace {

/// What each classifier that gqcnn-eval reports says of every grasp of a set: P(success).
struct SetScores {
  std::vector<float> gqcnn, logistic, majority;
  /// With gripper clearances (empty without): the planner never scores a grasp its clearance
  /// check drops, so such a grasp is a negative (probability 0, below every threshold and every
  /// admitted grasp's rank); the check alone says 1 or 0.
  std::vector<float> gqcnn_gated, logistic_gated, check;
};

constexpr const char* kPredateClearances =
    "the model takes gripper clearances, and these datasets predate them (regenerate them with "
    "softgrasp-sim gqcnn-dataset)";

/// The network's P(success) for every grasp of a set (its stored clearances when it takes them).
std::vector<float> PredictSet(const models::GqcnnModel& model, const models::GqcnnSet& s) {
  return model.Predict(
      s.crops_depth_m, s.grasp_depths_m,
      model.takes_clearances() ? std::span<const float>(s.clearances_m) : std::span<const float>());
}

SetScores ScoreSet(const models::GqcnnModel& model, const models::LogisticBaseline& baseline,
                   const models::GqcnnSet& s) {
  SetScores r;
  r.gqcnn = PredictSet(model, s);
  r.logistic.resize(s.size());
  r.majority.assign(s.size(), static_cast<float>(baseline.train_positive_rate));
  for (std::size_t i = 0; i < s.size(); ++i) {
    r.logistic[i] = static_cast<float>(
        baseline.Predict(models::GqcnnHandFeatures(s.crop(i), s.grasp_depths_m[i], s.width_px[i])));
  }
  if (s.clearances_measured) {
    auto gate = [&](const std::vector<float>& p) {
      std::vector<float> gated(s.size());
      for (std::size_t i = 0; i < s.size(); ++i) gated[i] = s.admitted[i] ? p[i] : 0.0F;
      return gated;
    };
    r.gqcnn_gated = gate(r.gqcnn);
    r.logistic_gated = gate(r.logistic);
    r.check.assign(s.admitted.begin(), s.admitted.end());
  }
  return r;
}

/// How the decision threshold is set: fixed, chosen on other labelled data (--calibrate-on), or
/// per --data set on the other --data sets (--cross-calibrate). Each classifier is calibrated on
/// its own probabilities.
struct ThresholdPolicy {
  double fixed = 0.5;
  const models::GqcnnSet* calibration = nullptr;  ///< --calibrate-on's data
  const SetScores* calibration_scores = nullptr;
  bool cross = false;
};

/// Per record of `s`, the threshold of the classifier whose probabilities on `s` are `p` and on
/// the calibration data `cal_p` (empty when the policy has none); `note` gets the choice.
/// @throws std::invalid_argument when the data chosen on lacks a class.
std::vector<double> Thresholds(const ThresholdPolicy& policy, const models::GqcnnSet& s,
                               std::span<const float> p, std::span<const float> cal_p,
                               nlohmann::json* note) {
  if (policy.calibration) {
    const ThresholdChoice c = ChooseBalancedAccuracyThreshold(policy.calibration->labels, cal_p);
    *note = {{"threshold", c.threshold}, {"calibration_balanced_accuracy", c.balanced_accuracy}};
    return std::vector<double>(s.size(), c.threshold);
  }
  if (!policy.cross) {
    *note = {{"threshold", policy.fixed}};
    return std::vector<double>(s.size(), policy.fixed);
  }
  std::vector<double> thresholds(s.size());
  *note = {{"thresholds_per_set", nlohmann::json::array()}};
  for (std::uint32_t d = 0; d < s.sources.size(); ++d) {
    std::vector<std::uint8_t> labels;
    std::vector<float> others;
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (s.object_sources[s.object_keys[i]] == d) continue;
      labels.push_back(s.labels[i]);
      others.push_back(p[i]);
    }
    const ThresholdChoice c = ChooseBalancedAccuracyThreshold(labels, others);
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (s.object_sources[s.object_keys[i]] == d) thresholds[i] = c.threshold;
    }
    (*note)["thresholds_per_set"].push_back(
        {{"data", s.sources[d]},
         {"threshold", c.threshold},
         {"balanced_accuracy_on_the_other_sets", c.balanced_accuracy}});
  }
  return thresholds;
}

/// gqcnn-eval's command line.
struct GqcnnEvalOptions {
  std::string model_path, json_out, predictions_out;
  std::vector<std::string> data;
  std::vector<std::string> calibration;  ///< --calibrate-on
  double threshold = 0.5;                ///< --threshold
  bool cross = false;                    ///< --cross-calibrate
  int threads = 2, resamples = 1000;
  std::uint64_t seed = 1;
};

core::Result<GqcnnEvalOptions> ParseGqcnnEvalOptions(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  GqcnnEvalOptions o;
  args.Required("--model", "MODEL", &o.model_path);
  o.data = args.All("--data");
  args.Text("--json", &o.json_out);
  args.Text("--predictions", &o.predictions_out);
  const bool has_threshold = args.Number("--threshold", cli::Bounds::Closed(0, 1), &o.threshold);
  o.calibration = args.All("--calibrate-on");
  o.cross = args.Flag("--cross-calibrate");
  args.Int("--resamples", 10, 1000000, &o.resamples);
  args.Int("--seed", 0, cli::kNoLimit, &o.seed);
  args.Int("--threads", 1, 256, &o.threads);
  if (o.data.empty()) args.Fail("--data DIR is required (repeat it for more datasets)", "--data");
  if (int{has_threshold} + int{!o.calibration.empty()} + int{o.cross} > 1) {
    args.Fail("give one of --threshold, --calibrate-on and --cross-calibrate, not two",
              "--calibrate-on");
  }
  if (o.cross && o.data.size() < 2) {
    args.Fail("--cross-calibrate needs two or more --data sets (each is calibrated on the others)",
              "--cross-calibrate");
  }
  for (const std::string& c : o.calibration) {
    std::error_code ec;
    for (const std::string& d : o.data) {
      if (fs::equivalent(fs::path(c), fs::path(d), ec)) {
        args.Fail("--calibrate-on " + c + " is also --data: calibrate on other objects",
                  "--calibrate-on");
      }
    }
  }
  if (const auto error = args.Finish()) return *error;
  return o;
}

/// What gqcnn-eval reads before it scores: the model, the baseline in its card, the records it
/// is evaluated on and those a threshold is chosen on (--calibrate-on) with their scores.
struct GqcnnEvalInputs {
  models::GqcnnModel model;
  models::LogisticBaseline baseline;
  models::GqcnnSet calibration;  ///< empty without --calibrate-on
  SetScores calibration_scores;
  models::GqcnnSet set;
};

/// An error that names no field: FailError prints its message alone.
core::Error MessageOnly(const std::string& message) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, message);
}

core::Result<GqcnnEvalInputs> LoadGqcnnEvalInputs(const GqcnnEvalOptions& o) {
  auto model = models::GqcnnModel::Load(o.model_path);
  if (!model.ok()) return model.error();
  const json& card = model.value().Card();
  auto baseline = models::LogisticBaseline::FromJson(card.value("baseline", json::object()));
  if (!baseline.ok()) return baseline.error();
  const bool takes_clearances = model.value().takes_clearances();
  models::GqcnnSet calibration;
  SetScores calibration_scores;
  if (!o.calibration.empty()) {
    auto loaded = Load(o.calibration);
    if (!loaded.ok()) return loaded.error();
    if (takes_clearances && !loaded.value().clearances_measured) {
      return MessageOnly(kPredateClearances);
    }
    calibration = std::move(loaded).value();
    calibration_scores = ScoreSet(model.value(), baseline.value(), calibration);
  }
  auto set = Load(o.data);
  if (!set.ok()) return set.error();
  if (takes_clearances && !set.value().clearances_measured) return MessageOnly(kPredateClearances);
  if (!o.calibration.empty() &&
      set.value().clearances_measured != calibration.clearances_measured) {
    return MessageOnly(
        "--calibrate-on data and --data differ in whether they carry gripper clearances");
  }
  return GqcnnEvalInputs{std::move(model).value(), baseline.value(), std::move(calibration),
                         std::move(calibration_scores), std::move(set).value()};
}

/// --predictions: one row per grasp (record, object, image, label, both probabilities, whether
/// the clearance check admits it) in the order the records were read.
std::optional<core::Error> WritePredictions(const std::string& path, const models::GqcnnSet& s,
                                            const SetScores& scores) {
  std::string csv = "record,object,image,label,p_gqcnn,p_logistic,admitted\n";
  for (std::size_t i = 0; i < s.size(); ++i) {
    csv += std::to_string(i) + "," + s.object_names[s.object_keys[i]] + "," +
           std::to_string(s.image_keys[i]) + "," + std::to_string(int{s.labels[i]}) + "," +
           std::to_string(scores.gqcnn[i]) + "," + std::to_string(scores.logistic[i]) + "," +
           (s.clearances_measured ? std::to_string(int{s.admitted[i]}) : "") + "\n";
  }
  return cli::WriteFile(path, csv, cli::Parents::kCreate);
}

/// One classifier's figures at its threshold(s), which are written beside them.
/// @throws std::invalid_argument when the data a threshold is chosen on lacks a class.
json ClassifierJson(const GqcnnEvalOptions& o, const ThresholdPolicy& policy,
                    const models::GqcnnSet& s, const SetScores& scores,
                    std::vector<float> SetScores::*which) {
  json note;
  const std::vector<double> thresholds = Thresholds(
      policy, s, scores.*which,
      policy.calibration_scores ? std::span<const float>(policy.calibration_scores->*which)
                                : std::span<const float>(),
      &note);
  GqcnnScored scored{s.labels, scores.*which, s.object_keys, s.image_keys, thresholds};
  std::vector<GqcnnObjectCounts> per_object;
  const GqcnnMetrics m = ComputeGqcnnMetrics(scored, policy.fixed, &per_object);
  json j = GqcnnMetricsJson(m, BootstrapGqcnnMetrics(per_object, o.resamples, o.seed));
  j.update(note);
  return j;
}

/// The --data sets that are also among the model's training data (its card's data.dirs).
json TrainingOverlap(const std::vector<std::string>& data, const json& train_dirs) {
  json overlap = json::array();
  for (const std::string& d : data) {
    std::error_code ec;
    for (const auto& t : train_dirs) {
      if (t.is_string() && fs::equivalent(fs::path(d), fs::path(t.get<std::string>()), ec)) {
        overlap.push_back(d);
      }
    }
  }
  return overlap;
}

/// How the thresholds were set: the fixed one, or what they were chosen on and by which rule.
json ThresholdJson(const GqcnnEvalOptions& o, const ThresholdPolicy& policy) {
  json threshold_json = policy.fixed;
  if (policy.calibration) {
    threshold_json = {{"chosen_on", o.calibration},
                      {"chosen_on_grasps", policy.calibration->size()},
                      {"chosen_on_objects", policy.calibration->object_names.size()}};
  } else if (policy.cross) {
    threshold_json = {{"chosen_on", "for each --data set, the other --data sets"}};
  }
  if (policy.calibration || policy.cross) {
    threshold_json["rule"] =
        "per classifier, the threshold among 0.01, 0.02, ..., 0.99 with its highest balanced "
        "accuracy there (of equal ones, the nearest 0.5); each classifier's figures give theirs";
  }
  return threshold_json;
}

/// The clearance check on a set with gripper clearances: its rule, the share of grasps it admits
/// and how often it agrees with the collision labels.
json ClearanceJson(const models::GqcnnSet& s) {
  std::size_t agree = 0, admitted_count = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    agree += s.admitted[i] == s.collision_free[i] ? 1 : 0;
    admitted_count += s.admitted[i];
  }
  const gqcnn::ClearanceRule rule;
  return {{"rule",
           {{"fingertip_reach_m", rule.fingertip_reach_m},
            {"min_height_m", rule.min_height_m},
            {"floor_noise_m", rule.floor_noise_m}}},
          {"admitted_rate", static_cast<double>(admitted_count) / static_cast<double>(s.size())},
          {"agreement_with_collision_labels",
           static_cast<double>(agree) / static_cast<double>(s.size())}};
}

/// gqcnn-eval's report: the network's figures and its baselines' (the majority class, the
/// logistic regression on hand features; with gripper clearances also as strategy=gqcnn
/// classifies and the check alone), each with 95 % intervals. Errors (the message alone) when
/// the data a threshold is chosen on lacks a class.
core::Result<json> GqcnnEvalReport(const GqcnnEvalOptions& o, const GqcnnEvalInputs& in,
                                   const ThresholdPolicy& policy, const SetScores& scores,
                                   double predict_s) {
  const models::GqcnnSet& s = in.set;
  const json& card = in.model.Card();
  const auto score = [&](std::vector<float> SetScores::*which) {
    return ClassifierJson(o, policy, s, scores, which);
  };
  json train_dirs =
      card.contains("data") ? card["data"].value("dirs", json::array()) : json::array();
  const json overlap = TrainingOverlap(o.data, train_dirs);
  json result;
  try {
    result = {{"model", o.model_path},
              {"model_description", in.model.description()},
              {"trained_on", train_dirs},
              {"data", o.data},
              {"threshold", ThresholdJson(o, policy)},
              {"bootstrap",
               {{"unit", "object"}, {"resamples", o.resamples}, {"seed", o.seed}, {"level", 0.95}}},
              {"predict_seconds", predict_s},
              {"predict_crops_per_second",
               predict_s > 0 ? static_cast<double>(s.size()) / predict_s : 0.0},
              {"gqcnn", score(&SetScores::gqcnn)},
              {"baselines",
               {{"majority_class",
                 {{"description", "constant P = the training split's positive rate (" +
                                      std::to_string(in.baseline.train_positive_rate) +
                                      "): predicts the majority class; every grasp ties, so its "
                                      "top-grasp precision is each image's positive rate (ties are "
                                      "broken at random, in expectation)"},
                  {"metrics", score(&SetScores::majority)}}},
                {"logistic_hand_features",
                 {{"description",
                   "logistic regression on (shallower jaw-tip depth - centre depth, grasp "
                   "depth - centre depth), balanced class weights, fitted on the model's "
                   "training split"},
                  {"model", in.baseline.ToJson()},
                  {"metrics", score(&SetScores::logistic)}}}}}};
    if (s.clearances_measured) {
      result["clearance"] = ClearanceJson(s);
      // As strategy=gqcnn classifies: only the grasps the clearance check admits are scored.
      result["gqcnn_with_clearance"] = score(&SetScores::gqcnn_gated);
      result["baselines"]["clearance_check_alone"] = {
          {"description", "P = 1 for the grasps the clearance check admits, 0 for the others"},
          {"metrics", score(&SetScores::check)}};
      result["baselines"]["logistic_with_clearance"] = {
          {"description", "the logistic baseline on the grasps the clearance check admits"},
          {"metrics", score(&SetScores::logistic_gated)}};
    }
  } catch (const std::invalid_argument&) {
    return MessageOnly(policy.cross
                           ? "--cross-calibrate: every --data set's others need grasps that "
                             "succeed and grasps that fail"
                           : "--calibrate-on data needs grasps that succeed and grasps that fail");
  }
  if (!overlap.empty()) {
    result["warning"] = "the evaluation data includes the model's training data";
    result["overlap"] = overlap;
  }
  return result;
}

}  // namespace

int RunGqcnnEvaluate(std::vector<std::string> argv) {
  auto options = ParseGqcnnEvalOptions(std::move(argv));
  if (!options.ok()) return Fail(kCommand, options.error().message);
  const GqcnnEvalOptions& o = options.value();
  models::SetTorchThreads(o.threads);
  auto inputs = LoadGqcnnEvalInputs(o);
  if (!inputs.ok()) return FailError(kCommand, inputs.error());
  const GqcnnEvalInputs& in = inputs.value();
  ThresholdPolicy policy;
  policy.fixed = o.threshold;
  policy.cross = o.cross;
  if (!o.calibration.empty()) {
    policy.calibration = &in.calibration;
    policy.calibration_scores = &in.calibration_scores;
  }

  const auto t0 = std::chrono::steady_clock::now();
  const SetScores scores = ScoreSet(in.model, in.baseline, in.set);
  const double predict_s = SecondsSince(t0);
  if (!o.predictions_out.empty()) {
    if (auto error = WritePredictions(o.predictions_out, in.set, scores)) {
      return FailError(kCommand, *error);
    }
  }
  auto report = GqcnnEvalReport(o, in, policy, scores, predict_s);
  if (!report.ok()) return FailError(kCommand, report.error());
  const std::string text = report.value().dump(2) + "\n";
  if (!o.json_out.empty()) {
    if (auto error = cli::WriteFile(o.json_out, text, cli::Parents::kCreate)) {
      return FailError(kCommand, *error);
    }
  }
  std::cout << text;
  return 0;
}

int RunGqcnnCalibrate(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  std::string model_path, out;
  int threads = 2;
  args.Required("--model", "MODEL", &model_path);
  const std::vector<std::string> data = args.All("--data");
  args.Required("--out", "OUT", &out);
  args.Int("--threads", 1, 256, &threads);
  if (data.empty()) args.Fail("--data DIR is required (repeat it for more datasets)", "--data");
  if (const auto error = args.Finish()) return Fail(kCommand, error->message);

  models::SetTorchThreads(threads);
  auto model = models::GqcnnModel::Load(model_path);
  if (!model.ok()) return FailError(kCommand, model.error());
  auto raw = models::LoadGqcnnNet(model_path);  // written back as read (weights unflushed)
  if (!raw.ok()) return FailError(kCommand, raw.error());
  auto set = Load(data);
  if (!set.ok()) return FailError(kCommand, set.error());
  const models::GqcnnSet& s = set.value();
  if (model.value().takes_clearances() && !s.clearances_measured) {
    return Fail(kCommand, kPredateClearances);
  }
  const std::vector<float> p = PredictSet(model.value(), s);
  ThresholdChoice choice;
  try {
    choice = ChooseBalancedAccuracyThreshold(s.labels, p);
  } catch (const std::invalid_argument&) {
    return Fail(kCommand, "--data needs grasps that succeed and grasps that fail");
  }
  json card = raw.value().card;
  card["decision_threshold"] = {
      {"p", choice.threshold},
      {"chosen_on", data},
      {"grasps", s.size()},
      {"objects", s.object_names.size()},
      {"balanced_accuracy_there", choice.balanced_accuracy},
      {"rule",
       "of 0.01, 0.02, ..., 0.99, the threshold with the network's highest balanced accuracy on "
       "these grasps (of equal ones, the nearest 0.5)"}};
  std::error_code ec;
  if (const fs::path parent = fs::path(out).parent_path(); !parent.empty()) {
    fs::create_directories(parent, ec);
  }
  try {
    models::SaveGqcnnNet(out, raw.value().net, raw.value().config, raw.value().normalisation, card);
  } catch (const std::exception& e) {
    const std::string what = e.what();
    return Fail(kCommand, "cannot write " + out + ": " + what.substr(0, what.find('\n')));
  }
  // The card beside the model: the one beside --model when there is one (it may carry notes
  // added after training), with the threshold and the new file's size.
  json side = card;
  {
    std::ifstream in(models::GqcnnCardPath(model_path));
    if (in) {
      json existing = json::parse(in, nullptr, /*allow_exceptions=*/false);
      if (existing.is_object()) {
        existing["decision_threshold"] = card["decision_threshold"];
        side = existing;
      }
    }
  }
  side["model_file_bytes"] = fs::file_size(out);
  if (auto error = cli::WriteFile(models::GqcnnCardPath(out).string(), side.dump(2) + "\n",
                                  cli::Parents::kCreate)) {
    return FailError(kCommand, *error);
  }
  std::cout << "decision threshold " << choice.threshold << " (balanced accuracy "
            << choice.balanced_accuracy << " on " << s.size() << " grasps of "
            << s.object_names.size() << " objects); model " << out << ", card "
            << models::GqcnnCardPath(out).string() << std::endl;
  return 0;
}

int RunGqcnnBench(std::vector<std::string> argv) {
  cli::Args args(std::move(argv));
  std::string model_path;
  int threads = 2, repeats = 5, batch = 64;
  models::GqcnnNetConfig config;
  args.Text("--model", &model_path);
  ReadNetworkOptions(args, &config);
  args.Int("--threads", 1, 256, &threads);
  args.Int("--repeats", 1, 1000, &repeats);
  args.Int("--batch", 1, 4096, &batch);
  if (const auto error = args.Finish()) return Fail(kCommand, error->message);
  models::SetTorchThreads(threads);
  const fs::path tmp =
      fs::temp_directory_path() / ("gqcnn-bench-" + std::to_string(getpid()) + ".pt");
  if (!model_path.empty()) {
    auto loaded = models::LoadGqcnnNet(model_path);
    if (!loaded.ok()) return FailError(kCommand, loaded.error());
    config = loaded.value().config;
  } else {
    models::GqcnnNet net(config);
    models::InitGqcnnWeights(net);
    models::SaveGqcnnNet(tmp, net, config, {0.6, 0.05, 0.6, 0.05}, json::object());
    model_path = tmp.string();
  }
  auto model = models::GqcnnModel::Load(model_path);
  if (model_path == tmp.string()) fs::remove(tmp);
  if (!model.ok()) return FailError(kCommand, model.error());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> depth(0.55f, 0.7f);
  json result = {{"model", model.value().description()}, {"threads", threads}};
  for (const int n : {1, 250, 1000}) {
    std::vector<float> crops(static_cast<std::size_t>(n) * 1024),
        depths(static_cast<std::size_t>(n)), clearances;
    for (float& v : crops) v = depth(rng);
    for (float& v : depths) v = depth(rng);
    if (model.value().takes_clearances()) {
      clearances.resize(static_cast<std::size_t>(n) * 3);
      std::uniform_real_distribution<float> clearance(-0.05f, 0.05f);
      for (float& v : clearances) v = clearance(rng);
    }
    (void)model.value().Predict(crops, depths, clearances);  // warm-up
    std::vector<double> ms;
    for (int r = 0; r < repeats; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      (void)model.value().Predict(crops, depths, clearances);
      ms.push_back(MillisecondsSince(t0));
    }
    std::sort(ms.begin(), ms.end());
    result["predict_ms_median"][std::to_string(n)] = ms[ms.size() / 2];
  }
  // Training throughput: forward, weighted cross-entropy, backward and an Adam step on random
  // batches (augmentation and batch assembly excluded; `softgrasp-train gqcnn` prints the whole).
  {
    const models::GqcnnNetConfig c = config;
    models::GqcnnNet net(c);
    models::InitGqcnnWeights(net);
    torch::optim::Adam opt(net->parameters(), torch::optim::AdamOptions(1e-3));
    const torch::Tensor images = torch::randn({batch, 1, 32, 32});
    const torch::Tensor poses = torch::randn({batch, models::GqcnnPoseInputs(c)});
    const torch::Tensor target = torch::randint(0, 2, {batch}, torch::kInt64);
    const int steps = 30;
    std::chrono::steady_clock::time_point t0;
    for (int step = 0; step < steps + 5; ++step) {
      if (step == 5) t0 = std::chrono::steady_clock::now();
      opt.zero_grad();
      const torch::Tensor loss = torch::cross_entropy_loss(net->forward(images, poses), target);
      loss.backward();
      opt.step();
    }
    const double s = SecondsSince(t0);
    result["train_crops_per_second"] = steps * batch / s;
    result["train_batch"] = batch;
    result["forward_macs_per_crop"] = models::GqcnnForwardMacs(c);
    result["parameters"] = models::CountParameters(*net);
  }
  std::cout << result.dump(2) << std::endl;
  return 0;
}

}  // namespace softgrasp::tools
