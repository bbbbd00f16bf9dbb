// Fuzzes the mesh decoders (OBJ, PLY, STL; sniffed). A successful decode must respect the
// limits, hold only in-range indices and finite coordinates, and survive a write/read round trip
// (exactly for OBJ and PLY; STL is float32 and welds, so only success is required).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "service/mesh/mesh_io.h"

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
  return 0;
}
