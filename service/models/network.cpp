#include "service/models/network.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "service/models/model_archive.h"
#include "service/models/stiffness_model.h"

namespace softgrasp::models {
namespace {

int LevelChannels(const NetworkConfig& config, int level) {
  return config.base_channels * (1 << std::min(level, 3));
}

torch::nn::Conv2dOptions Down(int in, int out) {
  return torch::nn::Conv2dOptions(in, out, 4).stride(2).padding(1);
}

// Per-sample normalisation (like pix2pix's instance norm at batch 1) in groups of channels.
torch::nn::GroupNorm Norm(int channels) {
  return torch::nn::GroupNorm(torch::nn::GroupNormOptions(std::min(8, channels), channels));
}

}  // namespace

UNetGeneratorImpl::UNetGeneratorImpl(const NetworkConfig& config) : dropout_(config.dropout) {
  const int levels = config.levels;
  if (levels < 2 || config.base_channels < 1 || (config.input_size >> levels) < 1) {
    throw std::invalid_argument("UNetGenerator: bad network config");
  }
  for (int i = 0; i < levels; ++i) {
    const int in = i == 0 ? 1 : LevelChannels(config, i - 1);
    down_.push_back(register_module("down" + std::to_string(i),
                                    torch::nn::Conv2d(Down(in, LevelChannels(config, i)))));
    // The first level (raw input) and the innermost (1-4 px wide) carry no norm, as in pix2pix.
    const bool norm = i > 0 && i < levels - 1;
    down_norm_.push_back(
        norm ? register_module("down_norm" + std::to_string(i), Norm(LevelChannels(config, i)))
             : torch::nn::GroupNorm{nullptr});
  }
  up_.resize(levels, torch::nn::Conv2d{nullptr});
  up_norm_.resize(levels, torch::nn::GroupNorm{nullptr});
  up_dropout_.resize(levels, false);
  for (int i = levels - 1; i >= 0; --i) {
    const int in = i == levels - 1 ? LevelChannels(config, i) : 2 * LevelChannels(config, i);
    const int out = i == 0 ? 1 : LevelChannels(config, i - 1);
    up_[i] = register_module("up" + std::to_string(i),
                             torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, 3).padding(1)));
    if (i > 0) up_norm_[i] = register_module("up_norm" + std::to_string(i), Norm(out));
    up_dropout_[i] = i > 0 && i >= levels - 2;
  }
}

torch::Tensor UNetGeneratorImpl::forward(const torch::Tensor& x) {
  const int levels = static_cast<int>(down_.size());
  std::vector<torch::Tensor> skips;
  torch::Tensor h = x;
  for (int i = 0; i < levels; ++i) {
    if (i > 0) h = torch::leaky_relu(h, 0.2);
    h = down_[i]->forward(h);
    if (down_norm_[i]) h = down_norm_[i]->forward(h);
    skips.push_back(h);
  }
  for (int i = levels - 1; i >= 0; --i) {
    if (i < levels - 1) h = torch::cat({h, skips[i]}, 1);
    h = torch::upsample_nearest2d(torch::relu(h),
                                  std::vector<std::int64_t>{2 * h.size(2), 2 * h.size(3)});
    h = up_[i]->forward(h);
    if (i == 0) break;
    h = up_norm_[i]->forward(h);
    if (up_dropout_[i]) h = torch::dropout(h, dropout_, is_training());
  }
  return torch::sigmoid(h);
}

PatchDiscriminatorImpl::PatchDiscriminatorImpl(const NetworkConfig& config) {
  const int c = config.disc_channels;
  if (c < 1) throw std::invalid_argument("PatchDiscriminator: bad network config");
  auto conv = [](int in, int out, int stride) {
    return torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, 4).stride(stride).padding(1));
  };
  auto lrelu = torch::nn::LeakyReLU(torch::nn::LeakyReLUOptions().negative_slope(0.2));
  body_ =
      register_module("body", torch::nn::Sequential(conv(2, c, 2), lrelu,                   //
                                                    conv(c, 2 * c, 2), Norm(2 * c), lrelu,  //
                                                    conv(2 * c, 4 * c, 2), Norm(4 * c), lrelu,
                                                    conv(4 * c, 8 * c, 1), Norm(8 * c), lrelu,  //
                                                    conv(8 * c, 1, 1)));
}

torch::Tensor PatchDiscriminatorImpl::forward(const torch::Tensor& input,
                                              const torch::Tensor& stiffness) {
  // The stiffness joins the input on the same [-1, 1] scale.
  return body_->forward(torch::cat({input, stiffness * 2.0 - 1.0}, 1));
}

