#pragma once
/// Training the GQ-CNN on CPU with libtorch (docs/gqcnn.md, "Training"): datasets written by
/// `softgrasp-sim gqcnn-dataset` (gqcnn/dataset_format.h) loaded into memory, an object-wise
/// train/validation split, Dex-Net 2.0's augmentations, a weighted cross-entropy or balanced
/// sampling against the class imbalance, checkpoints that resume bit for bit, loss and accuracy
/// curves, and the best model by validation balanced accuracy with its card.

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "service/core/status.h"
#include "service/gqcnn/dataset_format.h"
#include "service/models/gqcnn_network.h"

namespace softgrasp::models {

/// Every record of one or more datasets, in memory (4 KB of crop per record: 100 k records are
/// 400 MB). Objects and images of different datasets get different keys.
struct GqcnnSet {
  std::vector<float> crops_depth_m;   ///< size() x kCropPixels
  std::vector<float> grasp_depths_m;  ///< size()
  std::vector<float> width_px;        ///< hand_pose[6]: the jaw opening in the full image
  std::vector<std::uint8_t> labels;
  /// The label's two factors: the gripper reaches the grasp without collision, and the robust
  /// quality is above the dataset's metric threshold (label = both).
  std::vector<std::uint8_t> collision_free;
  std::vector<std::uint8_t> quality_labels;
  /// The gripper clearance stored with the record admits the grasp (gqcnn::ClearanceRule's
  /// defaults, the dataset's 5 cm gripper): the grasps strategy=gqcnn lets the network score.
  /// 1 for records of datasets written before clearances were stored.
  std::vector<std::uint8_t> admitted;
  /// The stored clearances, size() x 3: jaws, palm, floor (gqcnn::GripperClearance, metres; NaN
  /// in records of datasets written before clearances were).
  std::vector<float> clearances_m;
  /// Every record carries its clearances (false when a dataset predates them).
  bool clearances_measured = true;
  std::vector<std::uint32_t> object_keys;     ///< into object_names
  std::vector<std::uint32_t> image_keys;      ///< dense, per (dataset, image_index)
  std::vector<std::string> object_names;      ///< "DIR:name"
  std::vector<std::string> sources;           ///< the dataset directories
  std::vector<std::uint32_t> object_sources;  ///< per object: its directory, into sources
  std::uint64_t positives = 0;
  std::size_t size() const { return labels.size(); }
  std::size_t images() const;
  const float* crop(std::size_t i) const { return crops_depth_m.data() + i * gqcnn::kCropPixels; }
  const float* clearance(std::size_t i) const { return clearances_m.data() + i * 3; }
};

/// Reads every finished shard of every directory. `progress(shards_done, shards_total)`.
/// Errors: ReadIndex / ReadShard's (the message names the file), an object_index outside the
/// index's objects, no record at all (kInvalidArgument, field "data").
core::Result<GqcnnSet> LoadGqcnnSet(const std::vector<std::filesystem::path>& dirs,
                                    const std::function<void(int, int)>& progress = {});

/// Record indices of an object-wise split: objects are shuffled with `seed` and the first
/// round(validation_fraction x objects) (at least 1 when there are >= 2 objects) are held out.
struct GqcnnSplit {
  std::vector<std::size_t> train, validation;
  std::vector<std::uint32_t> validation_objects;
};
GqcnnSplit SplitByObject(const GqcnnSet& set, double validation_fraction, std::uint64_t seed);

/// Scalar statistics over the valid (> 0) pixels and the grasp depths of `records`.
GqcnnNormalisation ComputeNormalisation(const GqcnnSet& set,
                                        const std::vector<std::size_t>& records);

/// Dex-Net 2.0's training-time augmentation (REFERENCE §1.9).
struct GqcnnAugmentation {
  bool multiplicative = true;  ///< depth x Gamma(shape, 1 / shape) per image
  double gamma_shape = 1000.0;
  double gp_rate = 0.5;       ///< probability of correlated noise
  double gp_sigma_m = 0.005;  ///< N(0, sigma^2) on a grid ...
  int gp_grid = 8;            ///< ... of gp_grid x gp_grid, bicubically upsampled to 32 x 32
  bool symmetries = true;     ///< 180-degree rotation, left-right, up-down flips, each p 0.5
};

/// What one AugmentCrop call drew.
struct GqcnnAugmentDraw {
  bool rotate_180 = false, flip_lr = false, flip_ud = false, gp_noise = false;
  double gain = 1.0;
};

/// Rotates by 180 degrees and flips in place (a 32 x 32 row-major crop).
void ApplyCropSymmetries(float* crop, bool rotate_180, bool flip_lr, bool flip_ud);
/// Augments one crop in place (depths in metres, 0 = missing, which stays 0: noise goes only to
/// valid pixels, and noisy valid pixels stay > 0). Draws from `rng` in a fixed order.
GqcnnAugmentDraw AugmentCrop(float* crop, const GqcnnAugmentation& params, std::mt19937_64& rng);

/// A simple baseline: logistic regression on two hand features of a crop, fitted with balanced
/// class weights on the training split, stored in the model card and evaluated beside the net.
///   f0 = (shallower of the two jaw-tip depths) - (centre depth): > 0 when the surface at the
///        centre stands up above both jaw paths (something to close on);
///   f1 = grasp depth - centre depth: how far below the surface at the centre the jaws close.
/// Depths are 3 x 3 means of valid pixels at the crop centre and at the jaw tips, half the
/// opening (width_px / 3, the 96 -> 32 px resize) either side along the rows; a missing patch
/// gives a feature 0.
std::array<double, 2> GqcnnHandFeatures(const float* crop, float grasp_depth_m, float width_px);

struct LogisticBaseline {
  std::array<double, 2> feature_mean{}, feature_std{1.0, 1.0};
  std::array<double, 3> weights{};  ///< bias, f0, f1 on standardised features
  double train_positive_rate = 0;
  double Predict(const std::array<double, 2>& features) const;
  nlohmann::json ToJson() const;
  static core::Result<LogisticBaseline> FromJson(const nlohmann::json& json);
};
/// Newton's method (IRLS) with balanced class weights and a small ridge (1e-3).
LogisticBaseline FitLogisticBaseline(const GqcnnSet& set, const std::vector<std::size_t>& records);

enum class GqcnnOptimizer { kSgd, kAdam };
enum class GqcnnBalance { kNone, kWeightedLoss, kBalancedSampling };

struct GqcnnTrainOptions {
  std::filesystem::path out;  ///< best model; OUT.json card, OUT.ckpt, OUT_loss.csv/.png beside
  int steps = 0;              ///< total steps; 0: from `epochs`
  double epochs = 10;         ///< when steps == 0: steps = ceil(epochs x train records / batch)
  int batch = 64;
  GqcnnOptimizer optimizer = GqcnnOptimizer::kAdam;
  double learning_rate = 0;  ///< 0: 1e-3 for Adam, 0.01 for SGD
  double momentum = 0.9;     ///< SGD only
  double weight_decay = 5e-4;
  double lr_decay = 0.95;  ///< staircase: x lr_decay every decay_every_epochs
  double decay_every_epochs = 0.66;
  GqcnnBalance balance = GqcnnBalance::kWeightedLoss;
  double validation_fraction = 0.2;
  std::uint64_t seed = 1;
  int eval_every = 0;        ///< steps between validations; 0: 20 validations per run
  int checkpoint_every = 0;  ///< steps between checkpoints; 0: at every validation
  bool resume = false;       ///< continue from OUT.ckpt when it exists
  /// Train and validate on the records whose clearance the planner admits (GqcnnSet::admitted)
  /// only: the network then learns to judge the grasps it will be asked about. Needs datasets
  /// with clearances.
  bool admitted_only = false;
  int stop_after_step = 0;  ///< stop (checkpointing) after this step as if killed; 0 = run on
  GqcnnNetConfig network;
  GqcnnAugmentation augmentation;
};

/// Classification figures at the 0.5 threshold.
struct GqcnnValidation {
  int step = 0;
  double loss = 0;  ///< mean cross-entropy (unweighted)
  double accuracy = 0, balanced_accuracy = 0, precision = 0, recall = 0;
};

struct GqcnnStepRecord {
  int step = 0;
  double loss = 0;      ///< training loss of the batch (as optimised: weighted if so)
  double accuracy = 0;  ///< of the batch, augmented
  double learning_rate = 0;
};

struct GqcnnTrainReport {
  int start_step = 0, end_step = 0, total_steps = 0;
  double seconds = 0;                    ///< this run's wall time
  double crops_per_second = 0;           ///< training throughput of this run (steps x batch / time)
  std::vector<GqcnnStepRecord> history;  ///< every step from 1 (resumed ones included)
  std::vector<GqcnnValidation> validations;  ///< every validation from the start
  GqcnnValidation best;                      ///< the saved model's
  nlohmann::json card;                       ///< as written beside the model
};

using GqcnnProgress =
    std::function<void(const GqcnnStepRecord&, const GqcnnValidation* validation, int total)>;

/// Trains on `set`. Deterministic given the options and torch's thread count: batches and
/// augmentations come from streams seeded with (seed, step), so a resumed run does what an
/// uninterrupted one would. Errors: kInvalidArgument (bad options; a split without training or
/// validation positives and negatives), kUnprocessable (unreadable or mismatched checkpoint),
/// kInternal (non-finite loss).
core::Result<GqcnnTrainReport> TrainGqcnn(const GqcnnTrainOptions& options, const GqcnnSet& set,
                                          const GqcnnProgress& progress = {});

/// OUT.json beside the model.
std::filesystem::path GqcnnCardPath(const std::filesystem::path& out);
/// OUT_accuracy.png beside the model (OUT_loss.png is LossPngPath).
std::filesystem::path GqcnnAccuracyPngPath(const std::filesystem::path& out);

}  // namespace softgrasp::models
