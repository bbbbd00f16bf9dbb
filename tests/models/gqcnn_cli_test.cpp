// `softgrasp-train gqcnn` and `gqcnn-eval` as processes (what CI runs to prove the pipeline):
// a few training steps on a synthetic dataset, its files and card, resume, evaluation on other
// objects with intervals and baselines, and command lines that exit 2 naming the problem.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "service/gqcnn/clearance.h"
#include "service/gqcnn/dataset_format.h"
#include "service/models/gqcnn_model.h"
#include "tests/models/gqcnn_synthetic.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::models {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct CliRun {
  int exit_code = -1;
  std::string out, err;
};

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class GqcnnCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new testing::TempDir("gqcnn-cli");
    testing::WriteSyntheticGqcnnDataset(*root_ / "train", {});
    testing::SyntheticGqcnnParams held_out;
    held_out.objects = 8;
    held_out.seed = 99;
    held_out.first_object_width_seed = 5;
    testing::WriteSyntheticGqcnnDataset(*root_ / "test", held_out);
  }
  static void TearDownTestSuite() { delete root_; }

  static CliRun Run(const std::string& args) {
    const fs::path out = *root_ / "stdout.txt", err = *root_ / "stderr.txt";
    const std::string cmd = std::string(SOFTGRASP_TRAIN_EXE) + " " + args + " > " + out.string() +
                            " 2> " + err.string() + " < /dev/null";
    const int status = std::system(cmd.c_str());
    CliRun r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = Slurp(out);
    r.err = Slurp(err);
    return r;
  }
  static std::string Dir(const char* name) { return (*root_ / name).string(); }
  static testing::TempDir* root_;
};
testing::TempDir* GqcnnCliTest::root_ = nullptr;

