#include "service/models/gqcnn_network.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "service/gqcnn/dataset_format.h"
#include "service/models/model_archive.h"

namespace softgrasp::models {
namespace {

constexpr int kSide = gqcnn::kCropSizePx;

/// A marker tensor so another model file is never taken for a GQ-CNN one.
torch::Tensor KindMarker() { return torch::tensor({0x6C, 0xC2}, torch::kInt64); }

torch::Tensor ConfigTensor(const GqcnnNetConfig& c) {
  return torch::tensor(
      {kGqcnnFormatVersion, static_cast<std::int64_t>(c.conv1_channels),
       static_cast<std::int64_t>(c.conv2_channels), static_cast<std::int64_t>(c.conv1_1_kernel),
       static_cast<std::int64_t>(c.conv1_2_kernel), static_cast<std::int64_t>(c.fc3_units),
       static_cast<std::int64_t>(c.pc1_units), static_cast<std::int64_t>(c.fc4_units),
       static_cast<std::int64_t>(c.local_response_norm ? 1 : 0),
       static_cast<std::int64_t>(c.factored ? 1 : 0),
       static_cast<std::int64_t>(c.clearance_inputs ? 1 : 0)},
      torch::kInt64);
}

torch::nn::Conv2d Conv(int in, int out, int kernel) {
  return torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, kernel).padding(kernel / 2));
}

bool ValidConfig(const GqcnnNetConfig& c) {
  auto width = [](int w) { return w >= 1 && w <= 1024; };
  auto kernel = [](int k) { return k >= 1 && k <= 15 && k % 2 == 1; };
  return width(c.conv1_channels) && width(c.conv2_channels) && width(c.fc3_units) &&
         width(c.pc1_units) && width(c.fc4_units) && kernel(c.conv1_1_kernel) &&
         kernel(c.conv1_2_kernel);
}

/// Fills `t` with N(0, std^2) truncated at two standard deviations (redrawing outliers).
void TruncatedNormal(torch::Tensor t, double std) {
  t.normal_(0.0, std);
  for (int round = 0; round < 20; ++round) {
    const torch::Tensor outside = t.abs() > 2.0 * std;
    if (!outside.any().item<bool>()) return;
    t.copy_(torch::where(outside, torch::randn_like(t) * std, t));
  }
  t.clamp_(-2.0 * std, 2.0 * std);
}

/// Config values per format version: [version, 7 sizes, LRN] (1), + factored (2), + clearance
/// inputs (3).
std::int64_t ConfigLength(std::int64_t version) { return 8 + version; }

}  // namespace

float GqcnnClearanceInput(double clearance_m) {
  if (!std::isfinite(clearance_m)) return 0.0F;
  return static_cast<float>(std::clamp(clearance_m, -kGqcnnClearanceClampM, kGqcnnClearanceClampM) /
                            kGqcnnClearanceScaleM);
}

torch::Tensor GqcnnSuccessProbability(const torch::Tensor& logits, const GqcnnNetConfig& config) {
  if (config.factored)
    return torch::sigmoid(logits.select(1, 0)) * torch::sigmoid(logits.select(1, 1));
  return torch::softmax(logits, 1).select(1, 1);
}

torch::Tensor GqcnnSuccessLoss(const torch::Tensor& logits, const torch::Tensor& labels,
                               const GqcnnNetConfig& config, const torch::Tensor& class_weights,
                               bool sum) {
  torch::Tensor log_probs;  // [N, 2]: log P(fails), log P(succeeds)
  if (config.factored) {
    const torch::Tensor log_success =
        torch::log_sigmoid(logits.select(1, 0)) + torch::log_sigmoid(logits.select(1, 1));
    // log(1 - p) with p = exp(log_success) < 1; the clamp keeps a certain success finite.
    const torch::Tensor log_fail = torch::log1p(-torch::exp(log_success).clamp_max(1.0 - 1e-6));
    log_probs = torch::stack({log_fail, log_success}, 1);
  } else {
    log_probs = torch::log_softmax(logits, 1);
  }
  const auto reduction = sum ? at::Reduction::Sum : at::Reduction::Mean;
  return torch::nll_loss(log_probs, labels, class_weights, reduction);
}

std::int64_t GqcnnForwardMacs(const GqcnnNetConfig& c) {
  const std::int64_t full = kSide * kSide, half = full / 4;
  const std::int64_t c1 = c.conv1_channels, c2 = c.conv2_channels;
  std::int64_t macs = full * c1 * c.conv1_1_kernel * c.conv1_1_kernel;  // conv1_1
  macs += full * c1 * c1 * c.conv1_2_kernel * c.conv1_2_kernel;         // conv1_2
  macs += half * c2 * c1 * 9 + half * c2 * c2 * 9;                      // conv2_1, conv2_2
  macs += (half / 4) * c2 * c.fc3_units;                                // fc3
  macs += GqcnnPoseInputs(c) * c.pc1_units + (c.fc3_units + c.pc1_units) * c.fc4_units +
          c.fc4_units * 2;  // rest
  return macs;
}

