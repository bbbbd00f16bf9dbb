// Fuzzes the mesh decoders (OBJ, PLY, STL; sniffed) and the preparation of what they decode. A
// successful decode must respect the limits, hold only in-range indices and finite coordinates,
// and survive a write/read round trip (exactly for OBJ and PLY; STL is float32 and welds, so only
// success is required). PrepareMesh (small limits; with and without Dex-Net's rescale) must then
// give a closed, 2-manifold, connected, outward solid with finite coordinates within the limits,
// or refuse with kUnprocessable or kTooLarge on field "mesh": nothing else, and no crash.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "service/mesh/mesh_check.h"
#include "service/mesh/mesh_io.h"
#include "service/mesh/mesh_prepare.h"

namespace {

using softgrasp::mesh::Encoding;
using softgrasp::mesh::TriangleMesh;

constexpr std::int64_t kMaxVertices = 1 << 14;
constexpr std::int64_t kMaxFaces = 1 << 15;

void CheckDecoded(const TriangleMesh& mesh) {
  if (mesh.faces.empty() || static_cast<std::int64_t>(mesh.faces.size()) > kMaxFaces ||
      static_cast<std::int64_t>(mesh.vertices.size()) > kMaxVertices) {
    std::abort();
  }
  const auto nv = static_cast<int>(mesh.vertices.size());
  for (const auto& f : mesh.faces) {
    for (const int i : f) {
      if (i < 0 || i >= nv) std::abort();
    }
  }
  for (const auto& v : mesh.vertices) {
    for (const double x : v) {
      if (!std::isfinite(x)) std::abort();
    }
  }
}

constexpr std::int64_t kMaxPrepareTriangles = 1 << 12;

void CheckPrepared(const TriangleMesh& decoded, const softgrasp::mesh::PrepareOptions& options) {
  using softgrasp::core::ErrorCode;
  const auto prepared = softgrasp::mesh::PrepareMesh(decoded, options);
  if (!prepared.ok()) {
    const auto& e = prepared.error();
    const bool allowed = e.code == ErrorCode::kUnprocessable ||
                         (e.code == ErrorCode::kTooLarge &&
                          static_cast<std::int64_t>(decoded.faces.size()) > options.max_triangles);
    if (!allowed || e.field != "mesh" || e.message.empty()) std::abort();
    return;
  }
  const softgrasp::mesh::PreparedMesh& p = prepared.value();
  const TriangleMesh& m = p.mesh;
  // Filled holes add faces (a hole of k edges takes k - 2 triangles between its own vertices),
  // never vertices; everything else only drops or flips.
  const auto& c = p.counts;
  if (c.hole_faces_added != c.filled_hole_edges - 2 * c.filled_holes || c.filled_holes < 0 ||
      !(c.filled_area_fraction >= 0.0 &&
        c.filled_area_fraction <= options.fill_hole_max_area_fraction)) {
    std::abort();
  }
  if (m.faces.empty() ||
      static_cast<std::int64_t>(m.faces.size()) > options.max_triangles + c.hole_faces_added ||
      m.faces.size() > decoded.faces.size() + static_cast<std::size_t>(c.hole_faces_added) ||
      m.vertices.size() > decoded.vertices.size()) {
    std::abort();
  }
  for (const auto& v : m.vertices) {
    for (const double x : v) {
      if (!std::isfinite(x)) std::abort();
    }
  }
  const auto r = softgrasp::mesh::CheckMesh(m, {.self_intersections = false});
  if (!(r.indices_valid && r.closed && r.edge_manifold && r.vertex_manifold && r.connected &&
        r.consistently_oriented && r.outward && r.num_degenerate_faces == 0 &&
        r.num_unreferenced_vertices == 0 && r.num_nonfinite_vertices == 0)) {
    std::abort();
  }
  if (!(p.volume_m3 > 0.0) || !std::isfinite(p.volume_m3) ||
      !(p.extents_m[0] >= options.min_extent_m) || !(p.extents_m[2] <= options.max_extent_m) ||
      !(p.scale_applied > 0.0) || !std::isfinite(p.scale_applied)) {
    std::abort();
  }
  // Rescaled: the smallest principal extent is the target, up to the rounding of coordinates
  // (far from the origin, a span is a difference of large numbers).
  if (options.rescale_min_extent_m) {
    double largest = 0.0;
    for (const auto& v : m.vertices) {
      for (const double x : v) largest = std::max(largest, std::abs(x));
    }
    const double target = *options.rescale_min_extent_m;
    if (!(std::abs(p.extents_m[0] - target) <= 1e-9 * target + 1e-13 * largest)) std::abort();
  }
  for (const auto& line : p.repairs) {
    if (line.empty()) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  softgrasp::mesh::MeshReadOptions options;
  options.max_vertices = kMaxVertices;
  options.max_faces = kMaxFaces;
  const auto mesh = softgrasp::mesh::ReadMesh(bytes, options);
  if (!mesh.ok()) return 0;
  const TriangleMesh& m = mesh.value();
  CheckDecoded(m);

  // Exact round trips through the lossless formats.
  for (const auto& written :
       {softgrasp::mesh::WriteObj(m), softgrasp::mesh::WritePly(m, Encoding::kAscii),
        softgrasp::mesh::WritePly(m, Encoding::kBinary)}) {
    const auto back = softgrasp::mesh::ReadMesh(written, options);
    if (!back.ok() || !(back.value() == m)) std::abort();
  }
  // STL needs float32-finite coordinates; when it can be written it must read back.
  bool float_ok = true;
  for (const auto& v : m.vertices) {
    for (const double x : v) float_ok = float_ok && std::isfinite(static_cast<float>(x));
  }
  if (float_ok) {
    for (const Encoding e : {Encoding::kAscii, Encoding::kBinary}) {
      if (!softgrasp::mesh::ReadMesh(softgrasp::mesh::WriteStl(m, e), options).ok()) std::abort();
    }
  }

  // Preparation: wide size limits so that odd inputs get through to the later steps.
  softgrasp::mesh::PrepareOptions prepare;
  prepare.max_triangles = kMaxPrepareTriangles;
  prepare.min_extent_m = 1e-9;
  prepare.max_extent_m = 1e9;
  prepare.max_debris_volume_fraction = 0.01;
  prepare.self_intersection_min_box_pairs = 20000;
  CheckPrepared(m, prepare);
  prepare.unit_scale_m = 0.001;
  prepare.rescale_min_extent_m = 0.04;
  prepare.self_intersections = softgrasp::mesh::SelfIntersectionPolicy::kRefuse;
  CheckPrepared(m, prepare);
  return 0;
}