TEST_F(GqcnnCliTest, TrainsAFewStepsResumesAndEvaluates) {
  const fs::path model = *root_ / "run" / "gqcnn.pt";
  const std::string common = "gqcnn --data " + Dir("train") + " --out " + model.string() +
                             " --batch 16 --seed 3 --eval-every 10 --threads 1";
  const CliRun first = Run(common + " --steps 20");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_NE(first.out.find("loaded 1200 grasps"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("trained steps 0 -> 20 of 20"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("val loss"), std::string::npos) << first.out;
  for (const char* suffix : {".pt", ".json", ".ckpt", "_loss.csv", "_loss.png", "_accuracy.png"}) {
    EXPECT_TRUE(fs::exists(*root_ / "run" / (std::string("gqcnn") + suffix))) << suffix;
  }
  const json card = json::parse(Slurp(*root_ / "run" / "gqcnn.json"));
  EXPECT_EQ(card.at("training").at("steps_done").get<int>() % 10, 0);
  EXPECT_EQ(card.at("data").at("dirs").at(0), Dir("train"));
  EXPECT_GT(card.at("model_file_bytes").get<std::int64_t>(), 1000);
  // 21 lines: header and steps 1..20.
  const std::string csv = Slurp(*root_ / "run" / "gqcnn_loss.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 21);

  // --resume extends the run from its checkpoint; a checkpoint of other options is refused.
  const CliRun again = Run(common + " --steps 30 --resume");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("trained steps 20 -> 30 of 30"), std::string::npos) << again.out;
  const std::string csv30 = Slurp(*root_ / "run" / "gqcnn_loss.csv");
  EXPECT_EQ(std::count(csv30.begin(), csv30.end(), '\n'), 31);
  const CliRun mismatched = Run(common + " --steps 40 --lr 0.5 --resume");
  EXPECT_EQ(mismatched.exit_code, 2);
  EXPECT_NE(mismatched.err.find("other options"), std::string::npos) << mismatched.err;

  const fs::path report = *root_ / "eval" / "report.json";
  const CliRun eval = Run("gqcnn-eval --model " + model.string() + " --data " + Dir("test") +
                          " --json " + report.string() + " --resamples 200 --threads 1");
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  const json j = json::parse(Slurp(report));
  EXPECT_EQ(json::parse(eval.out), j);
  const json& g = j.at("gqcnn");
  EXPECT_EQ(g.at("grasps").get<int>(), 8 * 10 * 4);
  EXPECT_EQ(g.at("objects").get<int>(), 8);
  EXPECT_EQ(g.at("images").get<int>(), 80);
  for (const char* key : {"accuracy", "balanced_accuracy", "top1_precision"}) {
    const double v = g.at(key).get<double>();
    EXPECT_GE(v, 0.0) << key;
    EXPECT_LE(v, 1.0) << key;
    ASSERT_EQ(g.at(std::string(key) + "_ci95").size(), 2u);
  }
  const json& majority = j.at("baselines").at("majority_class").at("metrics");
  EXPECT_DOUBLE_EQ(majority.at("balanced_accuracy").get<double>(), 0.5);  // all one class
  EXPECT_TRUE(j.at("baselines").at("logistic_hand_features").contains("metrics"));
  EXPECT_FALSE(j.contains("warning"));

  // As strategy=gqcnn classifies: the records' clearances, counted here from the shards.
  std::size_t records = 0, admitted = 0, agree = 0, positives = 0, admitted_positives = 0,
              admitted_negatives = 0;
  const auto index = gqcnn::ReadIndex(Dir("test"));
  ASSERT_TRUE(index.ok());
  for (const auto& shard : index.value().shards) {
    const auto read = gqcnn::ReadShard(fs::path(Dir("test")) / shard.file);
    ASSERT_TRUE(read.ok());
    for (const gqcnn::GraspDatapoint& d : read.value()) {
      const bool a = gqcnn::ClearanceRule{}.Admits(gqcnn::StoredClearance(d), core::Gripper{});
      ++records;
      admitted += a ? 1 : 0;
      agree += a == d.collision_free ? 1 : 0;
      positives += d.label ? 1 : 0;
      admitted_positives += a && d.label ? 1 : 0;
      admitted_negatives += a && !d.label ? 1 : 0;
    }
  }
  const json& clearance = j.at("clearance");
  EXPECT_DOUBLE_EQ(clearance.at("admitted_rate").get<double>(),
                   static_cast<double>(admitted) / static_cast<double>(records));
  EXPECT_DOUBLE_EQ(clearance.at("agreement_with_collision_labels").get<double>(),
                   static_cast<double>(agree) / static_cast<double>(records));
  const double check_recall = static_cast<double>(admitted_positives) / positives;
  const double check_specificity =
      1.0 - static_cast<double>(admitted_negatives) / static_cast<double>(records - positives);
  const json& check = j.at("baselines").at("clearance_check_alone").at("metrics");
  EXPECT_NEAR(check.at("balanced_accuracy").get<double>(), 0.5 * (check_recall + check_specificity),
              1e-9);
  // The gate only turns positives into negatives: recall at most the check's and the net's.
  const json& gated = j.at("gqcnn_with_clearance");
  EXPECT_LE(gated.at("recall").get<double>(), check_recall + 1e-12);
  EXPECT_LE(gated.at("recall").get<double>(), g.at("recall").get<double>() + 1e-12);
  EXPECT_TRUE(j.at("baselines").at("logistic_with_clearance").contains("metrics"));

  // Evaluating on the training data says so.
  const CliRun leak =
      Run("gqcnn-eval --model " + model.string() + " --data " + Dir("train") + " --resamples 20");
  ASSERT_EQ(leak.exit_code, 0) << leak.err;
  EXPECT_TRUE(json::parse(leak.out).contains("warning"));
}

// --factored and --no-gain reach the card; --predictions writes one row per grasp.
TEST_F(GqcnnCliTest, FactoredTrainingWithoutGainAndPredictionRows) {
  const fs::path model = *root_ / "factored" / "gqcnn.pt";
  const CliRun train = Run("gqcnn --data " + Dir("train") + " --out " + model.string() +
                           " --batch 16 --seed 3 --eval-every 10 --threads 1 --steps 10"
                           " --factored --no-gain");
  ASSERT_EQ(train.exit_code, 0) << train.err;
  const json card = json::parse(Slurp(*root_ / "factored" / "gqcnn.json"));
  EXPECT_EQ(card.at("architecture").at("output").get<std::string>().rfind("factored", 0), 0u);
  EXPECT_FALSE(card.at("training").at("augmentation").at("multiplicative").get<bool>());
  EXPECT_TRUE(card.at("training").at("augmentation").at("symmetries").get<bool>());

  const fs::path rows = *root_ / "factored" / "rows.csv";
  const CliRun eval = Run("gqcnn-eval --model " + model.string() + " --data " + Dir("test") +
                          " --predictions " + rows.string() + " --resamples 20 --threads 1");
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  const json confusion = json::parse(eval.out).at("gqcnn").at("confusion");
  const json gated = json::parse(eval.out).at("gqcnn_with_clearance").at("confusion");
  std::istringstream csv(Slurp(rows));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "record,object,image,label,p_gqcnn,p_logistic,admitted");
  int n = 0, positives = 0, predicted = 0, predicted_and_admitted = 0;
  while (std::getline(csv, line)) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 7u) << line;
    EXPECT_EQ(std::stoi(cells[0]), n);
    EXPECT_EQ(cells[1].rfind("test:bar-", 0), 0u) << line;
    positives += cells[3] == "1";
    const double p = std::stod(cells[4]);
    EXPECT_GE(p, 0.0);
    EXPECT_LE(p, 1.0);
    predicted += p >= 0.5;
    ASSERT_TRUE(cells[6] == "0" || cells[6] == "1") << line;
    predicted_and_admitted += p >= 0.5 && cells[6] == "1";
    ++n;
  }
  EXPECT_EQ(n, 8 * 10 * 4);
  EXPECT_EQ(predicted_and_admitted, gated.at("tp").get<int>() + gated.at("fp").get<int>());
  EXPECT_EQ(positives, confusion.at("tp").get<int>() + confusion.at("fn").get<int>());
  EXPECT_EQ(predicted, confusion.at("tp").get<int>() + confusion.at("fp").get<int>());

  // --calibrate-on: the threshold is the grid value where the network's balanced accuracy on
  // the calibration objects (here the test set, whose rows were just written) is highest, and
  // the evaluation of other objects is the one at that threshold.
  double best_t = 0.5, best_ba = -1;
  for (int k = 1; k <= 99; ++k) {
    const double t = k / 100.0;
    double tp = 0, fn = 0, tn = 0, fp = 0;
    std::istringstream again(Slurp(rows));
    std::getline(again, line);
    while (std::getline(again, line)) {
      std::vector<std::string> cells;
      std::istringstream row(line);
      for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
      const bool y = cells[3] == "1", yes = std::stod(cells[4]) >= t;
      tp += y && yes;
      fn += y && !yes;
      fp += !y && yes;
      tn += !y && !yes;
    }
    const double ba = 0.5 * (tp / (tp + fn) + tn / (tn + fp));
    if (ba > best_ba + 1e-12 ||
        (std::abs(ba - best_ba) <= 1e-12 && std::abs(t - 0.5) < std::abs(best_t - 0.5))) {
      best_t = t;
      best_ba = ba;
    }
  }
  const CliRun calibrated = Run("gqcnn-eval --model " + model.string() + " --data " + Dir("train") +
                                " --calibrate-on " + Dir("test") + " --resamples 20 --threads 1");
  ASSERT_EQ(calibrated.exit_code, 0) << calibrated.err;
  const json c = json::parse(calibrated.out);
  EXPECT_DOUBLE_EQ(c.at("gqcnn").at("threshold").get<double>(), best_t);
  EXPECT_NEAR(c.at("gqcnn").at("calibration_balanced_accuracy").get<double>(), best_ba, 1e-9);
  EXPECT_EQ(c.at("threshold").at("chosen_on_grasps").get<int>(), 8 * 10 * 4);
  EXPECT_EQ(c.at("threshold").at("chosen_on").at(0), Dir("test"));
  // Each classifier is calibrated on its own probabilities: the constant majority baseline
  // scores 0.5 at every threshold, so keeps 0.5.
  EXPECT_DOUBLE_EQ(
      c.at("baselines").at("majority_class").at("metrics").at("threshold").get<double>(), 0.5);
  char fixed[32];
  std::snprintf(fixed, sizeof fixed, "%.2f", best_t);
  const CliRun at_t = Run("gqcnn-eval --model " + model.string() + " --data " + Dir("train") +
                          " --threshold " + fixed + " --resamples 20 --threads 1");
  ASSERT_EQ(at_t.exit_code, 0) << at_t.err;
  EXPECT_EQ(c.at("gqcnn").at("confusion"), json::parse(at_t.out).at("gqcnn").at("confusion"));
  EXPECT_DOUBLE_EQ(json::parse(at_t.out).at("threshold").get<double>(), best_t);

  // gqcnn-calibrate writes the same choice into the model's card; the network is unchanged.
  const fs::path cut_model = *root_ / "factored" / "cut" / "gqcnn.pt";
  const CliRun cut = Run("gqcnn-calibrate --model " + model.string() + " --data " + Dir("test") +
                         " --out " + cut_model.string() + " --threads 1");
  ASSERT_EQ(cut.exit_code, 0) << cut.err;
  const json cut_card = json::parse(Slurp(*root_ / "factored" / "cut" / "gqcnn.json"));
  EXPECT_DOUBLE_EQ(cut_card.at("decision_threshold").at("p").get<double>(), best_t);
  EXPECT_EQ(cut_card.at("decision_threshold").at("grasps").get<int>(), 8 * 10 * 4);
  EXPECT_EQ(cut_card.at("model_file_bytes").get<std::int64_t>(),
            static_cast<std::int64_t>(fs::file_size(cut_model)));
  auto before = GqcnnModel::Load(model);
  auto after = GqcnnModel::Load(cut_model);
  ASSERT_TRUE(before.ok() && after.ok());
  EXPECT_DOUBLE_EQ(after.value().decision_threshold(), best_t);
  EXPECT_EQ(after.value().Card().at("decision_threshold"), cut_card.at("decision_threshold"));
  const CliRun unwritable = Run("gqcnn-calibrate --model " + model.string() + " --data " +
                                Dir("test") + " --out /proc/softgrasp-nowhere/m.pt");
  EXPECT_EQ(unwritable.exit_code, 2);
  EXPECT_NE(unwritable.err.find("cannot write /proc/softgrasp-nowhere/m.pt"), std::string::npos)
      << unwritable.err;
  std::vector<float> crops(3 * gqcnn::kCropPixels, 0.7F), depths{0.68F, 0.69F, 0.7F};
  for (std::size_t i = 0; i < crops.size(); i += 7) crops[i] = 0.65F;
  EXPECT_EQ(before.value().Predict(crops, depths), after.value().Predict(crops, depths));

  // --cross-calibrate: each set at the threshold chosen on the other; the figures are those of
  // the two --calibrate-on runs added up.
  const CliRun other = Run("gqcnn-eval --model " + model.string() + " --data " + Dir("test") +
                           " --calibrate-on " + Dir("train") + " --resamples 20 --threads 1");
  ASSERT_EQ(other.exit_code, 0) << other.err;
  const json o = json::parse(other.out);
  const CliRun both =
      Run("gqcnn-eval --model " + model.string() + " --data " + Dir("train") + " --data " +
          Dir("test") + " --cross-calibrate --resamples 20 --threads 1");
  ASSERT_EQ(both.exit_code, 0) << both.err;
  const json x = json::parse(both.out);
  EXPECT_TRUE(x.at("threshold").at("chosen_on").is_string());
  const json& per_set = x.at("gqcnn").at("thresholds_per_set");
  ASSERT_EQ(per_set.size(), 2u);
  EXPECT_EQ(per_set.at(0).at("data"), Dir("train"));
  EXPECT_DOUBLE_EQ(per_set.at(0).at("threshold").get<double>(), best_t);
  EXPECT_DOUBLE_EQ(per_set.at(1).at("threshold").get<double>(),
                   o.at("gqcnn").at("threshold").get<double>());
  for (const char* k : {"tp", "fp", "tn", "fn"}) {
    EXPECT_EQ(x.at("gqcnn").at("confusion").at(k).get<double>(),
              c.at("gqcnn").at("confusion").at(k).get<double>() +
                  o.at("gqcnn").at("confusion").at(k).get<double>())
        << k;
    const json& xl = x.at("baselines").at("logistic_hand_features").at("metrics");
    const json& cl = c.at("baselines").at("logistic_hand_features").at("metrics");
    const json& ol = o.at("baselines").at("logistic_hand_features").at("metrics");
    EXPECT_EQ(xl.at("confusion").at(k).get<double>(),
              cl.at("confusion").at(k).get<double>() + ol.at("confusion").at(k).get<double>())
        << k;
  }
}

