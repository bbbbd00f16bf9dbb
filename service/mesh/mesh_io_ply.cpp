// PLY: the writer (ASCII or binary little-endian, double coordinates) and the reader (ASCII and
// binary of either byte order, any scalar types, extra elements and properties skipped). Binary
// values are assembled byte by byte, so the bytes do not depend on the host.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "service/mesh/mesh_io.h"
#include "service/mesh/mesh_io_internal.h"

namespace softgrasp::mesh {
namespace detail {
namespace {

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

}  // namespace

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

}  // namespace detail

std::string WritePly(const TriangleMesh& mesh, Encoding encoding) {
  using namespace detail;
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

}  // namespace softgrasp::mesh
