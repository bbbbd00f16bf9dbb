// Camera intrinsics as JSON, in the layouts robot software writes them:
// - GQ-CNN / autolab_core `.intr`: {"_frame": "primesense_overhead", "_fx": 525.0, "_fy": 525.0,
//   "_cx": 319.5, "_cy": 239.5, "_skew": 0.0, "_height": 480, "_width": 640, "_K": 0};
// - ROS sensor_msgs/CameraInfo (ROS 1 "K", "P", ROS 2 "k", "p"): {"width", "height", "K": [fx, 0,
//   cx, 0, fy, cy, 0, 0, 1], "P": [fx', 0, cx', Tx, 0, fy', cy', Ty, 0, 0, 1, 0], "binning_x",
//   "binning_y", "roi", ...}, row-major; read as ROS's image_geometry reads it (below);
// - Open3D's PinholeCameraIntrinsic: {"width", "height", "intrinsic_matrix": [fx, 0, 0, 0, fy, 0,
//   cx, cy, 1]}, column-major;
// - librealsense's rs2_intrinsics: {"width", "height", "ppx", "ppy", "fx", "fy", ...}.
// Only the pinhole parameters and the image size are used (skew, distortion and frame names are
// ignored).
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

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
    "CameraInfo ({\"width\", \"height\", \"K\" or \"k\": 9 numbers, row-major; \"P\" or \"p\": "
    "12}), Open3D's "
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

/// A 3 x `columns` matrix as 3 x columns numbers (or 3 rows), row-major (ROS) or column-major
/// (Open3D), as rows of `columns` numbers.
core::Result<std::vector<double>> ReadMatrix(const json& doc, const std::string& key, int columns,
                                             bool column_major) {
  const json& value = doc.at(key);
  const auto count = static_cast<std::size_t>(3 * columns);
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
  const std::string shape = "3 x " + std::to_string(columns);
  if (flat.size() != count) {
    return IntrinsicsError("intrinsics '" + key + "' must be a " + shape + " matrix (" +
                               std::to_string(count) + " numbers)",
                           key);
  }
  std::vector<double> m(count);
  for (std::size_t i = 0; i < count; ++i) {
    if (!flat[i].is_number() || !std::isfinite(flat[i].get<double>())) {
      return IntrinsicsError(
          "intrinsics '" + key + "' must hold " + std::to_string(count) + " finite numbers", key);
    }
    // Element (row r, column c) of the matrix at index r * columns + c.
    const std::size_t cols = static_cast<std::size_t>(columns);
    const std::size_t r = column_major ? i % 3 : i / cols;
    const std::size_t c = column_major ? i / 3 : i % cols;
    m[r * cols + c] = flat[i].get<double>();
  }
  return m;
}

/// The pinhole parameters of a camera matrix [fx, s, cx; 0, fy, cy; 0, 0, 1] (the left 3 x 3 of
/// `m`, rows of `columns`). Its last row must be (0, 0, 1) and fx, fy positive: a matrix in the
/// other order is refused rather than read with the principal point in the wrong place.
struct Pinhole {
  double fx, fy, cx, cy;
};
core::Result<Pinhole> CameraMatrix(const std::vector<double>& m, int columns,
                                   const std::string& key, bool column_major) {
  auto at = [&](int r, int c) { return m[static_cast<std::size_t>(r * columns + c)]; };
  const bool last_row =
      at(2, 0) == 0.0 && at(2, 1) == 0.0 && at(2, 2) == 1.0 && (columns == 3 || at(2, 3) == 0.0);
  if (!last_row || !(at(0, 0) > 0.0) || !(at(1, 1) > 0.0) || at(1, 0) != 0.0) {
    return IntrinsicsError("intrinsics '" + key + "' is not a camera matrix " +
                               (columns == 3 ? "[fx, s, cx; 0, fy, cy; 0, 0, 1] "
                                             : "[fx, s, cx, Tx; 0, fy, cy, Ty; 0, 0, 1, 0] ") +
                               (column_major ? "stored column-major" : "stored row-major"),
                           key);
  }
  return Pinhole{at(0, 0), at(1, 1), at(0, 2), at(1, 2)};
}

/// Open3D's `intrinsic_matrix`: 3 x 3, column-major.
core::Result<core::Camera> ParseOpen3d(const json& doc) {
  const std::string key = "intrinsic_matrix";
  auto m = ReadMatrix(doc, key, 3, /*column_major=*/true);
  if (!m) return m.error();
  auto p = CameraMatrix(m.value(), 3, key, /*column_major=*/true);
  if (!p) return p.error();
  return MakeCamera(p.value().fx, p.value().fy, p.value().cx, p.value().cy, doc, "width", "height");
}

