#include "service/models/stiffness_model.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "service/models/network.h"

namespace softgrasp::models {

cv::Mat1f MakeModelInput(const core::Scene& scene, cv::Size size) {
  cv::Mat1f resized;
  cv::resize(scene.height_m, resized, size, 0, 0, cv::INTER_AREA);
  cv::Mat1f out(size);
  const float scale = static_cast<float>(2.0 / kInputHeightRangeM);
  const float range = static_cast<float>(kInputHeightRangeM);
  for (int r = 0; r < size.height; ++r) {
    const float* src = resized.ptr<float>(r);
    float* dst = out.ptr<float>(r);
    for (int c = 0; c < size.width; ++c) {
      // NaN (no floor intersection) counts as floor level.
      const float h = std::isfinite(src[c]) ? std::clamp(src[c], 0.0f, range) : 0.0f;
      dst[c] = h * scale - 1.0f;
    }
  }
  return out;
}

void SetTorchThreads(int n) {
  const int per_cpu = static_cast<int>(std::thread::hardware_concurrency());
  torch::set_num_threads(n > 0 ? n : std::max(1, per_cpu));
}

struct StiffnessModel::Impl {
  LoadedGenerator loaded;
  std::string description;
  std::int64_t parameters = 0;
  mutable std::mutex mutex;  // one forward at a time: the 2-core budget is shared anyway
};

StiffnessModel::StiffnessModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
StiffnessModel::StiffnessModel(StiffnessModel&&) noexcept = default;
StiffnessModel& StiffnessModel::operator=(StiffnessModel&&) noexcept = default;
StiffnessModel::~StiffnessModel() = default;

core::Result<StiffnessModel> StiffnessModel::Load(const std::filesystem::path& path) {
  auto loaded = LoadGenerator(path);
  if (!loaded.ok()) return loaded.error();
  auto impl = std::make_unique<Impl>();
  impl->loaded = std::move(loaded.value());
  if (auto mismatch = HeightRangeMismatch(path, impl->loaded.height_range_m)) return *mismatch;
  const NetworkConfig& c = impl->loaded.config;
  impl->parameters = CountParameters(*impl->loaded.generator);
  FlushSubnormalParameters(*impl->loaded.generator);
  impl->description = "pix2stiffness U-Net " + std::to_string(c.input_size) + "x" +
                      std::to_string(c.input_size) + ", " + std::to_string(c.levels) +
                      " levels, base " + std::to_string(c.base_channels) + " channels, " +
                      std::to_string(impl->parameters) + " parameters";
  return StiffnessModel(std::move(impl));
}

int StiffnessModel::input_size() const { return impl_->loaded.config.input_size; }
std::int64_t StiffnessModel::parameter_count() const { return impl_->parameters; }
const std::string& StiffnessModel::description() const { return impl_->description; }

cv::Mat1f StiffnessModel::PredictModelInput(const cv::Mat1f& input) const {
  const int side = input_size();
  if (input.rows != side || input.cols != side) {
    throw std::invalid_argument("PredictModelInput: input must be side x side");
  }
  cv::Mat1f in = input.isContinuous() ? input : input.clone();
  std::lock_guard<std::mutex> lock(impl_->mutex);
  torch::NoGradGuard no_grad;
  const torch::Tensor x = torch::from_blob(in.ptr<float>(), {1, 1, side, side}, torch::kFloat32);
  const torch::Tensor y = impl_->loaded.generator->forward(x).contiguous();
  cv::Mat1f out(side, side);
  std::copy_n(y.data_ptr<float>(), static_cast<std::size_t>(side) * side, out.ptr<float>());
  return out;
}

cv::Mat1f StiffnessModel::PredictScene(const core::Scene& scene) const {
  const cv::Mat1f small = PredictModelInput(MakeModelInput(scene, input_size()));
  cv::Mat1f out;
  cv::resize(small, out, scene.height_m.size(), 0, 0, cv::INTER_LINEAR);
  // Bilinear resampling stays within [0, 1]; the clamp only guards rounding.
  cv::min(cv::max(out, 0.0f), 1.0f, out);
  out.setTo(0.0f, out < kBackgroundThreshold);
  return out;
}

core::Result<cv::Mat1f> StiffnessModel::Predict(const core::DepthImage& depth,
                                                const core::Camera& camera,
                                                const core::PreprocessParams& params) const {
  auto scene = core::Preprocess(depth, camera, params);
  if (!scene.ok()) return scene.error();
  return PredictScene(scene.value());
}

}  // namespace softgrasp::models
