// Wavefront OBJ: the writer and the reader ("v" and "f" lines; everything else is skipped).
#include <algorithm>
#include <array>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "service/mesh/mesh_io.h"
#include "service/mesh/mesh_io_internal.h"

namespace softgrasp::mesh {
namespace detail {

core::Result<TriangleMesh> ReadObj(std::string_view text, const MeshReadOptions& options) {
  TriangleMesh mesh;
  std::vector<int> polygon;
  std::size_t pos = 0;
  std::int64_t line_number = 0;
  while (pos < text.size()) {
    ++line_number;
    std::string_view line = NextLine(text, pos);
    if (const auto hash = line.find('#'); hash != std::string_view::npos)
      line = line.substr(0, hash);
    const auto words = SplitWords(line);
    if (words.empty()) continue;
    const std::string where = " (line " + std::to_string(line_number) + ")";
    if (words[0] == "v") {
      if (words.size() < 4) return Malformed("OBJ vertex needs x y z" + where);
      std::array<double, 3> p{};
      for (std::size_t k = 0; k < 3; ++k) {
        const auto x = ParseDouble(words[k + 1]);
        if (!x) return Malformed("OBJ vertex coordinate is not a number" + where);
        p[k] = *x;
      }
      if (auto e = CheckFinite(p)) return *e;
      if (static_cast<std::int64_t>(mesh.vertices.size()) >= options.max_vertices) {
        return TooLarge("more than " + std::to_string(options.max_vertices) + " vertices");
      }
      mesh.vertices.push_back(p);
    } else if (words[0] == "f") {
      polygon.clear();
      for (std::size_t k = 1; k < words.size(); ++k) {
        const std::string_view ref = words[k].substr(0, words[k].find('/'));
        const auto index = ParseInt(ref);
        if (!index || *index == 0)
          return Malformed("OBJ face index is not a non-zero integer" + where);
        // Negative indices count back from the last vertex so far; positive ones are checked at
        // the end (some writers put faces before their vertices).
        const std::int64_t nv = static_cast<std::int64_t>(mesh.vertices.size());
        const std::int64_t i = *index > 0 ? *index - 1 : nv + *index;
        if (i < 0 || i >= options.max_vertices)
          return Malformed("OBJ face index out of range" + where);
        polygon.push_back(static_cast<int>(i));
      }
      if (auto e = AddPolygon(polygon, mesh, options)) return *e;
    }
    // Everything else (vt, vn, o, g, s, usemtl, mtllib, l, ...) does not change the triangles.
  }
  const auto nv = static_cast<int>(mesh.vertices.size());
  for (const auto& f : mesh.faces) {
    for (const int i : f) {
      if (i >= nv) {
        return Malformed("OBJ face index " + std::to_string(i + 1) + " exceeds the " +
                         std::to_string(nv) + " vertices");
      }
    }
  }
  return Finish(std::move(mesh));
}

bool LooksLikeObj(std::string_view text) {
  static constexpr std::string_view kKeywords[] = {
      "v", "vt", "vn",     "vp",     "f",      "o",   "g",    "s",
      "l", "p",  "mtllib", "usemtl", "cstype", "deg", "curv", "surf"};
  std::size_t pos = 0;
  const std::string_view head = text.substr(0, 1 << 16);
  while (pos < head.size()) {
    const auto words = SplitWords(NextLine(head, pos));
    if (words.empty() || words[0].front() == '#') continue;
    return std::find(std::begin(kKeywords), std::end(kKeywords), words[0]) != std::end(kKeywords);
  }
  return false;
}

}  // namespace detail

std::string WriteObj(const TriangleMesh& mesh) {
  using namespace detail;
  CheckWritable(mesh, false);
  std::string out = "# softgrasp mesh: ";
  AppendInt(out, static_cast<std::int64_t>(mesh.vertices.size()));
  out += " vertices, ";
  AppendInt(out, static_cast<std::int64_t>(mesh.faces.size()));
  out += " triangles\n";
  for (const auto& v : mesh.vertices) {
    out += "v ";
    AppendCoordinates(out, v);
  }
  for (const auto& f : mesh.faces) {
    out += "f ";
    AppendIndices(out, f, 1);  // OBJ counts from 1
  }
  return out;
}

}  // namespace softgrasp::mesh
