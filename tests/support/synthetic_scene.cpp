#include "tests/support/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>

namespace softgrasp::testing {
namespace {

struct Vec3 {
  double x, y, z;
};

struct Ray {  // in table coordinates; the parameter t is the camera depth (optical-axis z)
  Vec3 origin;
  Vec3 dir;
};

// Table point -> tilted frame (before the vertical flip to the camera): rotation about x.
Vec3 TiltTableToCameraAxes(const Vec3& p, double tilt) {
  const double c = std::cos(tilt), s = std::sin(tilt);
  return {p.x, p.y * c - p.z * s, p.y * s + p.z * c};
}

Vec3 TiltCameraAxesToTable(const Vec3& p, double tilt) {
  const double c = std::cos(tilt), s = std::sin(tilt);
  return {p.x, p.y * c + p.z * s, -p.y * s + p.z * c};
}

// Camera point (X, Y, Z) corresponds to tilted-frame point (X, Y, H - Z).
Ray PixelRay(const SceneSpec& spec, double u, double v) {
  const core::Camera& cam = spec.camera;
  const double rx = (u - cam.cx) / cam.fx;
  const double ry = (v - cam.cy) / cam.fy;
  return {TiltCameraAxesToTable({0, 0, spec.camera_height_m}, spec.table_tilt_rad),
          TiltCameraAxesToTable({rx, ry, -1}, spec.table_tilt_rad)};
}

double HitTable(const Ray& ray) {
  if (!(ray.dir.z < 0)) return std::numeric_limits<double>::infinity();
  const double t = -ray.origin.z / ray.dir.z;
  return t > 0 ? t : std::numeric_limits<double>::infinity();
}

// Slab test in the box's own frame. Returns the entry depth or +inf.
double HitBox(const Ray& ray, const Box& box) {
  const double c = std::cos(box.yaw_rad), s = std::sin(box.yaw_rad);
  const double ox = ray.origin.x - box.x_m, oy = ray.origin.y - box.y_m;
  const double o[3] = {c * ox + s * oy, -s * ox + c * oy, ray.origin.z};
  const double d[3] = {c * ray.dir.x + s * ray.dir.y, -s * ray.dir.x + c * ray.dir.y, ray.dir.z};
  const double lo[3] = {-box.size_x_m / 2, -box.size_y_m / 2, 0.0};
  const double hi[3] = {box.size_x_m / 2, box.size_y_m / 2, box.height_m};
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0) {
      if (o[i] < lo[i] || o[i] > hi[i]) return std::numeric_limits<double>::infinity();
      continue;
    }
    const double t0 = (lo[i] - o[i]) / d[i];
    const double t1 = (hi[i] - o[i]) / d[i];
    t_near = std::max(t_near, std::min(t0, t1));
    t_far = std::min(t_far, std::max(t0, t1));
  }
  if (t_near > t_far || t_near <= 0) return std::numeric_limits<double>::infinity();
  return t_near;
}

}  // namespace

SyntheticScene RenderScene(const SceneSpec& spec) {
  const core::Camera& cam = spec.camera;
  SyntheticScene scene;
  scene.camera = cam;
  scene.depth.depth_m = cv::Mat1f(cam.height, cam.width);
  scene.object_id = cv::Mat1i(cam.height, cam.width);
  scene.height_m = cv::Mat1f(cam.height, cam.width);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const Ray ray = PixelRay(spec, u, v);
      double t = HitTable(ray);
      int id = std::isfinite(t) ? kTableId : kNothingId;
      for (const Box& box : spec.boxes) {
        const double tb = HitBox(ray, box);
        if (tb < t) {
          t = tb;
          id = box.id;
        }
      }
      const bool hit = std::isfinite(t);
      scene.depth.depth_m(v, u) =
          hit ? static_cast<float>(t) : std::numeric_limits<float>::quiet_NaN();
      scene.object_id(v, u) = id;
      scene.height_m(v, u) = hit ? static_cast<float>(ray.origin.z + t * ray.dir.z)
                                 : std::numeric_limits<float>::quiet_NaN();
    }
  }
  return scene;
}

