// Format names, sniffing and dispatch to the codecs: OBJ in mesh_io_obj.cpp, PLY in
// mesh_io_ply.cpp, STL in mesh_io_stl.cpp, their shared helpers in mesh_io_common.cpp.
#include "service/mesh/mesh_io.h"

#include <cstdint>
#include <limits>
#include <stdexcept>

#include "service/mesh/mesh_io_internal.h"

namespace softgrasp::mesh {

using namespace detail;

namespace {

bool LooksLikeText(std::string_view bytes) {
  for (const char ch : bytes.substr(0, 1024)) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\f' && c != '\v') return false;
  }
  return true;
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
    case MeshFormat::kObj:
      return "obj";
    case MeshFormat::kPlyAscii:
    case MeshFormat::kPlyBinary:
      return "ply";
    case MeshFormat::kStlAscii:
    case MeshFormat::kStlBinary:
      return "stl";
  }
  return "obj";
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
  return core::MakeError(core::ErrorCode::kUnsupportedFormat,
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
