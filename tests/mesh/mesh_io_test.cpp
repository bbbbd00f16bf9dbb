// Mesh codecs: exact round trips, format details (polygons, OBJ index forms, PLY types and byte
// orders, STL welding), broken input, limits, and the fuzz corpus in tests/fuzz/corpus/mesh_decode
// (SOFTGRASP_WRITE_FUZZ_CORPUS=1 rewrites it from CorpusFiles() below).
#include "service/mesh/mesh_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>
#include <string>

#include "service/mesh/fractal.h"
#include "tests/mesh/mesh_test_util.h"
#include "tests/support/box_mesh.h"

namespace softgrasp::mesh {
namespace {

using softgrasp::testing::BoxMesh;

constexpr MeshFormat kAllFormats[] = {MeshFormat::kObj, MeshFormat::kPlyAscii,
                                      MeshFormat::kPlyBinary, MeshFormat::kStlAscii,
                                      MeshFormat::kStlBinary};

/// Vertices renumbered in order of first appearance in the faces (what STL gives back).
TriangleMesh FirstAppearanceOrder(const TriangleMesh& m) {
  TriangleMesh out;
  std::vector<int> id(m.vertices.size(), -1);
  for (const auto& f : m.faces) {
    std::array<int, 3> g{};
    for (std::size_t k = 0; k < 3; ++k) {
      int& i = id[static_cast<std::size_t>(f[k])];
      if (i < 0) {
        i = static_cast<int>(out.vertices.size());
        out.vertices.push_back(m.vertices[static_cast<std::size_t>(f[k])]);
      }
      g[k] = i;
    }
    out.faces.push_back(g);
  }
  return out;
}

TriangleMesh MustRead(const std::string& bytes, const MeshReadOptions& options = {}) {
  auto r = ReadMesh(bytes, options);
  EXPECT_TRUE(r.ok()) << r.error().message;
  return r.ok() ? r.value() : TriangleMesh{};
}

core::ErrorCode ErrorOf(const std::string& bytes, const MeshReadOptions& options = {}) {
  const auto r = ReadMesh(bytes, options);
  EXPECT_FALSE(r.ok()) << "decoded unexpectedly";
  if (!r.ok()) {
    EXPECT_EQ(r.error().field, "mesh");
    EXPECT_FALSE(r.error().message.empty());
  }
  return r.ok() ? core::ErrorCode::kInternal : r.error().code;
}

std::string Le32(std::uint32_t v) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[static_cast<std::size_t>(i)] = static_cast<char>(v >> (8 * i));
  return s;
}

std::string Be(const void* p, std::size_t n) {
  std::string s(static_cast<const char*>(p), n);
  return std::string(s.rbegin(), s.rend());  // host is little-endian (x86-64, aarch64)
}

TEST(MeshIoTest, CubeRoundTripsInEveryFormat) {
  const TriangleMesh cube = BoxMesh({-0.5, 0.25, 3.0}, {-0.375, 0.375, 3.125});
  for (const MeshFormat f : kAllFormats) {
    const std::string bytes = WriteMesh(cube, f);
    const auto sniffed = SniffMeshFormat(bytes);
    ASSERT_TRUE(sniffed.ok());
    EXPECT_EQ(sniffed.value(), f) << MeshFormatName(f);
    const TriangleMesh back = MustRead(bytes);
    const bool stl = f == MeshFormat::kStlAscii || f == MeshFormat::kStlBinary;
    EXPECT_EQ(back, stl ? FirstAppearanceOrder(cube) : cube) << MeshFormatName(f);
    EXPECT_EQ(WriteMesh(back, f), stl ? WriteMesh(FirstAppearanceOrder(cube), f) : bytes);
  }
}

TEST(MeshIoTest, FractalMeshRoundTripsExactlyInEveryFormat) {
  FractalParams p;
  p.seed = 4;
  p.num_points = 2000;
  const auto model = GenerateFractal(p);
  ASSERT_TRUE(model.ok());
  const TriangleMesh& mesh = model.value().mesh;
  for (const MeshFormat f : kAllFormats) {
    EXPECT_EQ(MustRead(WriteMesh(mesh, f)), mesh) << MeshFormatName(f);
  }
}

TEST(MeshIoTest, ObjAndPlyKeepDoublesExactly) {
  TriangleMesh m = testing::MakeTetrahedron();
  m.vertices[1] = {0.1, 1.0 / 3.0, 1e-300};
  m.vertices[2] = {-123456.789, 1e300, 2.5e-7};
  for (const MeshFormat f : {MeshFormat::kObj, MeshFormat::kPlyAscii, MeshFormat::kPlyBinary}) {
    EXPECT_EQ(MustRead(WriteMesh(m, f)), m) << MeshFormatName(f);
  }
}

TEST(MeshIoTest, StlIsFloat32AndWelds) {
  TriangleMesh m = testing::MakeTetrahedron();
  m.vertices[1] = {0.1, 0.2, 0.3};
  for (const Encoding e : {Encoding::kAscii, Encoding::kBinary}) {
    const TriangleMesh back = MustRead(WriteStl(m, e));
    ASSERT_EQ(back.vertices.size(), 4u);  // 12 corners welded back to 4 points
    ASSERT_EQ(back.faces.size(), 4u);
    const auto first = FirstAppearanceOrder(m);
    for (std::size_t i = 0; i < 4; ++i) {
      for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_EQ(back.vertices[i][k],
                  static_cast<double>(static_cast<float>(first.vertices[i][k])));
      }
    }
  }
  const std::string binary = WriteStl(m, Encoding::kBinary);
  EXPECT_EQ(binary.size(), 84u + 50u * 4u);
  EXPECT_NE(binary.substr(0, 5), "solid");
  EXPECT_EQ(WriteStl(m, Encoding::kAscii).substr(0, 6), "solid ");
}