GqcnnNetImpl::GqcnnNetImpl(const GqcnnNetConfig& c) : config_(c) {
  if (!ValidConfig(c)) throw std::invalid_argument("GqcnnNet: bad network config");
  conv1_1_ = register_module("conv1_1", Conv(1, c.conv1_channels, c.conv1_1_kernel));
  conv1_2_ = register_module("conv1_2", Conv(c.conv1_channels, c.conv1_channels, c.conv1_2_kernel));
  conv2_1_ = register_module("conv2_1", Conv(c.conv1_channels, c.conv2_channels, 3));
  conv2_2_ = register_module("conv2_2", Conv(c.conv2_channels, c.conv2_channels, 3));
  // TensorFlow's LRN sums alpha * x^2 over 2r + 1 = 5 channels; PyTorch divides alpha by the
  // size, so alpha 2e-5 in TensorFlow is 1e-4 here.
  lrn_ = register_module("lrn",
                         torch::nn::LocalResponseNorm(
                             torch::nn::LocalResponseNormOptions(5).alpha(1e-4).beta(0.75).k(1.0)));
  fc3_ = register_module(
      "fc3", torch::nn::Linear((kSide / 4) * (kSide / 4) * c.conv2_channels, c.fc3_units));
  pc1_ = register_module("pc1", torch::nn::Linear(GqcnnPoseInputs(c), c.pc1_units));
  fc4_ = register_module("fc4", torch::nn::Linear(c.fc3_units + c.pc1_units, c.fc4_units));
  fc5_ = register_module("fc5", torch::nn::Linear(c.fc4_units, 2));
}

torch::Tensor GqcnnNetImpl::forward(const torch::Tensor& image, const torch::Tensor& pose) {
  torch::Tensor h = torch::relu(conv1_1_->forward(image));
  h = torch::relu(conv1_2_->forward(h));
  if (config_.local_response_norm) h = lrn_->forward(h);
  h = torch::max_pool2d(h, 2);
  h = torch::relu(conv2_1_->forward(h));
  h = torch::relu(conv2_2_->forward(h));
  if (config_.local_response_norm) h = lrn_->forward(h);
  h = torch::max_pool2d(h, 2);
  h = torch::relu(fc3_->forward(h.flatten(1)));
  const torch::Tensor p = torch::relu(pc1_->forward(pose));
  h = torch::relu(fc4_->forward(torch::cat({h, p}, 1)));
  return fc5_->forward(h);
}

void InitGqcnnWeights(GqcnnNet& net) {
  torch::NoGradGuard no_grad;
  for (auto& item : net->named_parameters()) {
    torch::Tensor p = item.value();
    if (p.dim() >= 2) {
      const double fan_in = static_cast<double>(p.numel() / p.size(0));
      TruncatedNormal(p, std::sqrt(2.0 / fan_in));
    } else {
      p.zero_();
    }
  }
}

void NormaliseGqcnnInputs(const float* crops, const float* depths, const float* clearances,
                          std::int64_t n, const GqcnnNetConfig& config,
                          const GqcnnNormalisation& norm, torch::Tensor* images,
                          torch::Tensor* poses) {
  if (config.clearance_inputs && clearances == nullptr && n > 0) {
    throw std::invalid_argument("NormaliseGqcnnInputs: the network takes clearances");
  }
  const int pose_inputs = GqcnnPoseInputs(config);
  *images = torch::empty({n, 1, kSide, kSide}, torch::kFloat32);
  *poses = torch::empty({n, pose_inputs}, torch::kFloat32);
  float* im = images->data_ptr<float>();
  float* po = poses->data_ptr<float>();
  const auto im_mean = static_cast<float>(norm.im_mean_m);
  const auto im_scale = static_cast<float>(1.0 / norm.im_std_m);
  const std::int64_t total = n * gqcnn::kCropPixels;
  for (std::int64_t i = 0; i < total; ++i) {
    const float d = crops[i];
    im[i] = (std::isfinite(d) && d > 0.0f) ? (d - im_mean) * im_scale : 0.0f;
  }
  for (std::int64_t i = 0; i < n; ++i) {
    const float d = depths[i];
    float* row = po + i * pose_inputs;
    row[0] = std::isfinite(d) ? static_cast<float>((d - norm.pose_mean_m) / norm.pose_std_m) : 0.0f;
    for (int k = 1; k < pose_inputs; ++k) row[k] = GqcnnClearanceInput(clearances[i * 3 + k - 1]);
  }
}

nlohmann::json GqcnnConfigJson(const GqcnnNetConfig& c) {
  return {{"conv1_channels", c.conv1_channels},
          {"conv2_channels", c.conv2_channels},
          {"conv1_1_kernel", c.conv1_1_kernel},
          {"conv1_2_kernel", c.conv1_2_kernel},
          {"fc3_units", c.fc3_units},
          {"pc1_units", c.pc1_units},
          {"fc4_units", c.fc4_units},
          {"local_response_norm", c.local_response_norm},
          {"output", c.factored ? "factored: sigmoid(collision-free) x sigmoid(quality)"
                                : "softmax (fails, succeeds)"},
          {"pose_inputs", c.clearance_inputs
                              ? "grasp depth; jaw, palm and floor clearance (clamped to +-6 cm)"
                              : "grasp depth"},
          {"forward_macs_per_crop", GqcnnForwardMacs(c)}};
}

