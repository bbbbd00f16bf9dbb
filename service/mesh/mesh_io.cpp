// OBJ / PLY / STL writers and readers. Text numbers go through std::to_chars / std::from_chars
// (shortest round-trip, locale-independent); binary values are assembled byte by byte in
// little-endian order, so the bytes do not depend on the host.
#include "service/mesh/mesh_io.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <unordered_map>
#include <utility>
#include <vector>

namespace softgrasp::mesh {
namespace {

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

// "x y z\n" and "a b c\n" (indices shifted by `base`): the text lines OBJ and ASCII PLY share.
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

template <class T>
void AppendLittleEndian(std::string& out, T value) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::uint64_t bits = 0;
  if constexpr (sizeof(T) == 8) {
    std::memcpy(&bits, &value, 8);
  } else if constexpr (sizeof(T) == 4) {
    std::uint32_t b32 = 0;
    std::memcpy(&b32, &value, 4);
    bits = b32;
  } else if constexpr (sizeof(T) == 2) {
    std::uint16_t b16 = 0;
    std::memcpy(&b16, &value, 2);
    bits = b16;
  } else {
    std::uint8_t b8 = 0;
    std::memcpy(&b8, &value, 1);
    bits = b8;
  }
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    out.push_back(static_cast<char>((bits >> (8 * i)) & 0xffu));
  }
}

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

// ---------------------------------------------------------------------------------------------
// Reading: shared helpers

core::Error Malformed(const std::string& what) {
  return core::MakeError(core::ErrorCode::kInvalidArgument, what, "mesh");
}
core::Error TooLarge(const std::string& what) {
  return core::MakeError(core::ErrorCode::kPayloadTooLarge, what, "mesh");
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

/// Whitespace-separated tokens over a text, with line awareness for the formats that need it.
class Tokens {
 public:
  explicit Tokens(std::string_view text) : text_(text) {}
  /// Next token on any line; empty at the end.
  std::string_view Next() {
    while (pos_ < text_.size() && IsSpace(text_[pos_])) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !IsSpace(text_[pos_])) ++pos_;
    return text_.substr(start, pos_ - start);
  }
  /// Skips the rest of the current line.
  void SkipLine() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  }
  std::size_t remaining() const { return text_.size() - pos_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
};

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

/// Appends the fan (i0, i_k, i_k+1) of a polygon; checks the triangle limit.
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

// ---------------------------------------------------------------------------------------------
// OBJ

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

// ---------------------------------------------------------------------------------------------
// PLY

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<PlyType> ParsePlyType(std::string_view name) {
  static constexpr std::pair<std::string_view, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [n, t] : kNames) {
    if (n == name) return t;
  }
  return std::nullopt;
}

std::size_t PlyTypeSize(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 1;
}

bool IsFloatType(PlyType t) { return t == PlyType::kFloat32 || t == PlyType::kFloat64; }

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  ///< value type (item type for lists)
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  std::int64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyEncoding { kAscii, kLittle, kBig };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::kAscii;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;
};

constexpr std::size_t kMaxPlyHeader = 1 << 16;