TEST(MeshIoTest, BinaryStlWhoseHeaderSaysSolidIsBinary) {
  std::string bytes = WriteStl(BoxMesh({0, 0, 0}, {1, 1, 1}), Encoding::kBinary);
  bytes.replace(0, 11, "solid cube ");
  ASSERT_TRUE(SniffMeshFormat(bytes).ok());
  EXPECT_EQ(SniffMeshFormat(bytes).value(), MeshFormat::kStlBinary);
  EXPECT_EQ(MustRead(bytes), FirstAppearanceOrder(BoxMesh({0, 0, 0}, {1, 1, 1})));
}

TEST(MeshIoTest, ObjIndexFormsPolygonsAndExtras) {
  const std::string obj =
      "# a square pyramid\nmtllib x.mtl\no pyramid\n"
      "v 0 0 0\nv 1 0 0 1.0\nv 1 1 0\nv 0 1 0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\n"
      "f 1/1/1 4/1/1 3/1/1 2/1/1\n"  // the base quad -> 2 triangles
      "v 0.5 0.5 1  # apex\n"
      "f -5//1 -4//1 -1//1\nf 2 3 5\ns off\nf 3 4 5\nf 4/1 1/1 5/1\n";
  const TriangleMesh m = MustRead(obj);
  ASSERT_EQ(m.vertices.size(), 5u);
  ASSERT_EQ(m.faces.size(), 6u);
  EXPECT_EQ(m.faces[0], (std::array<int, 3>{0, 3, 2}));
  EXPECT_EQ(m.faces[1], (std::array<int, 3>{0, 2, 1}));
  EXPECT_EQ(m.faces[2], (std::array<int, 3>{0, 1, 4}));
  EXPECT_EQ(m.vertices[4], (std::array<double, 3>{0.5, 0.5, 1.0}));
}

