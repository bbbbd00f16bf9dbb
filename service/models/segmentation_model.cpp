#include "service/models/segmentation_model.h"

#include <cmath>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "service/models/network.h"
#include "service/models/segmentation_network.h"
#include "service/models/stiffness_model.h"

namespace softgrasp::models {

struct SegmentationModel::Impl {
  LoadedSegmentationNet loaded;
  std::string description;
  std::int64_t parameters = 0;
  mutable std::mutex mutex;  // one forward at a time: the 2-core budget is shared anyway
};

SegmentationModel::SegmentationModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SegmentationModel::SegmentationModel(SegmentationModel&&) noexcept = default;
SegmentationModel& SegmentationModel::operator=(SegmentationModel&&) noexcept = default;
SegmentationModel::~SegmentationModel() = default;

core::Result<SegmentationModel> SegmentationModel::Load(const std::filesystem::path& path) {
  auto loaded = LoadSegmentationNet(path);
  if (!loaded.ok()) return loaded.error();
  auto impl = std::make_unique<Impl>();
  impl->loaded = std::move(loaded.value());
  if (auto mismatch = HeightRangeMismatch(path, impl->loaded.height_range_m)) return *mismatch;
  const SegmentationNetConfig& c = impl->loaded.config;
  impl->parameters = CountParameters(*impl->loaded.net);
  impl->description = "segmentation U-Net " + std::to_string(c.width) + "x" +
                      std::to_string(c.height) + ", " + std::to_string(c.levels) +
                      " levels, base " + std::to_string(c.base_channels) + " channels, " +
                      std::to_string(impl->parameters) + " parameters";
  return SegmentationModel(std::move(impl));
}

int SegmentationModel::input_width() const { return impl_->loaded.config.width; }
int SegmentationModel::input_height() const { return impl_->loaded.config.height; }
std::int64_t SegmentationModel::parameter_count() const { return impl_->parameters; }
const std::string& SegmentationModel::description() const { return impl_->description; }

SegmentationOutput SegmentationModel::SegmentScene(const core::Scene& scene,
                                                   const GroupingParams& grouping) const {
  const int w = input_width();
  const int h = input_height();
  cv::Mat1f input = MakeModelInput(scene, cv::Size(w, h));
  HeadMaps heads;
  cv::Mat1f deformability_small(h, w);
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    torch::NoGradGuard no_grad;
    const torch::Tensor x = torch::from_blob(input.ptr<float>(), {1, 1, h, w}, torch::kFloat32);
    torch::Tensor y = impl_->loaded.net->forward(x)[0];
    auto plane = [&](int channel, bool sigmoid, float scale) {
      torch::Tensor t = y[channel];
      if (sigmoid) t = torch::sigmoid(t);
      if (scale != 1.0f) t = t * scale;
      t = t.contiguous();
      return cv::Mat1f(h, w, t.data_ptr<float>()).clone();
    };
    heads.foreground = plane(kHeadForeground, true, 1.0f);
    heads.centre = plane(kHeadCentre, false, 1.0f);  // regressed directly (MSE), no sigmoid
    heads.offset_u_px = plane(kHeadOffsetU, false, kOffsetScalePx);
    heads.offset_v_px = plane(kHeadOffsetV, false, kOffsetScalePx);
    deformability_small = plane(kHeadDeformability, true, 1.0f);
  }
  SegmentationOutput out;
  const cv::Size size = scene.height_m.size();
  out.instances = GroupInstances(heads, size, grouping, &out.foreground);
  cv::resize(deformability_small, out.deformability, size, 0, 0, cv::INTER_LINEAR);
  cv::min(cv::max(out.deformability, 0.0f), 1.0f, out.deformability);
  out.deformability.setTo(0.0f, out.instances.labels == 0);
  return out;
}

}  // namespace softgrasp::models