// --clearance-inputs reaches the model file and the card; gqcnn-eval hands the stored
// clearances to such a model, gqcnn-bench random ones.
TEST_F(GqcnnCliTest, ClearanceInputsTrainAndEvaluate) {
  const fs::path model = *root_ / "clearance" / "gqcnn.pt";
  const CliRun train = Run("gqcnn --data " + Dir("train") + " --out " + model.string() +
                           " --batch 16 --seed 3 --eval-every 10 --threads 1 --steps 10"
                           " --clearance-inputs");
  ASSERT_EQ(train.exit_code, 0) << train.err;
  const json card = json::parse(Slurp(*root_ / "clearance" / "gqcnn.json"));
  EXPECT_EQ(
      card.at("architecture").at("pose_inputs").get<std::string>().rfind("grasp depth; jaw", 0),
      0u);
  EXPECT_EQ(card.at("format_version").get<int>(), 3);
  const CliRun eval = Run("gqcnn-eval --model " + model.string() + " --data " + Dir("test") +
                          " --resamples 20 --threads 1");
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  const json confusion = json::parse(eval.out).at("gqcnn").at("confusion");
  int total = 0;
  for (const char* k : {"tp", "fp", "tn", "fn"}) total += confusion.at(k).get<int>();
  EXPECT_EQ(total, 8 * 10 * 4);
  const CliRun bench =
      Run("gqcnn-bench --model " + model.string() + " --repeats 1 --batch 8 --threads 1");
  ASSERT_EQ(bench.exit_code, 0) << bench.err;
  EXPECT_NE(json::parse(bench.out).at("model").get<std::string>().find("clearance inputs"),
            std::string::npos)
      << bench.out;
}