TEST(MeshIoTest, PlyBigEndianFloatsExtraPropertiesAndElements) {
  std::string ply =
      "ply\r\nformat binary_big_endian 1.0\r\ncomment made by hand\r\nelement vertex 4\r\n"
      "property float x\r\nproperty float y\r\nproperty float z\r\nproperty uchar red\r\n"
      "element face 2\r\nproperty uchar flags\r\nproperty list uchar uint vertex_index\r\n"
      "element edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\nend_header\r\n";
  const float xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 1}};
  for (const auto& v : xyz) {
    for (const float x : v) ply += Be(&x, 4);
    ply += '\x07';
  }
  ply += '\x01';
  ply += '\x04';  // a quad
  for (const std::uint32_t i : {0u, 1u, 2u, 3u}) ply += Be(&i, 4);
  ply += '\x00';
  ply += '\x03';
  for (const std::uint32_t i : {0u, 3u, 1u}) ply += Be(&i, 4);
  for (const std::int32_t i : {0, 1}) ply += Be(&i, 4);
  const TriangleMesh m = MustRead(ply);
  ASSERT_EQ(m.vertices.size(), 4u);
  ASSERT_EQ(m.faces.size(), 3u);
  EXPECT_EQ(m.vertices[2], (std::array<double, 3>{1, 1, 0}));
  EXPECT_EQ(m.faces[1], (std::array<int, 3>{0, 2, 3}));
  EXPECT_EQ(m.faces[2], (std::array<int, 3>{0, 3, 1}));
}

TEST(MeshIoTest, AsciiPlyWithComments) {
  const std::string ply =
      "ply\nformat ascii 1.0\ncomment hi\nelement vertex 3\nproperty double x\n"
      "property double y\nproperty double z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const TriangleMesh m = MustRead(ply);
  EXPECT_EQ(m.faces.size(), 1u);
}

