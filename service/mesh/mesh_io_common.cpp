// Helpers shared by the OBJ, PLY and STL codecs (mesh_detail.h). Text numbers go through
// std::to_chars / std::from_chars (shortest round-trip, locale-independent).
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "service/mesh/mesh_io_internal.h"

namespace softgrasp::mesh::detail {

// ---------------------------------------------------------------------------------------------
// Writing

void CheckWritable(const TriangleMesh& mesh, bool as_float) {
  const auto nv = static_cast<std::int64_t>(mesh.vertices.size());
  if (nv > std::numeric_limits<int>::max()) throw std::invalid_argument("mesh: too many vertices");
  for (const auto& f : mesh.faces) {
    for (const int i : f) {
      if (i < 0 || i >= nv) {
        throw std::invalid_argument("mesh: face index " + std::to_string(i) + " out of range [0, " +
                                    std::to_string(nv) + ")");
      }
    }
  }
  for (const auto& v : mesh.vertices) {
    for (const double x : v) {
      const bool ok = as_float ? std::isfinite(static_cast<float>(x)) : std::isfinite(x);
      if (!ok) throw std::invalid_argument("mesh: vertex coordinate not finite (as written)");
    }
  }
}

void AppendDouble(std::string& out, double x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

void AppendFloat(std::string& out, float x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

void AppendInt(std::string& out, std::int64_t x) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

void AppendCoordinates(std::string& out, const std::array<double, 3>& v) {
  AppendDouble(out, v[0]);
  out += ' ';
  AppendDouble(out, v[1]);
  out += ' ';
  AppendDouble(out, v[2]);
  out += '\n';
}

void AppendIndices(std::string& out, const std::array<int, 3>& f, int base) {
  AppendInt(out, f[0] + base);
  out += ' ';
  AppendInt(out, f[1] + base);
  out += ' ';
  AppendInt(out, f[2] + base);
  out += '\n';
}

// ---------------------------------------------------------------------------------------------
// Reading

core::Error Malformed(const std::string& what) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, what, "mesh");
}
core::Error TooLarge(const std::string& what) {
  return core::MakeError(core::ErrorCode::kTooLarge, what, "mesh");
}

bool IsSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

bool StartsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

std::optional<double> ParseDouble(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  double value = 0.0;
  const auto r = std::from_chars(token.data(), token.data() + token.size(), value);
  if (r.ec != std::errc() || r.ptr != token.data() + token.size()) return std::nullopt;
  return value;
}

std::optional<float> ParseFloat(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  float value = 0.0f;
  const auto r = std::from_chars(token.data(), token.data() + token.size(), value);
  if (r.ec != std::errc() || r.ptr != token.data() + token.size()) return std::nullopt;
  return value;
}

std::optional<std::int64_t> ParseInt(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  std::int64_t value = 0;
  const auto r = std::from_chars(token.data(), token.data() + token.size(), value);
  if (r.ec != std::errc() || r.ptr != token.data() + token.size()) return std::nullopt;
  return value;
}

std::string_view NextLine(std::string_view text, std::size_t& pos) {
  const std::size_t start = pos;
  const std::size_t end = text.find('\n', pos);
  pos = end == std::string_view::npos ? text.size() : end + 1;
  std::string_view line =
      text.substr(start, (end == std::string_view::npos ? text.size() : end) - start);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

std::vector<std::string_view> SplitWords(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && IsSpace(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !IsSpace(line[i])) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

std::optional<core::Error> AddPolygon(const std::vector<int>& polygon, TriangleMesh& mesh,
                                      const MeshReadOptions& options) {
  if (polygon.size() < 3) return Malformed("a face has fewer than 3 vertices");
  const auto added = static_cast<std::int64_t>(polygon.size()) - 2;
  if (static_cast<std::int64_t>(mesh.faces.size()) + added > options.max_faces) {
    return TooLarge("more than " + std::to_string(options.max_faces) + " triangles");
  }
  for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {
    mesh.faces.push_back({polygon[0], polygon[k], polygon[k + 1]});
  }
  return std::nullopt;
}

std::optional<core::Error> CheckFinite(const std::array<double, 3>& p) {
  if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) return std::nullopt;
  return Malformed("a vertex coordinate is NaN or infinite");
}

core::Result<TriangleMesh> Finish(TriangleMesh mesh) {
  if (mesh.faces.empty()) {
    return core::MakeError(core::ErrorCode::kUnprocessable, "the mesh has no triangles", "mesh");
  }
  return mesh;
}

std::uint32_t ReadU32Le(std::string_view bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
  }
  return v;
}

}  // namespace softgrasp::mesh::detail
