#pragma once
/// Mesh files: OBJ, PLY (ASCII and binary little-endian) and STL (ASCII and binary), written to
/// and read from bytes. Writers are deterministic (same mesh -> same bytes) and lossless for our
/// meshes: OBJ and PLY keep doubles exactly (shortest round-trip text, binary float64); STL is a
/// float32 format in both flavours, so it is exact for float32-representable coordinates (every
/// fractal mesh is). Readers never trust declared sizes: counts are checked against the limits
/// and against the bytes actually present before anything is allocated.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "service/core/status.h"
#include "service/mesh/mesh.h"

namespace softgrasp::mesh {

enum class MeshFormat { kObj, kPlyAscii, kPlyBinary, kStlAscii, kStlBinary };
enum class Encoding { kAscii, kBinary };

/// "obj", "ply_ascii", "ply_binary", "stl_ascii", "stl_binary".
const char* MeshFormatName(MeshFormat format);

/// The format named by MeshFormatName(), or the short aliases "ply" and "stl" (binary).
std::optional<MeshFormat> MeshFormatFromName(std::string_view name);

/// File name extension without the dot: "obj", "ply" or "stl".
const char* MeshFileExtension(MeshFormat format);

/// Wavefront OBJ: "v x y z" lines then "f a b c" (1-based).
/// @throws std::invalid_argument if a face index is out of range or a coordinate not finite
///         (the same for every writer).
std::string WriteObj(const TriangleMesh& mesh);
/// PLY with `property double x, y, z` and `property list uchar int vertex_indices`; binary is
/// little-endian.
std::string WritePly(const TriangleMesh& mesh, Encoding encoding);
/// STL, float32 coordinates, facet normals from the vertex order. The binary header never starts
/// with "solid" (so it is never mistaken for ASCII).
std::string WriteStl(const TriangleMesh& mesh, Encoding encoding);
std::string WriteMesh(const TriangleMesh& mesh, MeshFormat format);

struct MeshReadOptions {
  std::int64_t max_vertices = 5000000;  ///< more (declared or found) -> kTooLarge
  std::int64_t max_faces = 10000000;    ///< triangles after splitting polygons, likewise
};

/// Recognises the format from the content: "ply" magic (and its format line), a binary STL whose
/// size matches its triangle count, "solid ... facet" text, OBJ keywords, else other binary data
/// of at least 84 bytes as a (broken) binary STL. kUnsupportedFormat when none fits.
core::Result<MeshFormat> SniffMeshFormat(std::string_view bytes);

/// Decodes any of the formats (sniffed). Polygons are split into triangle fans. STL vertices are
/// welded when their float32 coordinates are exactly equal, numbered in order of first
/// appearance. Errors (field "mesh"): kUnsupportedFormat (unknown format), kInvalidArgument
/// (malformed, truncated, count mismatch, index out of range, NaN/inf coordinate),
/// kTooLarge (over the limits), kUnprocessable (no faces).
core::Result<TriangleMesh> ReadMesh(std::string_view bytes, const MeshReadOptions& options = {});

}  // namespace softgrasp::mesh
