#pragma once
/// Private to softgrasp_mesh's codec sources (mesh_io*.cpp): the helpers the OBJ, PLY and STL
/// codecs share and each format's reader, which mesh_io.cpp dispatches to after sniffing. Not
/// part of the library's interface; other code includes mesh_io.h.

#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "service/core/status.h"
#include "service/mesh/mesh.h"
#include "service/mesh/mesh_io.h"

namespace softgrasp::mesh::detail {

// ---------------------------------------------------------------------------------------------
// Writing

/// @throws std::invalid_argument if a face index is out of range or a coordinate is not finite
/// (as float32 when `as_float`).
void CheckWritable(const TriangleMesh& mesh, bool as_float);

void AppendDouble(std::string& out, double x);
void AppendFloat(std::string& out, float x);
void AppendInt(std::string& out, std::int64_t x);
// "x y z\n" and "a b c\n" (indices shifted by `base`): the text lines OBJ and ASCII PLY share.
void AppendCoordinates(std::string& out, const std::array<double, 3>& v);
void AppendIndices(std::string& out, const std::array<int, 3>& f, int base);

template <class T>
inline void AppendLittleEndian(std::string& out, T value) {
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

// ---------------------------------------------------------------------------------------------
// Reading

core::Error Malformed(const std::string& what);
core::Error TooLarge(const std::string& what);

bool IsSpace(char c);
bool StartsWith(std::string_view s, std::string_view prefix);

/// Whole-token numbers (a leading '+' allowed); nullopt unless the token is exactly one number.
std::optional<double> ParseDouble(std::string_view token);
std::optional<float> ParseFloat(std::string_view token);
std::optional<std::int64_t> ParseInt(std::string_view token);

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

/// The line starting at `pos` without its "\n" or "\r\n"; moves `pos` past it.
std::string_view NextLine(std::string_view text, std::size_t& pos);
std::vector<std::string_view> SplitWords(std::string_view line);

/// Appends the fan (i0, i_k, i_k+1) of a polygon; checks the triangle limit.
std::optional<core::Error> AddPolygon(const std::vector<int>& polygon, TriangleMesh& mesh,
                                      const MeshReadOptions& options);
/// Malformed unless all three coordinates are finite.
std::optional<core::Error> CheckFinite(const std::array<double, 3>& p);
/// The mesh, or kUnprocessable when it has no triangles.
core::Result<TriangleMesh> Finish(TriangleMesh mesh);

/// Little-endian uint32 at `at` (the caller checks the bounds).
std::uint32_t ReadU32Le(std::string_view bytes, std::size_t at);

// ---------------------------------------------------------------------------------------------
// The formats (mesh_io_obj.cpp, mesh_io_ply.cpp, mesh_io_stl.cpp)

/// True if the first non-empty, non-comment line starts with an OBJ keyword.
bool LooksLikeObj(std::string_view text);
core::Result<TriangleMesh> ReadObj(std::string_view text, const MeshReadOptions& options);
core::Result<TriangleMesh> ReadPly(std::string_view bytes, const MeshReadOptions& options);
core::Result<TriangleMesh> ReadStlBinary(std::string_view bytes, const MeshReadOptions& options);
core::Result<TriangleMesh> ReadStlAscii(std::string_view text, const MeshReadOptions& options);

}  // namespace softgrasp::mesh::detail