core::Result<PlyHeader> ParsePlyHeader(std::string_view bytes) {
  PlyHeader header;
  std::size_t pos = 0;
  if (NextLine(bytes, pos) != "ply") return Malformed("PLY: missing 'ply' magic line");
  bool have_format = false;
  while (true) {
    if (pos >= bytes.size()) return Malformed("PLY: header ends before end_header");
    if (pos > kMaxPlyHeader) return Malformed("PLY: header longer than 64 KiB");
    const auto words = SplitWords(NextLine(bytes, pos));
    if (words.empty()) continue;
    if (words[0] == "end_header") break;
    if (words[0] == "comment" || words[0] == "obj_info") continue;
    if (words[0] == "format") {
      if (words.size() != 3 || words[2] != "1.0") return Malformed("PLY: bad format line");
      if (words[1] == "ascii") {
        header.encoding = PlyEncoding::kAscii;
      } else if (words[1] == "binary_little_endian") {
        header.encoding = PlyEncoding::kLittle;
      } else if (words[1] == "binary_big_endian") {
        header.encoding = PlyEncoding::kBig;
      } else {
        return Malformed("PLY: unknown format '" + std::string(words[1].substr(0, 32)) + "'");
      }
      have_format = true;
    } else if (words[0] == "element") {
      if (words.size() != 3) return Malformed("PLY: bad element line");
      const auto count = ParseInt(words[2]);
      if (!count || *count < 0)
        return Malformed("PLY: element count is not a non-negative integer");
      header.elements.push_back({std::string(words[1].substr(0, 64)), *count, {}});
    } else if (words[0] == "property") {
      if (header.elements.empty()) return Malformed("PLY: property before any element");
      PlyProperty p;
      if (words.size() == 5 && words[1] == "list") {
        const auto count_type = ParsePlyType(words[2]);
        const auto item_type = ParsePlyType(words[3]);
        if (!count_type || !item_type || IsFloatType(*count_type)) {
          return Malformed("PLY: bad list property types");
        }
        p = {std::string(words[4].substr(0, 64)), *item_type, true, *count_type};
      } else if (words.size() == 3) {
        const auto type = ParsePlyType(words[1]);
        if (!type) return Malformed("PLY: unknown property type");
        p = {std::string(words[2].substr(0, 64)), *type, false, PlyType::kUint8};
      } else {
        return Malformed("PLY: bad property line");
      }
      header.elements.back().properties.push_back(std::move(p));
    } else {
      return Malformed("PLY: unknown header keyword");
    }
  }
  if (!have_format) return Malformed("PLY: no format line");
  header.body_offset = pos;
  return header;
}

/// Reads scalars from the PLY body in either encoding.
class PlyBody {
 public:
  PlyBody(std::string_view body, PlyEncoding encoding)
      : body_(body), encoding_(encoding), tokens_(body) {}

  bool binary() const { return encoding_ != PlyEncoding::kAscii; }
  std::size_t remaining() const { return binary() ? body_.size() - pos_ : tokens_.remaining(); }

  /// Any scalar as a double; nullopt if truncated or not a number.
  std::optional<double> Value(PlyType type) {
    if (!binary()) {
      const std::string_view t = tokens_.Next();
      if (t.empty()) return std::nullopt;
      if (IsFloatType(type)) return ParseDouble(t);
      const auto i = ParseInt(t);
      if (!i) return std::nullopt;
      return static_cast<double>(*i);
    }
    const std::size_t n = PlyTypeSize(type);
    if (body_.size() - pos_ < n) return std::nullopt;
    std::uint64_t bits = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto byte = static_cast<std::uint64_t>(static_cast<unsigned char>(body_[pos_ + i]));
      const std::size_t shift = encoding_ == PlyEncoding::kLittle ? i : n - 1 - i;
      bits |= byte << (8 * shift);
    }
    pos_ += n;
    switch (type) {
      case PlyType::kInt8:
        return static_cast<double>(static_cast<std::int8_t>(bits));
      case PlyType::kUint8:
        return static_cast<double>(static_cast<std::uint8_t>(bits));
      case PlyType::kInt16:
        return static_cast<double>(static_cast<std::int16_t>(bits));
      case PlyType::kUint16:
        return static_cast<double>(static_cast<std::uint16_t>(bits));
      case PlyType::kInt32:
        return static_cast<double>(static_cast<std::int32_t>(bits));
      case PlyType::kUint32:
        return static_cast<double>(static_cast<std::uint32_t>(bits));
      case PlyType::kFloat32: {
        const auto b32 = static_cast<std::uint32_t>(bits);
        float f = 0.0f;
        std::memcpy(&f, &b32, 4);
        return static_cast<double>(f);
      }
      case PlyType::kFloat64: {
        double d = 0.0;
        std::memcpy(&d, &bits, 8);
        return d;
      }
    }
    return std::nullopt;
  }

  /// An integer (count or index): nullopt if truncated, not integral or out of int64 range.
  std::optional<std::int64_t> Integer(PlyType type) {
    const auto v = Value(type);
    if (!v || !std::isfinite(*v) || std::floor(*v) != *v || std::abs(*v) > 9.0e15) {
      return std::nullopt;
    }
    return static_cast<std::int64_t>(*v);
  }

 private:
  std::string_view body_;
  PlyEncoding encoding_;
  std::size_t pos_ = 0;
  Tokens tokens_;
};