TEST_F(GqcnnCliTest, BadCommandLinesExitTwoNamingTheProblem) {
  const std::string model = (*root_ / "bad" / "m.pt").string();
  struct Case {
    std::string args, expected;
  };
  const Case cases[] = {
      {"gqcnn --out " + model, "--data DIR is required"},
      {"gqcnn --data " + Dir("train"), "--out MODEL is required"},
      {"gqcnn --data " + Dir("train") + " --out " + model + " --steps 5 --epochs 2", "not both"},
      {"gqcnn --data " + Dir("train") + " --out " + model + " --optimizer rmsprop",
       "--optimizer must be one of adam, sgd"},
      {"gqcnn --data " + Dir("nowhere") + " --out " + model + " --steps 5", "index"},
      {"gqcnn --data " + Dir("train") + " --out " + model + " --bogus", "unknown argument"},
      {"gqcnn-eval --model " + model + " --data " + Dir("test"), "no GQ-CNN model file"},
      {"gqcnn-eval --model " + model + " --data " + Dir("test") +
           " --threshold 0.3 --calibrate-on " + Dir("train"),
       "not two"},
      {"gqcnn-eval --model " + model + " --data " + Dir("test") + " --calibrate-on " + Dir("test"),
       "calibrate on other objects"},
      {"gqcnn-eval --model " + model + " --data " + Dir("test") + " --cross-calibrate",
       "two or more --data sets"},
      {"gqcnn-calibrate --model " + model + " --data " + Dir("test"), "--out OUT is required"},
      {"gqcnn-calibrate --model " + model + " --out " + model, "--data DIR is required"},
      {"gqcnn-calibrate --model " + model + " --data " + Dir("test") + " --out " + model,
       "no GQ-CNN model file"},
      {"gqcnn-calibrate --model " + Dir("train") + "/index.json --data " + Dir("test") + " --out " +
           model,
       "cannot read GQ-CNN model"},
      {"gqcnn-eval --model " + Dir("train") + "/index.json --data " + Dir("test"),
       "cannot read GQ-CNN model"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const CliRun r = Run(c.args);
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace softgrasp::models