TEST(MeshIoTest, BrokenInputIsAnErrorNotACrash) {
  using core::ErrorCode;
  const TriangleMesh cube = BoxMesh({0, 0, 0}, {1, 1, 1});
  const std::string stl = WriteStl(cube, Encoding::kBinary);
  EXPECT_EQ(ErrorOf(stl.substr(0, stl.size() - 10)), ErrorCode::kInvalidArgument);  // truncated
  std::string wrong_count = stl;
  wrong_count.replace(80, 4, Le32(13));
  EXPECT_EQ(ErrorOf(wrong_count), ErrorCode::kInvalidArgument);
  std::string nan_stl = stl;
  const float nan = std::nanf("");
  std::memcpy(&nan_stl[84 + 12], &nan, 4);
  EXPECT_EQ(ErrorOf(nan_stl), ErrorCode::kInvalidArgument);

  const std::string ply = WritePly(cube, Encoding::kBinary);
  EXPECT_EQ(ErrorOf(ply.substr(0, ply.size() - 5)), ErrorCode::kInvalidArgument);
  std::string bad_index = WritePly(cube, Encoding::kAscii);
  bad_index.replace(bad_index.rfind("3 1 7 5"), 7, "3 1 7 8");
  EXPECT_EQ(ErrorOf(bad_index), ErrorCode::kInvalidArgument);
  std::string more_vertices = WritePly(cube, Encoding::kAscii);
  more_vertices.replace(more_vertices.find("vertex 8"), 8, "vertex 9");
  EXPECT_EQ(ErrorOf(more_vertices), ErrorCode::kInvalidArgument);
  std::string nan_ply = WritePly(cube, Encoding::kAscii);
  nan_ply.replace(nan_ply.find("end_header\n0 0 0"), 16, "end_header\nnan 0 0");
  EXPECT_EQ(ErrorOf(nan_ply), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("ply\nformat ascii 1.0\nelement vertex 3\nend_header\n"),
            ErrorCode::kInvalidArgument);  // no x, y, z
  EXPECT_EQ(ErrorOf("ply\nformat ascii 2.0\nend_header\n"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("ply\nformat ascii 1.0\nelement vertex 3\n"), ErrorCode::kInvalidArgument);

  EXPECT_EQ(ErrorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("v 0 nan 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("v 0 0x1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("v 0 0 0\nv 1 0 0\nf 1 2\n"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(ErrorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\n"), ErrorCode::kUnprocessable);  // no faces

  EXPECT_EQ(ErrorOf("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                    "vertex 0 1 0\nendfacet\nendsolid x\n"),
            ErrorCode::kInvalidArgument);  // no endloop
  EXPECT_EQ(ErrorOf("solid x\nendsolid x\n"), ErrorCode::kUnprocessable);

  EXPECT_EQ(ErrorOf(""), ErrorCode::kUnsupportedFormat);
  EXPECT_EQ(ErrorOf("hello world\n"), ErrorCode::kUnsupportedFormat);
  EXPECT_EQ(ErrorOf(std::string("\x89PNG\r\n\x1a\n", 8)), ErrorCode::kUnsupportedFormat);
}

TEST(MeshIoTest, LimitsAreCheckedBeforeAllocating) {
  using core::ErrorCode;
  // Declared counts far beyond the data: refused from the header alone.
  EXPECT_EQ(ErrorOf("ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                    "property float x\nproperty float y\nproperty float z\nend_header\n"),
            ErrorCode::kTooLarge);
  EXPECT_EQ(ErrorOf("ply\nformat binary_little_endian 1.0\nelement vertex 4000000\n"
                    "property float x\nproperty float y\nproperty float z\nend_header\n"),
            ErrorCode::kInvalidArgument);  // within the limit, but 12 bytes can't hold it
  EXPECT_EQ(ErrorOf("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 99999999999\n"
                    "property list uchar int vertex_indices\nend_header\n"),
            ErrorCode::kTooLarge);
  std::string huge_stl(84, '\0');
  huge_stl.replace(80, 4, Le32(0xffffffffu));
  EXPECT_EQ(ErrorOf(huge_stl), ErrorCode::kTooLarge);

  MeshReadOptions small;
  small.max_vertices = 7;
  small.max_faces = 100;
  for (const MeshFormat f : kAllFormats) {
    EXPECT_EQ(ErrorOf(WriteMesh(BoxMesh({0, 0, 0}, {1, 1, 1}), f), small), ErrorCode::kTooLarge)
        << MeshFormatName(f);
  }
  small.max_vertices = 8;
  small.max_faces = 11;
  for (const MeshFormat f : kAllFormats) {
    EXPECT_EQ(ErrorOf(WriteMesh(BoxMesh({0, 0, 0}, {1, 1, 1}), f), small), ErrorCode::kTooLarge)
        << MeshFormatName(f);
  }
  small.max_faces = 12;
  for (const MeshFormat f : kAllFormats) {
    MustRead(WriteMesh(BoxMesh({0, 0, 0}, {1, 1, 1}), f), small);
  }
}

TEST(MeshIoTest, WritersRejectBrokenMeshes) {
  TriangleMesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.faces[0][0] = 8;
  for (const MeshFormat f : kAllFormats) EXPECT_THROW(WriteMesh(m, f), std::invalid_argument);
  m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.vertices[2][1] = INFINITY;
  for (const MeshFormat f : kAllFormats) EXPECT_THROW(WriteMesh(m, f), std::invalid_argument);
  m = BoxMesh({0, 0, 0}, {1, 1, 1});
  m.vertices[2][1] = 1e300;  // finite, but not as float32
  EXPECT_THROW(WriteStl(m, Encoding::kBinary), std::invalid_argument);
  EXPECT_NO_THROW(WriteObj(m));
}

// ---------------------------------------------------------------------------------------------
// The fuzz corpus: small valid and broken files of every format. ok_* must decode, bad_* must
// be refused; the fuzz replay feeds the same files to LLVMFuzzerTestOneInput.

std::map<std::string, std::string> CorpusFiles() {
  std::map<std::string, std::string> files;
  const TriangleMesh cube = BoxMesh({0, 0, 0}, {0.5, 0.5, 0.5});
  files["ok_cube.obj"] = WriteObj(cube);
  files["ok_cube_ascii.ply"] = WritePly(cube, Encoding::kAscii);
  files["ok_cube_binary.ply"] = WritePly(cube, Encoding::kBinary);
  files["ok_cube_ascii.stl"] = WriteStl(cube, Encoding::kAscii);
  files["ok_cube_binary.stl"] = WriteStl(cube, Encoding::kBinary);
  files["ok_quads.obj"] =
      "# quads, texture/normal indices, negative indices\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
      "vt 0 0\nvn 0 0 1\nf 1/1/1 4/1/1 3/1/1 2/1/1\nv 0.5 0.5 1\nf -5//1 -4//1 -1//1\n"
      "f 2 3 5\nf 3 4 5\nf 4/1 1/1 5/1\n";
  std::string solid_header = WriteStl(cube, Encoding::kBinary);
  solid_header.replace(0, 6, "solid ");
  files["ok_solid_header_binary.stl"] = solid_header;
  const std::string stl = WriteStl(cube, Encoding::kBinary);
  files["bad_truncated_binary.stl"] = stl.substr(0, stl.size() - 7);
  std::string count = stl;
  count.replace(80, 4, Le32(1000));
  files["bad_count_mismatch.stl"] = count;
  std::string nan_stl = stl;
  const float nan = std::nanf("");
  std::memcpy(&nan_stl[84 + 24], &nan, 4);
  files["bad_nan_binary.stl"] = nan_stl;
  files["bad_no_endloop.stl"] =
      "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
      "endfacet\nendsolid x\n";
  const std::string ply = WritePly(cube, Encoding::kBinary);
  files["bad_truncated_binary.ply"] = ply.substr(0, ply.size() - 9);
  std::string wrong = WritePly(cube, Encoding::kAscii);
  wrong.replace(wrong.find("face 12"), 7, "face 13");
  files["bad_wrong_count.ply"] = wrong;
  std::string index = WritePly(cube, Encoding::kAscii);
  index.replace(index.rfind("3 1 7 5"), 7, "3 1 7 9");
  files["bad_index_out_of_range.ply"] = index;
  files["bad_huge_count.ply"] =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\nproperty float x\n"
      "property float y\nproperty float z\nelement face 4294967295\n"
      "property list uint int vertex_indices\nend_header\n";
  files["bad_index_out_of_range.obj"] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
  files["bad_zero_index.obj"] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n";
  files["bad_nan.obj"] = "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  files["bad_no_faces.obj"] = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  files["bad_unknown.bin"] = std::string("\x00\x01\x02\x03garbage", 11);
  return files;
}

TEST(MeshIoTest, FuzzCorpusDecodesAsNamed) {
  const std::filesystem::path dir =
      std::filesystem::path(SOFTGRASP_SOURCE_DIR) / "tests/fuzz/corpus/mesh_decode";
  const char* write = std::getenv("SOFTGRASP_WRITE_FUZZ_CORPUS");
  if (write != nullptr && std::string(write) == "1") {
    std::filesystem::create_directories(dir);
    for (const auto& [name, bytes] : CorpusFiles()) {
      std::ofstream(dir / name, std::ios::binary) << bytes;
    }
  }
  ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string name = entry.path().filename().string();
    const auto mesh = ReadMesh(bytes);
    if (name.rfind("ok_", 0) == 0) {
      EXPECT_TRUE(mesh.ok()) << name << ": " << mesh.error().message;
    } else if (name.rfind("bad_", 0) == 0) {
      EXPECT_FALSE(mesh.ok()) << name;
    }
    ++files;
  }
  EXPECT_GE(files, static_cast<int>(CorpusFiles().size()));
}

}  // namespace
}  // namespace softgrasp::mesh