void SaveGqcnnNet(const std::filesystem::path& path, GqcnnNet& net, const GqcnnNetConfig& c,
                  const GqcnnNormalisation& norm, const nlohmann::json& card) {
  torch::serialize::OutputArchive archive;
  archive.write("kind", KindMarker());
  archive.write("config", ConfigTensor(c));
  archive.write("normalisation",
                torch::tensor({norm.im_mean_m, norm.im_std_m, norm.pose_mean_m, norm.pose_std_m},
                              torch::kFloat64));
  const std::string text = card.dump();
  torch::Tensor bytes = torch::empty({static_cast<std::int64_t>(text.size())}, torch::kUInt8);
  std::copy(text.begin(), text.end(), reinterpret_cast<char*>(bytes.data_ptr<std::uint8_t>()));
  archive.write("card", bytes);
  torch::serialize::OutputArchive weights;
  net->save(weights);
  archive.write("net", weights);
  SaveModelArchive(archive, path);
}

core::Result<LoadedGqcnnNet> LoadGqcnnNet(const std::filesystem::path& path) {
  return LoadModelArchive<LoadedGqcnnNet>(
      path, "GQ-CNN",
      [](torch::serialize::InputArchive& archive,
         const ModelFileError& fail) -> core::Result<LoadedGqcnnNet> {
        torch::Tensor kind, config_t, norm_t, card_t;
        if (!archive.try_read("kind", kind) || kind.numel() != 2 || !kind.equal(KindMarker())) {
          return fail("a libtorch archive but not a GQ-CNN model");
        }
        if (!archive.try_read("config", config_t) || config_t.numel() < 1) return fail("no config");
        const auto cfg = config_t.to(torch::kInt64).contiguous();
        const std::int64_t* v = cfg.data_ptr<std::int64_t>();
        if (v[0] < 1 || v[0] > kGqcnnFormatVersion) {
          return fail("format version " + std::to_string(v[0]) +
                      ", this build reads versions 1 to " + std::to_string(kGqcnnFormatVersion));
        }
        if (cfg.numel() != ConfigLength(v[0])) return fail("config of the wrong length");
        for (int i = 1; i < 9; ++i) {
          if (v[i] < 0 || v[i] > 1024) return fail("implausible config");
        }
        LoadedGqcnnNet out;
        out.config.conv1_channels = static_cast<int>(v[1]);
        out.config.conv2_channels = static_cast<int>(v[2]);
        out.config.conv1_1_kernel = static_cast<int>(v[3]);
        out.config.conv1_2_kernel = static_cast<int>(v[4]);
        out.config.fc3_units = static_cast<int>(v[5]);
        out.config.pc1_units = static_cast<int>(v[6]);
        out.config.fc4_units = static_cast<int>(v[7]);
        if (v[8] != 0 && v[8] != 1) return fail("implausible config");
        out.config.local_response_norm = v[8] == 1;
        if (v[0] >= 2) {
          if (v[9] != 0 && v[9] != 1) return fail("implausible config");
          out.config.factored = v[9] == 1;
        }
        if (v[0] >= 3) {
          if (v[10] != 0 && v[10] != 1) return fail("implausible config");
          out.config.clearance_inputs = v[10] == 1;
        }
        if (!ValidConfig(out.config)) return fail("implausible config");
        if (!archive.try_read("normalisation", norm_t) || norm_t.numel() != 4) {
          return fail("no normalisation");
        }
        const auto nv = norm_t.to(torch::kFloat64).contiguous();
        const double* n = nv.data_ptr<double>();
        out.normalisation = {n[0], n[1], n[2], n[3]};
        if (!std::isfinite(n[0]) || !std::isfinite(n[2]) || !(n[1] > 0) || !(n[3] > 0) ||
            !std::isfinite(n[1]) || !std::isfinite(n[3])) {
          return fail("implausible normalisation");
        }
        if (!archive.try_read("card", card_t) || card_t.dim() != 1) return fail("no model card");
        const auto bytes = card_t.to(torch::kUInt8).contiguous();
        const std::string text(reinterpret_cast<const char*>(bytes.data_ptr<std::uint8_t>()),
                               static_cast<std::size_t>(bytes.numel()));
        out.card = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
        if (out.card.is_discarded() || !out.card.is_object()) return fail("model card is not JSON");
        out.net = GqcnnNet(out.config);
        torch::serialize::InputArchive weights;
        if (!archive.try_read("net", weights)) return fail("no network weights");
        out.net->load(weights);
        out.net->eval();
        return out;
      });
}

}  // namespace softgrasp::models
