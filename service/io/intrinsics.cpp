// GQ-CNN / autolab_core `.intr` camera intrinsics, e.g.
// {"_frame": "primesense_overhead", "_fx": 525.0, "_fy": 525.0, "_cx": 319.5, "_cy": 239.5,
//  "_skew": 0.0, "_height": 480, "_width": 640, "_K": 0}
// Only the pinhole parameters and the image size are used; "_frame", "_skew" and "_K" are ignored.
#include <climits>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "service/io/depth_codec.h"

namespace softgrasp::io {
namespace {

using nlohmann::json;

core::Error IntrinsicsError(const std::string& message, const std::string& field) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, message, field);
}

core::Result<double> ReadNumber(const json& doc, const std::string& key) {
  const auto it = doc.find(key);
  if (it == doc.end()) return IntrinsicsError("intrinsics lack the key '" + key + "'", key);
  if (!it->is_number()) return IntrinsicsError("intrinsics '" + key + "' must be a number", key);
  const double value = it->get<double>();
  if (!std::isfinite(value)) {
    return IntrinsicsError("intrinsics '" + key + "' must be finite", key);
  }
  return value;
}

core::Result<double> ReadPositive(const json& doc, const std::string& key) {
  auto value = ReadNumber(doc, key);
  if (value && value.value() <= 0) {
    return IntrinsicsError("intrinsics '" + key + "' must be positive", key);
  }
  return value;
}

core::Result<int> ReadImageSide(const json& doc, const std::string& key) {
  const auto value = ReadPositive(doc, key);
  if (!value) return value.error();
  const double side = value.value();
  if (side != std::floor(side) || side > INT_MAX) {
    return IntrinsicsError("intrinsics '" + key + "' must be a positive integer", key);
  }
  return static_cast<int>(side);
}

}  // namespace

core::Result<core::Camera> ParseIntrinsicsJson(std::string_view text) {
  const json doc = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return IntrinsicsError(
        "intrinsics must be a JSON object like GQ-CNN's .intr files "
        "({\"_fx\", \"_fy\", \"_cx\", \"_cy\", \"_width\", \"_height\"})",
        "intrinsics");
  }
  const auto fx = ReadPositive(doc, "_fx");
  if (!fx) return fx.error();
  const auto fy = ReadPositive(doc, "_fy");
  if (!fy) return fy.error();
  const auto cx = ReadNumber(doc, "_cx");
  if (!cx) return cx.error();
  const auto cy = ReadNumber(doc, "_cy");
  if (!cy) return cy.error();
  const auto width = ReadImageSide(doc, "_width");
  if (!width) return width.error();
  const auto height = ReadImageSide(doc, "_height");
  if (!height) return height.error();
  return core::Camera{fx.value(), fy.value(),    cx.value(),
                      cy.value(), width.value(), height.value()};
}

}  // namespace softgrasp::io