/// Smallest number of bytes one element can take in the body (to reject impossible counts
/// before allocating).
std::size_t MinElementBytes(const PlyElement& e, bool binary) {
  std::size_t n = 0;
  for (const PlyProperty& p : e.properties) {
    if (binary) {
      n += p.is_list ? PlyTypeSize(p.count_type) : PlyTypeSize(p.type);
    } else {
      n += 2;  // a digit and a separator
    }
  }
  return std::max<std::size_t>(n, 1);
}

core::Result<TriangleMesh> ReadPly(std::string_view bytes, const MeshReadOptions& options) {
  auto parsed = ParsePlyHeader(bytes);
  if (!parsed.ok()) return parsed.error();
  const PlyHeader& header = parsed.value();
  PlyBody body(bytes.substr(header.body_offset), header.encoding);

  std::int64_t declared_vertices = -1;
  int vertex_elements = 0, face_elements = 0;
  for (const PlyElement& e : header.elements) {
    if (e.name == "vertex") {
      declared_vertices = e.count;
      ++vertex_elements;
    }
    if (e.name == "face") ++face_elements;
  }
  if (vertex_elements > 1 || face_elements > 1) {
    return Malformed("PLY: more than one vertex or face element");
  }
  if (declared_vertices < 0) return Malformed("PLY: no vertex element");
  if (declared_vertices > options.max_vertices) {
    return TooLarge("PLY declares " + std::to_string(declared_vertices) + " vertices, over the " +
                    std::to_string(options.max_vertices) + " limit");
  }

  TriangleMesh mesh;
  std::vector<int> polygon;
  for (const PlyElement& e : header.elements) {
    if (e.count > 0 && e.properties.empty()) {
      return Malformed("PLY: element '" + e.name + "' has no properties");
    }
    if (e.name == "face" && e.count > options.max_faces) {
      return TooLarge("PLY declares " + std::to_string(e.count) + " faces, over the " +
                      std::to_string(options.max_faces) + " limit");
    }
    const std::size_t min_bytes = MinElementBytes(e, body.binary());
    if (static_cast<std::uint64_t>(e.count) > body.remaining() / min_bytes + 1) {
      return Malformed("PLY: element '" + e.name + "' declares " + std::to_string(e.count) +
                       " entries, more than the data can hold (truncated?)");
    }
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    int xyz[3] = {-1, -1, -1};
    int indices = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const PlyProperty& p = e.properties[k];
      if (is_vertex && !p.is_list) {
        if (p.name == "x") xyz[0] = static_cast<int>(k);
        if (p.name == "y") xyz[1] = static_cast<int>(k);
        if (p.name == "z") xyz[2] = static_cast<int>(k);
      }
      if (is_face && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")) {
        indices = static_cast<int>(k);
      }
    }
    if (is_vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0)) {
      return Malformed("PLY: vertex element lacks x, y or z");
    }
    if (is_face && indices < 0) return Malformed("PLY: face element lacks vertex_indices");
    if (is_vertex) mesh.vertices.reserve(static_cast<std::size_t>(e.count));
    if (is_face) mesh.faces.reserve(static_cast<std::size_t>(e.count));

    for (std::int64_t n = 0; n < e.count; ++n) {
      std::array<double, 3> point{};
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        const int ik = static_cast<int>(k);
        if (!p.is_list) {
          const auto v = body.Value(p.type);
          if (!v) return Malformed("PLY: truncated or non-numeric data in '" + e.name + "'");
          for (std::size_t c = 0; c < 3; ++c) {
            if (is_vertex && ik == xyz[c]) point[c] = *v;
          }
          continue;
        }
        const auto length = body.Integer(p.count_type);
        if (!length || *length < 0) return Malformed("PLY: bad list length in '" + e.name + "'");
        const std::size_t item_min = body.binary() ? PlyTypeSize(p.type) : 2;
        if (static_cast<std::uint64_t>(*length) > body.remaining() / item_min + 1) {
          return Malformed("PLY: list longer than the data left (truncated?)");
        }
        const bool wanted = is_face && ik == indices;
        if (wanted) polygon.clear();
        for (std::int64_t j = 0; j < *length; ++j) {
          if (!wanted) {
            if (!body.Value(p.type)) return Malformed("PLY: truncated list in '" + e.name + "'");
            continue;
          }
          const auto index = body.Integer(p.type);
          if (!index) return Malformed("PLY: truncated or non-integer face index");
          if (*index < 0 || *index >= declared_vertices) {
            return Malformed("PLY: face index " + std::to_string(*index) + " out of range [0, " +
                             std::to_string(declared_vertices) + ")");
          }
          polygon.push_back(static_cast<int>(*index));
        }
        if (wanted) {
          if (auto err = AddPolygon(polygon, mesh, options)) return *err;
        }
      }
      if (is_vertex) {
        if (auto err = CheckFinite(point)) return *err;
        mesh.vertices.push_back(point);
      }
    }
  }
  return Finish(std::move(mesh));
}

