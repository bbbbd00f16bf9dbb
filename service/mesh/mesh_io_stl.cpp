// STL: the writers (ASCII and binary, float32 coordinates, facet normals from the vertex order)
// and the readers, which weld vertices with exactly equal float32 coordinates. Binary values are
// assembled byte by byte in little-endian order, so the bytes do not depend on the host.
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "service/mesh/mesh_io.h"
#include "service/mesh/mesh_io_internal.h"

namespace softgrasp::mesh {
namespace detail {
namespace {

std::array<float, 3> FacetNormal(const std::array<float, 3>& a, const std::array<float, 3>& b,
                                 const std::array<float, 3>& c) {
  const double u[3] = {double{b[0]} - a[0], double{b[1]} - a[1], double{b[2]} - a[2]};
  const double v[3] = {double{c[0]} - a[0], double{c[1]} - a[1], double{c[2]} - a[2]};
  const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                       u[0] * v[1] - u[1] * v[0]};
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (!(len > 0.0) || !std::isfinite(len)) return {0.0f, 0.0f, 0.0f};
  return {static_cast<float>(n[0] / len), static_cast<float>(n[1] / len),
          static_cast<float>(n[2] / len)};
}

std::array<float, 3> AsFloat(const std::array<double, 3>& p) {
  return {static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])};
}

/// Welds float32 vertices that are exactly equal; ids in order of first appearance.
class Welder {
 public:
  explicit Welder(TriangleMesh& mesh) : mesh_(mesh) {}
  int Add(std::array<float, 3> p) {
    Key key{};
    for (std::size_t k = 0; k < 3; ++k) {
      if (p[k] == 0.0f) p[k] = 0.0f;  // -0 and +0 are the same point
      std::memcpy(&key[k], &p[k], 4);
    }
    const auto [it, inserted] = ids_.try_emplace(key, static_cast<int>(mesh_.vertices.size()));
    if (inserted) {
      mesh_.vertices.push_back({double{p[0]}, double{p[1]}, double{p[2]}});
    }
    return it->second;
  }

 private:
  using Key = std::array<std::uint32_t, 3>;
  struct Hash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = 0x9E3779B97F4A7C15ull;
      for (const std::uint32_t x : k) h = (h ^ x) * 0x100000001B3ull;
      return static_cast<std::size_t>(h ^ (h >> 29));
    }
  };
  TriangleMesh& mesh_;
  std::unordered_map<Key, int, Hash> ids_;
};

std::optional<core::Error> CheckFiniteFloat(const std::array<float, 3>& p) {
  if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) return std::nullopt;
  return Malformed("STL: a vertex coordinate is NaN or infinite");
}

float ReadF32Le(std::string_view bytes, std::size_t at) {
  const std::uint32_t bits = ReadU32Le(bytes, at);
  float f = 0.0f;
  std::memcpy(&f, &bits, 4);
  return f;
}

}  // namespace

core::Result<TriangleMesh> ReadStlBinary(std::string_view bytes, const MeshReadOptions& options) {
  if (bytes.size() < 84) return Malformed("binary STL shorter than its 84-byte header");
  const std::uint64_t count = ReadU32Le(bytes, 80);
  if (static_cast<std::int64_t>(count) > options.max_faces) {
    return TooLarge("STL declares " + std::to_string(count) + " triangles, over the " +
                    std::to_string(options.max_faces) + " limit");
  }
  if (84 + 50 * count > bytes.size()) {
    return Malformed("binary STL declares " + std::to_string(count) + " triangles but holds only " +
                     std::to_string((bytes.size() - 84) / 50) + " (truncated?)");
  }
  TriangleMesh mesh;
  mesh.faces.reserve(count);
  Welder welder(mesh);
  for (std::uint64_t t = 0; t < count; ++t) {
    const std::size_t base = 84 + 50 * t + 12;  // skip the stored normal
    std::array<int, 3> face{};
    for (std::size_t c = 0; c < 3; ++c) {
      const std::array<float, 3> p = {ReadF32Le(bytes, base + 12 * c),
                                      ReadF32Le(bytes, base + 12 * c + 4),
                                      ReadF32Le(bytes, base + 12 * c + 8)};
      if (auto e = CheckFiniteFloat(p)) return *e;
      face[c] = welder.Add(p);
    }
    mesh.faces.push_back(face);
  }
  if (static_cast<std::int64_t>(mesh.vertices.size()) > options.max_vertices) {
    return TooLarge("STL has more than " + std::to_string(options.max_vertices) + " vertices");
  }
  return Finish(std::move(mesh));
}