/// A non-negative integer of a ROS CameraInfo (binning, region of interest); `fallback` when
/// the key is absent.
core::Result<int> ReadCount(const json& doc, const std::string& key, const std::string& field,
                            int fallback) {
  const auto it = doc.find(key);
  if (it == doc.end()) return fallback;
  const double v = it->is_number() ? it->get<double>() : -1.0;
  if (!(v >= 0.0) || v != std::floor(v) || v > 1e6) {
    return IntrinsicsError("intrinsics '" + field + "' must be a non-negative integer", field);
  }
  return static_cast<int>(v);
}

/// ROS sensor_msgs/CameraInfo, read as ROS's image_geometry::PinholeCameraModel reads it:
/// - the camera is P's left 3 x 3, the camera of the rectified image (image_rect, registered
///   depth: the frames a grasp planner is given); K, the raw image's, when P is absent or all
///   zeros (an uncalibrated camera). P's last column (a stereo pair's baseline) is not used:
///   grasps are in this camera's own optical frame. D (distortion) and R are not used.
/// - a region of interest (`roi`, in full-resolution pixels; all zeros = the whole image) moves
///   the principal point by its offset and is the image's size; binning (`binning_x`,
///   `binning_y`; 0 or 1 = none) then divides fx, cx, the width (and y likewise).
core::Result<core::Camera> ParseRosCameraInfo(const json& doc) {
  std::optional<Pinhole> pinhole;
  for (const char* key : {"P", "p"}) {
    if (!doc.contains(key)) continue;
    auto m = ReadMatrix(doc, key, 4, /*column_major=*/false);
    if (!m) return m.error();
    if (std::all_of(m.value().begin(), m.value().end(), [](double v) { return v == 0.0; })) break;
    auto p = CameraMatrix(m.value(), 4, key, /*column_major=*/false);
    if (!p) return p.error();
    pinhole = p.value();
    break;
  }
  for (const char* key : {"K", "k"}) {
    if (pinhole || !doc.contains(key)) continue;
    auto m = ReadMatrix(doc, key, 3, /*column_major=*/false);
    if (!m) return m.error();
    auto p = CameraMatrix(m.value(), 3, key, /*column_major=*/false);
    if (!p) return p.error();
    pinhole = p.value();
  }
  if (!pinhole) {
    return IntrinsicsError("intrinsics 'P' is all zeros and there is no 'K' to fall back on", "P");
  }
  auto full =
      MakeCamera(pinhole->fx, pinhole->fy, pinhole->cx, pinhole->cy, doc, "width", "height");
  if (!full) return full.error();
  core::Camera camera = full.value();
  // Region of interest, then binning (image_geometry's order).
  if (const auto roi = doc.find("roi"); roi != doc.end() && !roi->is_null()) {
    if (!roi->is_object()) return IntrinsicsError("intrinsics 'roi' must be an object", "roi");
    int v[4] = {};
    const char* keys[4] = {"x_offset", "y_offset", "width", "height"};
    for (int i = 0; i < 4; ++i) {
      auto n = ReadCount(*roi, keys[i], std::string("roi.") + keys[i], 0);
      if (!n) return n.error();
      v[i] = n.value();
    }
    const auto [x, y, w, h] = std::tuple{v[0], v[1], v[2], v[3]};
    const bool whole = x == 0 && y == 0 && w == 0 && h == 0;
    if (!whole) {
      if (w == 0 || h == 0 || x + w > camera.width || y + h > camera.height) {
        return IntrinsicsError("intrinsics 'roi' (" + std::to_string(w) + "x" + std::to_string(h) +
                                   " at " + std::to_string(x) + ", " + std::to_string(y) +
                                   ") must lie inside the " + std::to_string(camera.width) + "x" +
                                   std::to_string(camera.height) + " image",
                               "roi");
      }
      camera.cx -= x;
      camera.cy -= y;
      camera.width = w;
      camera.height = h;
    }
  }
  auto bx = ReadCount(doc, "binning_x", "binning_x", 1);
  if (!bx) return bx.error();
  auto by = ReadCount(doc, "binning_y", "binning_y", 1);
  if (!by) return by.error();
  const int binning_x = std::max(1, bx.value()), binning_y = std::max(1, by.value());
  if (binning_x > camera.width) {
    return IntrinsicsError("intrinsics 'binning_x' is larger than the image", "binning_x");
  }
  if (binning_y > camera.height) {
    return IntrinsicsError("intrinsics 'binning_y' is larger than the image", "binning_y");
  }
  camera.fx /= binning_x;
  camera.cx /= binning_x;
  camera.width /= binning_x;
  camera.fy /= binning_y;
  camera.cy /= binning_y;
  camera.height /= binning_y;
  return camera;
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
  for (const char* key : {"K", "k", "P", "p"}) {
    if (doc.contains(key)) return ParseRosCameraInfo(doc);
  }
  if (doc.contains("intrinsic_matrix")) return ParseOpen3d(doc);
  if (doc.contains("ppx")) return ParsePinhole(doc, kRealsenseKeys);
  return IntrinsicsError(std::string("intrinsics in no known layout: ") + kLayouts, "intrinsics");
}

}  // namespace softgrasp::io