// ---------------------------------------------------------------------------------------------
// STL

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

std::uint32_t ReadU32Le(std::string_view bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
  }
  return v;
}

float ReadF32Le(std::string_view bytes, std::size_t at) {
  const std::uint32_t bits = ReadU32Le(bytes, at);
  float f = 0.0f;
  std::memcpy(&f, &bits, 4);
  return f;
}

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

bool LooksLikeText(std::string_view bytes) {
  for (const char ch : bytes.substr(0, 1024)) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\f' && c != '\v') return false;
  }
  return true;
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

}  // namespace

const char* MeshFormatName(MeshFormat format) {
  switch (format) {
    case MeshFormat::kObj:
      return "obj";
    case MeshFormat::kPlyAscii:
      return "ply_ascii";
    case MeshFormat::kPlyBinary:
      return "ply_binary";
    case MeshFormat::kStlAscii:
      return "stl_ascii";
    case MeshFormat::kStlBinary:
      return "stl_binary";
  }
  return "obj";
}

std::optional<MeshFormat> MeshFormatFromName(std::string_view name) {
  for (MeshFormat f : {MeshFormat::kObj, MeshFormat::kPlyAscii, MeshFormat::kPlyBinary,
                       MeshFormat::kStlAscii, MeshFormat::kStlBinary}) {
    if (name == MeshFormatName(f)) return f;
  }
  if (name == "ply") return MeshFormat::kPlyBinary;
  if (name == "stl") return MeshFormat::kStlBinary;
  return std::nullopt;
}

const char* MeshFileExtension(MeshFormat format) {
  switch (format) {
    case MeshFormat::kObj: return "obj";
    case MeshFormat::kPlyAscii:
    case MeshFormat::kPlyBinary: return "ply";
    case MeshFormat::kStlAscii:
    case MeshFormat::kStlBinary: return "stl";
  }
  return "obj";
}

