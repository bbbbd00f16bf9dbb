#include "service/models/segmentation_network.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "service/models/model_archive.h"

namespace softgrasp::models {
namespace {

int Channels(const SegmentationNetConfig& c, int level) {
  return c.base_channels * (1 << std::min(level, 3));
}

torch::nn::GroupNorm Norm(int channels) {
  return torch::nn::GroupNorm(torch::nn::GroupNormOptions(std::min(8, channels), channels));
}

torch::nn::Conv2d Conv3(int in, int out) {
  return torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, 3).padding(1));
}

/// A marker tensor so a stiffness model file is never taken for a segmentation one.
torch::Tensor KindMarker() { return torch::tensor({0x5E6, 0x5E6}, torch::kInt64); }

}  // namespace

SegmentationNetImpl::SegmentationNetImpl(const SegmentationNetConfig& c) {
  const int div = 1 << c.levels;
  if (c.levels < 2 || c.levels > 6 || c.base_channels < 1 || c.width < div || c.height < div ||
      c.width % div != 0 || c.height % div != 0) {
    throw std::invalid_argument("SegmentationNet: bad network config");
  }
  stem_ = register_module("stem", Conv3(1, Channels(c, 0)));
  stem_norm_ = register_module("stem_norm", Norm(Channels(c, 0)));
  for (int i = 1; i <= c.levels; ++i) {
    down_.push_back(register_module(
        "down" + std::to_string(i),
        torch::nn::Conv2d(
            torch::nn::Conv2dOptions(Channels(c, i - 1), Channels(c, i), 4).stride(2).padding(1))));
    down_norm_.push_back(register_module("down_norm" + std::to_string(i), Norm(Channels(c, i))));
  }
  bottleneck_ = register_module("bottleneck", Conv3(Channels(c, c.levels), Channels(c, c.levels)));
  bottleneck_norm_ = register_module("bottleneck_norm", Norm(Channels(c, c.levels)));
  up_.resize(static_cast<std::size_t>(c.levels), torch::nn::Conv2d{nullptr});
  up_norm_.resize(static_cast<std::size_t>(c.levels), torch::nn::GroupNorm{nullptr});
  for (int i = c.levels - 1; i >= 0; --i) {
    const int in = Channels(c, i + 1) + Channels(c, i);
    up_[static_cast<std::size_t>(i)] =
        register_module("up" + std::to_string(i), Conv3(in, Channels(c, i)));
    up_norm_[static_cast<std::size_t>(i)] =
        register_module("up_norm" + std::to_string(i), Norm(Channels(c, i)));
  }
  head_hidden_ = register_module("head_hidden", Conv3(Channels(c, 0), Channels(c, 0)));
  head_out_ = register_module(
      "head_out", torch::nn::Conv2d(torch::nn::Conv2dOptions(Channels(c, 0), kHeadCount, 1)));
}

torch::Tensor SegmentationNetImpl::forward(const torch::Tensor& x) {
  std::vector<torch::Tensor> skips;
  torch::Tensor h = torch::leaky_relu(stem_norm_->forward(stem_->forward(x)), 0.2);
  skips.push_back(h);
  for (std::size_t i = 0; i < down_.size(); ++i) {
    h = torch::leaky_relu(down_norm_[i]->forward(down_[i]->forward(h)), 0.2);
    skips.push_back(h);
  }
  // A residual 3x3 at the coarsest level widens the receptive field to the biggest objects.
  h = h + torch::leaky_relu(bottleneck_norm_->forward(bottleneck_->forward(h)), 0.2);
  for (int i = static_cast<int>(up_.size()) - 1; i >= 0; --i) {
    const auto& skip = skips[static_cast<std::size_t>(i)];
    h = torch::upsample_nearest2d(h, std::vector<std::int64_t>{skip.size(2), skip.size(3)});
    h = torch::cat({h, skip}, 1);
    h = torch::relu(up_norm_[static_cast<std::size_t>(i)]->forward(
        up_[static_cast<std::size_t>(i)]->forward(h)));
  }
  h = torch::relu(head_hidden_->forward(h));
  return head_out_->forward(h);
}

void SaveSegmentationNet(const std::filesystem::path& path, SegmentationNet& net,
                         const SegmentationNetConfig& c, double height_range_m) {
  torch::serialize::OutputArchive archive;
  archive.write("kind", KindMarker());
  archive.write("config",
                torch::tensor({kSegmentationFormatVersion, static_cast<std::int64_t>(c.width),
                               static_cast<std::int64_t>(c.height),
                               static_cast<std::int64_t>(c.base_channels),
                               static_cast<std::int64_t>(c.levels)},
                              torch::kInt64));
  archive.write("height_range_m", torch::tensor({height_range_m}, torch::kFloat64));
  torch::serialize::OutputArchive weights;
  net->save(weights);
  archive.write("net", weights);
  SaveModelArchive(archive, path);
}

core::Result<LoadedSegmentationNet> LoadSegmentationNet(const std::filesystem::path& path) {
  return LoadModelArchive<LoadedSegmentationNet>(
      path, "segmentation",
      [](torch::serialize::InputArchive& archive,
         const ModelFileError& fail) -> core::Result<LoadedSegmentationNet> {
        torch::Tensor kind, config_t, range_t;
        if (!archive.try_read("kind", kind) || !kind.equal(KindMarker())) {
          return fail("a libtorch archive but not a segmentation model");
        }
        if (!archive.try_read("config", config_t) || !archive.try_read("height_range_m", range_t) ||
            config_t.numel() != 5 || range_t.numel() != 1) {
          return fail("missing config");
        }
        const auto cfg = config_t.to(torch::kInt64).contiguous();
        const std::int64_t* v = cfg.data_ptr<std::int64_t>();
        if (v[0] != kSegmentationFormatVersion) {
          return fail("format version " + std::to_string(v[0]) + ", this build reads version " +
                      std::to_string(kSegmentationFormatVersion));
        }
        LoadedSegmentationNet out;
        out.config.width = static_cast<int>(v[1]);
        out.config.height = static_cast<int>(v[2]);
        out.config.base_channels = static_cast<int>(v[3]);
        out.config.levels = static_cast<int>(v[4]);
        out.height_range_m = range_t.to(torch::kFloat64).item<double>();
        if (out.config.width < 16 || out.config.width > 4096 || out.config.height < 16 ||
            out.config.height > 4096 || out.config.base_channels > 256 ||
            !(out.height_range_m > 0)) {
          return fail("implausible config");
        }
        out.net = SegmentationNet(out.config);  // throws invalid_argument on other bad configs
        torch::serialize::InputArchive weights;
        if (!archive.try_read("net", weights)) return fail("no network weights");
        out.net->load(weights);
        out.net->eval();
        return out;
      });
}

}  // namespace softgrasp::models
