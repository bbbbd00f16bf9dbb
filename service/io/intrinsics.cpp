// Camera intrinsics as JSON, in the layouts robot software writes them:
// - GQ-CNN / autolab_core `.intr`: {"_frame": "primesense_overhead", "_fx": 525.0, "_fy": 525.0,
//   "_cx": 319.5, "_cy": 239.5, "_skew": 0.0, "_height": 480, "_width": 640, "_K": 0};
// - ROS sensor_msgs/CameraInfo (ROS 1 "K", ROS 2 "k"): {"width", "height", "K": [fx, 0, cx, 0, fy,
//   cy, 0, 0, 1], ...}, K row-major;
// - Open3D's PinholeCameraIntrinsic: {"width", "height", "intrinsic_matrix": [fx, 0, 0, 0, fy, 0,
//   cx, cy, 1]}, column-major;
// - librealsense's rs2_intrinsics: {"width", "height", "ppx", "ppy", "fx", "fy", ...}.
// Only the pinhole parameters and the image size are used (skew, distortion and frame names are
// ignored).
#include <array>
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

constexpr const char* kLayouts =
    "GQ-CNN's .intr ({\"_fx\", \"_fy\", \"_cx\", \"_cy\", \"_width\", \"_height\"}), a ROS "
    "CameraInfo ({\"width\", \"height\", \"K\" or \"k\": 9 numbers, row-major}), Open3D's "
    "PinholeCameraIntrinsic ({\"width\", \"height\", \"intrinsic_matrix\": 9 numbers, "
    "column-major}) or librealsense's intrinsics ({\"width\", \"height\", \"fx\", \"fy\", "
    "\"ppx\", \"ppy\"})";

core::Result<core::Camera> MakeCamera(double fx, double fy, double cx, double cy, const json& doc,
                                      const std::string& width_key, const std::string& height_key) {
  const auto width = ReadImageSide(doc, width_key);
  if (!width) return width.error();
  const auto height = ReadImageSide(doc, height_key);
  if (!height) return height.error();
  return core::Camera{fx, fy, cx, cy, width.value(), height.value()};
}

/// The key names of a layout that lists the pinhole parameters one by one.
struct PinholeKeys {
  const char* fx;
  const char* fy;
  const char* cx;
  const char* cy;
  const char* width;
  const char* height;
};
constexpr PinholeKeys kIntrKeys{"_fx", "_fy", "_cx", "_cy", "_width", "_height"};
constexpr PinholeKeys kRealsenseKeys{"fx", "fy", "ppx", "ppy", "width", "height"};

core::Result<core::Camera> ParsePinhole(const json& doc, const PinholeKeys& keys) {
  const auto fx = ReadPositive(doc, keys.fx);
  if (!fx) return fx.error();
  const auto fy = ReadPositive(doc, keys.fy);
  if (!fy) return fy.error();
  const auto cx = ReadNumber(doc, keys.cx);
  if (!cx) return cx.error();
  const auto cy = ReadNumber(doc, keys.cy);
  if (!cy) return cy.error();
  return MakeCamera(fx.value(), fy.value(), cx.value(), cy.value(), doc, keys.width, keys.height);
}

/// A 3 x 3 camera matrix as 9 numbers (or 3 rows of 3), row-major (ROS) or column-major
/// (Open3D). Its last row must be (0, 0, 1) and fx, fy positive: a matrix in the other order
/// is refused rather than read with the principal point in the wrong place.
core::Result<core::Camera> ParseMatrix(const json& doc, const std::string& key, bool column_major) {
  const json& value = doc.at(key);
  std::array<double, 9> m{};
  json flat = json::array();
  if (value.is_array()) {
    for (const json& item : value) {
      if (item.is_array()) {
        for (const json& inner : item) flat.push_back(inner);
      } else {
        flat.push_back(item);
      }
    }
  }
  if (flat.size() != 9) {
    return IntrinsicsError("intrinsics '" + key + "' must be a 3 x 3 matrix (9 numbers)", key);
  }
  for (std::size_t i = 0; i < 9; ++i) {
    if (!flat[i].is_number() || !std::isfinite(flat[i].get<double>())) {
      return IntrinsicsError("intrinsics '" + key + "' must hold 9 finite numbers", key);
    }
    // Element (row r, column c) of the matrix at index r * 3 + c.
    const std::size_t r = column_major ? i % 3 : i / 3;
    const std::size_t c = column_major ? i / 3 : i % 3;
    m[r * 3 + c] = flat[i].get<double>();
  }
  const bool last_row = m[6] == 0.0 && m[7] == 0.0 && m[8] == 1.0;
  if (!last_row || !(m[0] > 0.0) || !(m[4] > 0.0) || m[3] != 0.0) {
    return IntrinsicsError("intrinsics '" + key +
                               "' is not a camera matrix [fx, s, cx; 0, fy, cy; 0, 0, 1] " +
                               (column_major ? "stored column-major" : "stored row-major"),
                           key);
  }
  return MakeCamera(m[0], m[4], m[2], m[5], doc, "width", "height");
}

}  // namespace

core::Result<core::Camera> ParseIntrinsicsJson(std::string_view text) {
  const json doc = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return IntrinsicsError(std::string("intrinsics must be a JSON object: ") + kLayouts,
                           "intrinsics");
  }
  const auto& k = kIntrKeys;
  for (const char* key : {k.fx, k.fy, k.cx, k.cy, k.width, k.height}) {
    if (doc.contains(key)) return ParsePinhole(doc, kIntrKeys);
  }
  for (const char* key : {"K", "k"}) {
    if (doc.contains(key)) return ParseMatrix(doc, key, /*column_major=*/false);
  }
  if (doc.contains("intrinsic_matrix")) {
    return ParseMatrix(doc, "intrinsic_matrix", /*column_major=*/true);
  }
  if (doc.contains("ppx")) return ParsePinhole(doc, kRealsenseKeys);
  return IntrinsicsError(std::string("intrinsics in no known layout: ") + kLayouts, "intrinsics");
}

}  // namespace softgrasp::io