std::string WriteObj(const TriangleMesh& mesh) {
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

std::string WritePly(const TriangleMesh& mesh, Encoding encoding) {
  CheckWritable(mesh, false);
  const bool binary = encoding == Encoding::kBinary;
  std::string out = "ply\nformat ";
  out += binary ? "binary_little_endian" : "ascii";
  out += " 1.0\ncomment softgrasp mesh\nelement vertex ";
  AppendInt(out, static_cast<std::int64_t>(mesh.vertices.size()));
  out += "\nproperty double x\nproperty double y\nproperty double z\nelement face ";
  AppendInt(out, static_cast<std::int64_t>(mesh.faces.size()));
  out += "\nproperty list uchar int vertex_indices\nend_header\n";
  if (binary) {
    out.reserve(out.size() + 24 * mesh.vertices.size() + 13 * mesh.faces.size());
    for (const auto& v : mesh.vertices) {
      for (const double x : v) AppendLittleEndian(out, x);
    }
    for (const auto& f : mesh.faces) {
      AppendLittleEndian(out, std::uint8_t{3});
      for (const int i : f) AppendLittleEndian(out, static_cast<std::int32_t>(i));
    }
    return out;
  }
  for (const auto& v : mesh.vertices) AppendCoordinates(out, v);
  for (const auto& f : mesh.faces) {
    out += "3 ";
    AppendIndices(out, f, 0);
  }
  return out;
}

std::string WriteStl(const TriangleMesh& mesh, Encoding encoding) {
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

std::string WriteMesh(const TriangleMesh& mesh, MeshFormat format) {
  switch (format) {
    case MeshFormat::kObj:
      return WriteObj(mesh);
    case MeshFormat::kPlyAscii:
      return WritePly(mesh, Encoding::kAscii);
    case MeshFormat::kPlyBinary:
      return WritePly(mesh, Encoding::kBinary);
    case MeshFormat::kStlAscii:
      return WriteStl(mesh, Encoding::kAscii);
    case MeshFormat::kStlBinary:
      return WriteStl(mesh, Encoding::kBinary);
  }
  throw std::invalid_argument("WriteMesh: unknown format");
}

core::Result<MeshFormat> SniffMeshFormat(std::string_view bytes) {
  if (StartsWith(bytes, "ply\n") || StartsWith(bytes, "ply\r\n")) {
    std::size_t pos = 0;
    NextLine(bytes, pos);
    const std::string_view format_line = NextLine(bytes, pos);
    return format_line.find("binary") != std::string_view::npos ? MeshFormat::kPlyBinary
                                                                : MeshFormat::kPlyAscii;
  }
  if (bytes.size() >= 84 && 84 + 50 * std::uint64_t{ReadU32Le(bytes, 80)} == bytes.size()) {
    return MeshFormat::kStlBinary;
  }
  if (LooksLikeText(bytes)) {
    std::size_t start = 0;
    while (start < bytes.size() && IsSpace(bytes[start])) ++start;
    const std::string_view text = bytes.substr(start);
    if (StartsWith(text, "solid") && (text.size() == 5 || IsSpace(text[5]))) {
      return MeshFormat::kStlAscii;
    }
    if (LooksLikeObj(bytes)) return MeshFormat::kObj;
  } else if (bytes.size() >= 84) {
    return MeshFormat::kStlBinary;  // binary data with a wrong count: the reader says so
  }
  return core::MakeError(core::ErrorCode::kUnsupportedMediaType,
                         "not a mesh format we read (OBJ, PLY, STL)", "mesh");
}

core::Result<TriangleMesh> ReadMesh(std::string_view bytes, const MeshReadOptions& options) {
  if (options.max_vertices < 0 || options.max_faces < 0 ||
      options.max_vertices > std::numeric_limits<int>::max()) {
    throw std::invalid_argument("MeshReadOptions: limits must be in [0, INT_MAX]");
  }
  const auto format = SniffMeshFormat(bytes);
  if (!format.ok()) return format.error();
  switch (format.value()) {
    case MeshFormat::kObj:
      return ReadObj(bytes, options);
    case MeshFormat::kPlyAscii:
    case MeshFormat::kPlyBinary:
      return ReadPly(bytes, options);
    case MeshFormat::kStlAscii:
      return ReadStlAscii(bytes, options);
    case MeshFormat::kStlBinary:
      return ReadStlBinary(bytes, options);
  }
  return Malformed("unknown format");
}

}  // namespace softgrasp::mesh