void InitWeights(torch::nn::Module& module) {
  torch::NoGradGuard no_grad;
  for (auto& item : module.named_parameters()) {
    const std::string& name = item.key();
    torch::Tensor& p = item.value();
    const bool is_norm = name.find("norm") != std::string::npos || p.dim() == 1;
    if (name.size() >= 4 && name.compare(name.size() - 4, 4, "bias") == 0) {
      p.zero_();
    } else if (is_norm) {
      p.normal_(1.0, 0.02);
    } else {
      p.normal_(0.0, 0.02);
    }
  }
}

std::int64_t CountParameters(const torch::nn::Module& module) {
  std::int64_t n = 0;
  for (const auto& p : module.parameters()) n += p.numel();
  return n;
}

std::int64_t FlushSubnormalParameters(torch::nn::Module& module) {
  torch::NoGradGuard no_grad;
  std::int64_t flushed = 0;
  const auto flush = [&flushed](torch::Tensor t) {
    if (t.scalar_type() != torch::kFloat32) return;
    const torch::Tensor subnormal = (t.abs() < std::numeric_limits<float>::min()) & (t != 0.0F);
    flushed += subnormal.sum().item<std::int64_t>();
    t.masked_fill_(subnormal, 0.0F);
  };
  for (const torch::Tensor& p : module.parameters()) flush(p);
  for (const torch::Tensor& b : module.buffers()) flush(b);
  return flushed;
}

}  // namespace softgrasp::models

namespace softgrasp::models {

void SaveGenerator(const std::filesystem::path& path, UNetGenerator& generator,
                   const NetworkConfig& config, double height_range_m) {
  torch::serialize::OutputArchive archive;
  archive.write("config",
                torch::tensor({kModelFormatVersion, static_cast<std::int64_t>(config.input_size),
                               static_cast<std::int64_t>(config.base_channels),
                               static_cast<std::int64_t>(config.levels),
                               static_cast<std::int64_t>(config.disc_channels)},
                              torch::kInt64));
  archive.write("height_range_m", torch::tensor({height_range_m}, torch::kFloat64));
  torch::serialize::OutputArchive net;
  generator->save(net);
  archive.write("generator", net);
  SaveModelArchive(archive, path);
}

core::Result<LoadedGenerator> LoadGenerator(const std::filesystem::path& path) {
  return LoadModelArchive<LoadedGenerator>(
      path, "stiffness",
      [](torch::serialize::InputArchive& archive,
         const ModelFileError& fail) -> core::Result<LoadedGenerator> {
        torch::Tensor config_t;
        torch::Tensor range_t;
        if (!archive.try_read("config", config_t) || !archive.try_read("height_range_m", range_t) ||
            config_t.numel() != 5 || range_t.numel() != 1) {
          return fail("a libtorch archive but not a stiffness model (missing config)");
        }
        const auto c = config_t.to(torch::kInt64).contiguous();
        const std::int64_t* v = c.data_ptr<std::int64_t>();
        if (v[0] != kModelFormatVersion) {
          return fail("model format version " + std::to_string(v[0]) +
                      ", this build reads version " + std::to_string(kModelFormatVersion));
        }
        LoadedGenerator out;
        out.config.input_size = static_cast<int>(v[1]);
        out.config.base_channels = static_cast<int>(v[2]);
        out.config.levels = static_cast<int>(v[3]);
        out.config.disc_channels = static_cast<int>(v[4]);
        out.height_range_m = range_t.to(torch::kFloat64).item<double>();
        if (out.config.input_size < 16 || out.config.input_size > 4096 || out.config.levels < 2 ||
            out.config.levels > 10 || out.config.base_channels < 1 ||
            out.config.base_channels > 1024 || !(out.height_range_m > 0)) {
          return fail("implausible model config");
        }
        out.generator = UNetGenerator(out.config);
        torch::serialize::InputArchive net;
        if (!archive.try_read("generator", net)) return fail("no generator in the model file");
        out.generator->load(net);
        out.generator->eval();
        return out;
      });
}

std::optional<core::Error> HeightRangeMismatch(const std::filesystem::path& path,
                                               double trained_range_m) {
  if (std::abs(trained_range_m - kInputHeightRangeM) <= 1e-9) return std::nullopt;
  return core::MakeError(core::ErrorCode::kUnprocessable,
                         path.string() + ": trained with a height range of " +
                             std::to_string(trained_range_m) + " m, this build normalises with " +
                             std::to_string(kInputHeightRangeM) + " m",
                         "model");
}

}  // namespace softgrasp::models