cv::Point3d TableToCamera(const SceneSpec& spec, double x_m, double y_m, double z_m) {
  const Vec3 p = TiltTableToCameraAxes({x_m, y_m, z_m}, spec.table_tilt_rad);
  return {p.x, p.y, spec.camera_height_m - p.z};
}

cv::Point2d ProjectTablePoint(const SceneSpec& spec, double x_m, double y_m, double z_m) {
  const cv::Point3d p = TableToCamera(spec, x_m, y_m, z_m);
  return {spec.camera.cx + spec.camera.fx * p.x / p.z, spec.camera.cy + spec.camera.fy * p.y / p.z};
}

SceneSpec ClutterSceneSpec() {
  SceneSpec spec;
  spec.boxes = {
      {-0.20, -0.12, 0.030, 0.080, 0.040, 0.3, 1},  // slim box, graspable across
      {-0.05, -0.15, 0.060, 0.060, 0.070, 0.0, 2},  // wide and tall: not graspable
      {0.15, -0.10, 0.025, 0.050, 0.055, 1.2, 3},   // small, rotated
      {-0.15, 0.10, 0.040, 0.040, 0.030, 0.7, 4},   // low cube
      {0.05, 0.12, 0.030, 0.040, 0.045, 0.0, 5},    // two boxes pressed together ...
      {0.08, 0.12, 0.030, 0.040, 0.060, 0.0, 6},    // ... with different heights
      {0.22, 0.12, 0.035, 0.090, 0.035, -0.4, 7},   // long, low
      {0.00, 0.00, 0.045, 0.030, 0.050, 0.0, 8},    // in the middle
  };
  return spec;
}

namespace {

// The integers of the header's 'shape': (...) tuple; empty if there is none.
std::vector<int> NpyShape(const std::string& header) {
  const auto key = header.find("'shape':");
  const auto open = header.find('(', key);
  const auto close = header.find(')', open);
  if (key == std::string::npos || open == std::string::npos || close == std::string::npos) {
    return {};
  }
  std::vector<int> shape;
  const char* p = header.c_str() + open + 1;
  const char* end = header.c_str() + close;
  while (p < end) {
    char* next = nullptr;
    const long value = std::strtol(p, &next, 10);
    if (next == p) {
      ++p;  // skip ',' and spaces
      continue;
    }
    shape.push_back(static_cast<int>(value));
    p = next;
  }
  return shape;
}

}  // namespace

cv::Mat1f LoadNpyFloat32(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < 10 || bytes.compare(0, 6, "\x93NUMPY") != 0) {
    throw std::runtime_error(path + ": not an .npy file");
  }
  const auto major = static_cast<std::uint8_t>(bytes[6]);
  const std::size_t len_bytes = major == 1 ? 2 : 4;
  std::size_t header_len = 0;
  for (std::size_t i = 0; i < len_bytes; ++i) {
    header_len |= static_cast<std::size_t>(static_cast<std::uint8_t>(bytes[8 + i])) << (8 * i);
  }
  const std::size_t data_offset = 8 + len_bytes + header_len;
  const std::string header = bytes.substr(8 + len_bytes, header_len);
  const std::vector<int> shape = NpyShape(header);
  const bool one_channel = shape.size() == 2 || (shape.size() == 3 && shape[2] == 1);
  if (header.find("'<f4'") == std::string::npos ||
      header.find("'fortran_order': False") == std::string::npos || !one_channel) {
    throw std::runtime_error(path + ": expected C-order <f4 of shape (rows, cols[, 1])");
  }
  const int rows = shape[0];
  const int cols = shape[1];
  const std::size_t data_bytes =
      static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * 4;
  if (bytes.size() < data_offset + data_bytes) throw std::runtime_error(path + ": truncated");
  cv::Mat1f out(rows, cols);
  std::memcpy(out.data, bytes.data() + data_offset, data_bytes);  // little-endian host
  return out;
}

}  // namespace softgrasp::testing
