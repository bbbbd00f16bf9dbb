#include "service/models/gqcnn_model.h"

#include <algorithm>
#include <mutex>
#include <stdexcept>
#include <string>

#include "service/gqcnn/dataset_format.h"
#include "service/models/gqcnn_network.h"
#include "service/models/network.h"

namespace softgrasp::models {

struct GqcnnModel::Impl {
  LoadedGqcnnNet loaded;
  std::string description;
  std::int64_t parameters = 0;
  double decision_threshold = 0.5;
  nlohmann::json decision_threshold_card;  // null without one
  mutable std::mutex mutex;
};

GqcnnModel::GqcnnModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GqcnnModel::GqcnnModel(GqcnnModel&&) noexcept = default;
GqcnnModel& GqcnnModel::operator=(GqcnnModel&&) noexcept = default;
GqcnnModel::~GqcnnModel() = default;

core::Result<GqcnnModel> GqcnnModel::Load(const std::filesystem::path& path) {
  auto loaded = LoadGqcnnNet(path);
  if (!loaded.ok()) return loaded.error();
  auto impl = std::make_unique<Impl>();
  impl->loaded = std::move(loaded.value());
  impl->parameters = CountParameters(*impl->loaded.net);
  if (const auto it = impl->loaded.card.find("decision_threshold"); it != impl->loaded.card.end()) {
    const nlohmann::json* p = it->is_object() && it->contains("p") ? &it->at("p") : nullptr;
    const double value = p && p->is_number() ? p->get<double>() : -1.0;
    if (!(value > 0.0 && value < 1.0)) {
      return core::MakeError(core::ErrorCode::kUnprocessable,
                             path.string() +
                                 ": the card's decision_threshold must be {\"p\": a number in "
                                 "(0, 1), ...}",
                             "model");
    }
    impl->decision_threshold = value;
    impl->decision_threshold_card = *it;
  }
  FlushSubnormalParameters(*impl->loaded.net);
  const GqcnnNetConfig& c = impl->loaded.config;
  impl->description =
      "GQ-CNN conv " + std::to_string(c.conv1_1_kernel) + "x" + std::to_string(c.conv1_1_kernel) +
      "/" + std::to_string(c.conv1_2_kernel) + "x" + std::to_string(c.conv1_2_kernel) + "x" +
      std::to_string(c.conv1_channels) + ", 3x3x" + std::to_string(c.conv2_channels) + ", fc3 " +
      std::to_string(c.fc3_units) + ", pc1 " + std::to_string(c.pc1_units) + ", fc4 " +
      std::to_string(c.fc4_units) + ", " + std::to_string(impl->parameters) + " parameters" +
      (c.factored ? ", factored output" : "") + (c.clearance_inputs ? ", clearance inputs" : "");
  return GqcnnModel(std::move(impl));
}

std::vector<float> GqcnnModel::Predict(std::span<const float> crops, std::span<const float> depths,
                                       std::span<const float> clearances) const {
  if (crops.size() != depths.size() * gqcnn::kCropPixels) {
    throw std::invalid_argument("GqcnnModel::Predict: " + std::to_string(crops.size()) +
                                " crop values for " + std::to_string(depths.size()) +
                                " grasp depths (expected " + std::to_string(gqcnn::kCropPixels) +
                                " per grasp)");
  }
  const bool taken = takes_clearances();
  if ((!clearances.empty() || taken) && clearances.size() != depths.size() * 3) {
    throw std::invalid_argument("GqcnnModel::Predict: " + std::to_string(clearances.size()) +
                                " clearance values for " + std::to_string(depths.size()) +
                                " grasp depths (expected 3 per grasp" +
                                (taken ? "; this network takes them)" : " or none)"));
  }
  constexpr std::size_t kChunk = 256;
  std::vector<float> out(depths.size());
  std::lock_guard<std::mutex> lock(impl_->mutex);
  torch::NoGradGuard no_grad;
  for (std::size_t begin = 0; begin < depths.size(); begin += kChunk) {
    const std::size_t n = std::min(kChunk, depths.size() - begin);
    torch::Tensor images, poses;
    NormaliseGqcnnInputs(crops.data() + begin * gqcnn::kCropPixels, depths.data() + begin,
                         taken ? clearances.data() + begin * 3 : nullptr,
                         static_cast<std::int64_t>(n), impl_->loaded.config,
                         impl_->loaded.normalisation, &images, &poses);
    const torch::Tensor p =
        GqcnnSuccessProbability(impl_->loaded.net->forward(images, poses), impl_->loaded.config)
            .contiguous();
    std::copy_n(p.data_ptr<float>(), n, out.begin() + static_cast<std::ptrdiff_t>(begin));
  }
  return out;
}

bool GqcnnModel::takes_clearances() const { return impl_->loaded.config.clearance_inputs; }
const nlohmann::json& GqcnnModel::Card() const { return impl_->loaded.card; }
double GqcnnModel::decision_threshold() const { return impl_->decision_threshold; }
const nlohmann::json& GqcnnModel::decision_threshold_card() const {
  return impl_->decision_threshold_card;
}
std::int64_t GqcnnModel::parameter_count() const { return impl_->parameters; }
const std::string& GqcnnModel::description() const { return impl_->description; }

}  // namespace softgrasp::models
