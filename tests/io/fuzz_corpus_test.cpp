// The seed corpus of the depth_decode fuzz target, tests/fuzz/corpus/depth_decode/. Each file's
// name says what decoding it must give; SOFTGRASP_WRITE_FUZZ_CORPUS=1 rewrites the files first
// from the generator below.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "service/io/depth_codec.h"
#include "tests/io/io_test_util.h"

namespace softgrasp::io {
namespace {

namespace fs = std::filesystem;
using core::ErrorCode;
using namespace test;  // NOLINT(google-build-using-namespace): the file builders

const fs::path kCorpusDir = SOFTGRASP_SOURCE_DIR "/tests/fuzz/corpus/depth_decode";
constexpr std::int64_t kFuzzMaxPixels = 1 << 16;  // as in tests/fuzz/depth_decode_fuzz.cpp
constexpr std::uintmax_t kMaxSeedBytes = 20 * 1024;

using Seeds = std::vector<std::pair<std::string, std::string>>;  // file name, bytes

// The image's values as T, row after row (NaN becomes 0 for integers).
template <typename T>
std::vector<T> As(const cv::Mat1f& image) {
  std::vector<T> out;
  for (const float v : image) out.push_back(std::isfinite(v) ? static_cast<T>(v) : T{});
  return out;
}

Seeds NpySeeds() {
  const cv::Mat1f depth = TestDepth(24, 32);
  const std::string npy = EncodeNpy(depth);
  const std::string data = FloatBytes(depth);
  return {
      {"ok_npy_hw.npy", npy},
      {"ok_npy_hw1.npy", MakeNpy(NpyDict("<f4", "(24, 32, 1)"), data)},
      {"ok_npy_big_endian.npy", MakeNpy(NpyDict(">f4", "(24, 32)"), FloatBytes(depth, true))},
      {"ok_npy_fortran.npy", MakeNpy(NpyDict("<f4", "(32, 24)", true), data)},
      {"ok_npy_v2.npy", MakeNpy(NpyDict("<f4", "(24, 32)"), data, 2)},
      {"ok_npy_v3_python2_longs.npy",
       MakeNpy("{'descr':'<f4','fortran_order':False,'shape':(24L,32L)}", data, 3)},
      {"invalid_npy_truncated_header.npy", npy.substr(0, 40)},
      {"invalid_npy_truncated_data.npy", npy.substr(0, npy.size() - 7)},
      {"invalid_npy_zero_size.npy", MakeNpy(NpyDict("<f4", "(0, 32)"), "")},
      {"invalid_npy_malformed_header.npy", MakeNpy("{'descr': '<f4', 'shape': (24, 32", data)},
      {"ok_npy_f8.npy", MakeNpy(NpyDict("<f8", "(24, 32)"), ElementBytes(As<double>(depth)))},
      {"ok_npy_u2_big_endian.npy",
       MakeNpy(NpyDict(">u2", "(24, 32)"), ElementBytes(As<std::uint16_t>(depth * 1000), true))},
      {"invalid_npy_millimetres.npy",
       MakeNpy(NpyDict("<f4", "(24, 32)"), FloatBytes(depth * 1000))},
      {"unsupported_npy_i4.npy", MakeNpy(NpyDict("<i4", "(24, 32)"), data)},
      {"unsupported_npy_rgb.npy", MakeNpy(NpyDict("<f4", "(8, 32, 3)"), data)},
      {"too_large_npy_huge_shape.npy", MakeNpy(NpyDict("<f4", "(100000, 100000)"), data)},
      {"too_large_npy_overflow_shape.npy",
       MakeNpy(NpyDict("<f4", "(4294967296, 4294967296, 1)"), data)},
  };
}

Seeds PngSeeds() {
  const std::string png = EncodePng(TestCounts(24, 32));
  std::string huge = png;
  PatchPngSize(huge, 100000, 100000);
  return {
      {"ok_png16.png", png},
      {"invalid_png_truncated.png", png.substr(0, png.size() / 2)},
      {"unsupported_png_8bit.png", EncodePng(cv::Mat1b(24, 32, 100))},
      {"unsupported_png_rgb16.png", EncodeWithOpenCv(".png", cv::Mat(8, 8, CV_16UC3, 1000))},
      {"too_large_png_huge.png", huge},
  };
}

Seeds TiffSeeds() {
  const cv::Mat1f depth = TestDepth(24, 32);
  const std::string tiff = EncodeTiffFloat(depth);
  std::string huge = tiff;
  PatchTiffTag(huge, TIFFTAG_IMAGEWIDTH, 100000);
  PatchTiffTag(huge, TIFFTAG_IMAGELENGTH, 100000);
  return {
      {"ok_tiff_strips.tiff", tiff},
      {"ok_tiff_big_endian_tiled_lzw.tiff",
       WriteTiffWithLibtiff(depth, "wb", true, COMPRESSION_LZW)},
      {"ok_tiff_deflate.tiff", WriteTiffWithLibtiff(depth, "wl", false, COMPRESSION_ADOBE_DEFLATE)},
      {"invalid_tiff_truncated.tiff", tiff.substr(0, tiff.size() - 20)},
      {"unsupported_tiff_uint16.tiff", EncodeWithOpenCv(".tiff", cv::Mat1w(24, 32, 1000))},
      {"too_large_tiff_huge.tiff", huge},
  };
}

Seeds OtherSeeds() {
  return {
      {"unsupported_garbage.bin", std::string("\x00\x01garbage\xff\xfe not a depth image", 30)},
      {"intr_ok_primesense.intr",
       R"({"_cy": 239.5, "_cx": 319.5, "_fy": 525.0, "_height": 480, "_fx": 525.0, )"
       R"("_width": 640, "_skew": 0.0, "_K": 0, "_frame": "primesense_overhead"})"},
      {"intr_bad_negative_fx.intr",
       R"({"_cy": 239.5, "_cx": 319.5, "_fy": 525.0, "_height": 480, "_fx": -5, "_width": 640})"},
      {"intr_ok_ros_camera_info.json",
       R"({"height": 480, "width": 640, "K": [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]})"},
      {"intr_ok_open3d.json",
       R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})"},
      {"intr_ok_realsense.json",
       R"({"width": 640, "height": 480, "ppx": 319.5, "ppy": 239.5, "fx": 525, "fy": 525})"},
      {"intr_bad_ros_column_major.json",
       R"({"height": 480, "width": 640, "K": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})"},
      {"intr_ok_ros_rect_roi_binning.json",
       R"({"height": 720, "width": 1280, "distortion_model": "plumb_bob", "D": [0.1, -0.2, 0, 0, 0], )"
       R"("K": [600, 0, 640, 0, 600, 360, 0, 0, 1], "R": [1, 0, 0, 0, 1, 0, 0, 0, 1], )"
       R"("P": [590, 0, 638, 0, 0, 590, 358, 0, 0, 0, 1, 0], "binning_x": 2, "binning_y": 2, )"
       R"("roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": false}})"},
      {"intr_bad_ros_roi_outside.json",
       R"({"height": 480, "width": 640, "K": [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1], )"
       R"("roi": {"x_offset": 100, "y_offset": 0, "height": 480, "width": 640}})"},
  };
}

Seeds AllSeeds() {
  Seeds seeds;
  for (Seeds part : {NpySeeds(), PngSeeds(), TiffSeeds(), OtherSeeds()}) {
    for (auto& seed : part) seeds.push_back(std::move(seed));
  }
  return seeds;
}

void ExpectDecodes(const std::string& name, const std::string& bytes) {
  DepthDecodeOptions options;
  options.max_pixels = kFuzzMaxPixels;
  const auto result = DecodeDepth(bytes, options);
  const std::pair<const char*, ErrorCode> failures[] = {
      {"invalid_", ErrorCode::kInvalidArgument},
      {"unsupported_", ErrorCode::kUnsupportedFormat},
      {"too_large_", ErrorCode::kTooLarge}};
  if (name.starts_with("ok_")) {
    EXPECT_TRUE(result.ok()) << result.error().message;
    return;
  }
  for (const auto& [prefix, code] : failures) {
    if (!name.starts_with(prefix)) continue;
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.error().code, code) << result.error().message;
    return;
  }
  if (name.starts_with("intr_")) {
    EXPECT_FALSE(result.ok());
    EXPECT_EQ(ParseIntrinsicsJson(bytes).ok(), name.starts_with("intr_ok_"));
    return;
  }
  ADD_FAILURE() << "corpus file names start with ok_, invalid_, unsupported_, too_large_ or intr_";
}

TEST(FuzzCorpusTest, SeedsDecodeAsTheirNamesSay) {
  if (std::getenv("SOFTGRASP_WRITE_FUZZ_CORPUS")) {
    fs::create_directories(kCorpusDir);
    for (const auto& [name, bytes] : AllSeeds()) {
      std::ofstream(kCorpusDir / name, std::ios::binary) << bytes;
    }
  }
  int count = 0;
  for (const auto& entry : fs::directory_iterator(kCorpusDir)) {
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    EXPECT_LE(entry.file_size(), kMaxSeedBytes);
    ExpectDecodes(name, ReadFile(entry.path()));
    ++count;
  }
  EXPECT_GE(count, static_cast<int>(AllSeeds().size()));
}

TEST(FuzzCorpusTest, GeneratedSeedsDecodeAsTheirNamesSay) {
  for (const auto& [name, bytes] : AllSeeds()) {
    SCOPED_TRACE(name);
    ExpectDecodes(name, bytes);
  }
}

}  // namespace
}  // namespace softgrasp::io