core::Result<TriangleMesh> ReadStlAscii(std::string_view text, const MeshReadOptions& options) {
  Tokens tokens(text);
  TriangleMesh mesh;
  Welder welder(mesh);
  std::vector<int> polygon;
  auto expect = [&](std::string_view word) { return tokens.Next() == word; };
  std::string_view token = tokens.Next();
  if (token != "solid") return Malformed("ASCII STL must start with 'solid'");
  tokens.SkipLine();  // the solid's name
  while (true) {
    token = tokens.Next();
    if (token.empty()) return Malformed("ASCII STL ends without 'endsolid'");
    if (token == "endsolid") {
      tokens.SkipLine();
      token = tokens.Next();
      if (token.empty()) break;
      if (token != "solid") return Malformed("ASCII STL: unexpected text after 'endsolid'");
      tokens.SkipLine();
      continue;
    }
    if (token != "facet") return Malformed("ASCII STL: expected 'facet' or 'endsolid'");
    if (!expect("normal")) return Malformed("ASCII STL: expected 'normal'");
    for (int k = 0; k < 3; ++k) {
      if (!ParseDouble(tokens.Next())) return Malformed("ASCII STL: bad normal");
    }
    if (!expect("outer") || !expect("loop")) return Malformed("ASCII STL: expected 'outer loop'");
    polygon.clear();
    while (true) {
      token = tokens.Next();
      if (token == "endloop") break;
      if (token != "vertex") return Malformed("ASCII STL: expected 'vertex' or 'endloop'");
      std::array<float, 3> p{};
      for (std::size_t k = 0; k < 3; ++k) {
        const auto x = ParseFloat(tokens.Next());
        if (!x) return Malformed("ASCII STL: vertex coordinate is not a number");
        p[k] = *x;
      }
      if (auto e = CheckFiniteFloat(p)) return *e;
      if (polygon.size() > 1000000) return Malformed("ASCII STL: facet with too many vertices");
      polygon.push_back(welder.Add(p));
      if (static_cast<std::int64_t>(mesh.vertices.size()) > options.max_vertices) {
        return TooLarge("STL has more than " + std::to_string(options.max_vertices) + " vertices");
      }
    }
    if (!expect("endfacet")) return Malformed("ASCII STL: expected 'endfacet'");
    if (auto e = AddPolygon(polygon, mesh, options)) return *e;
  }
  return Finish(std::move(mesh));
}

}  // namespace detail

std::string WriteStl(const TriangleMesh& mesh, Encoding encoding) {
  using namespace detail;
  CheckWritable(mesh, true);
  if (encoding == Encoding::kBinary) {
    std::string out = "softgrasp binary STL";
    out.resize(80, ' ');
    if (mesh.faces.size() > std::numeric_limits<std::uint32_t>::max()) {
      throw std::invalid_argument("mesh: too many triangles for binary STL");
    }
    AppendLittleEndian(out, static_cast<std::uint32_t>(mesh.faces.size()));
    out.reserve(84 + 50 * mesh.faces.size());
    for (const auto& f : mesh.faces) {
      const auto a = AsFloat(mesh.vertices[static_cast<std::size_t>(f[0])]);
      const auto b = AsFloat(mesh.vertices[static_cast<std::size_t>(f[1])]);
      const auto c = AsFloat(mesh.vertices[static_cast<std::size_t>(f[2])]);
      for (const float x : FacetNormal(a, b, c)) AppendLittleEndian(out, x);
      for (const auto& p : {a, b, c}) {
        for (const float x : p) AppendLittleEndian(out, x);
      }
      AppendLittleEndian(out, std::uint16_t{0});
    }
    return out;
  }
  std::string out = "solid softgrasp\n";
  for (const auto& f : mesh.faces) {
    const auto a = AsFloat(mesh.vertices[static_cast<std::size_t>(f[0])]);
    const auto b = AsFloat(mesh.vertices[static_cast<std::size_t>(f[1])]);
    const auto c = AsFloat(mesh.vertices[static_cast<std::size_t>(f[2])]);
    const auto n = FacetNormal(a, b, c);
    out += "facet normal ";
    AppendFloat(out, n[0]);
    out += ' ';
    AppendFloat(out, n[1]);
    out += ' ';
    AppendFloat(out, n[2]);
    out += "\n outer loop\n";
    for (const auto& p : {a, b, c}) {
      out += "  vertex ";
      AppendFloat(out, p[0]);
      out += ' ';
      AppendFloat(out, p[1]);
      out += ' ';
      AppendFloat(out, p[2]);
      out += '\n';
    }
    out += " endloop\nendfacet\n";
  }
  out += "endsolid softgrasp\n";
  return out;
}

}  // namespace softgrasp::mesh
