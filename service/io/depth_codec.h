#pragma once
/// Decoders for depth uploads and encoders for what we send back. Every decoder checks the
/// declared image size against `max_pixels` before it allocates or decompresses anything.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>

#include "service/core/depth.h"
#include "service/core/status.h"

namespace softgrasp::io {

enum class DepthFormat { kNpy, kPng16, kTiff };

const char* DepthFormatName(DepthFormat format);  ///< "npy", "png16", "tiff"

struct DepthDecodeOptions {
  double png_unit_m = 0.001;  ///< metres per 16-bit PNG or uint16 NPY count (default: mm)
  std::int64_t max_pixels = 4096 * 4096;  ///< larger images are refused before decoding (413)
};

/// Recognises the format from the magic bytes. kUnsupportedFormat when none matches.
core::Result<DepthFormat> SniffDepthFormat(std::string_view bytes);

/// Decodes .npy (shape (H,W) or (H,W,1), either byte order; float32 or float64 in metres, or
/// uint16 counts x png_unit_m), 16-bit PNG (counts x png_unit_m), or 32-bit float TIFF in metres.
/// 0 and NaN (and inf, negative) become NaN.
/// Errors: kUnsupportedFormat (unknown format, wrong dtype or bit depth), kInvalidArgument
/// (corrupt or truncated file, zero-size image, a median reading over 100 m: millimetres read as
/// metres), kTooLarge (over max_pixels); the message says which, field = "depth"
/// ("png_unit_m" for a bad unit).
core::Result<core::DepthImage> DecodeDepth(std::string_view bytes,
                                           const DepthDecodeOptions& options = {});

/// Decodes a region-of-interest mask (GQ-CNN's `segmask` convention): a PNG of any bit depth and
/// colour type (grey, grey+alpha, RGB, RGBA, palette; interlaced or not) whose pixel is allowed
/// (255) when any colour sample is non-zero; alpha is ignored. Errors as DecodeDepth's
/// (kUnsupportedFormat for a file that is not a PNG, kInvalidArgument when corrupt or
/// truncated, kTooLarge over max_pixels), with field = "segmask".
core::Result<cv::Mat1b> DecodeMask(std::string_view bytes, std::int64_t max_pixels);

/// Parses camera intrinsics JSON in the layout of GQ-CNN's `.intr` ({"_fx", "_fy", "_cx", "_cy",
/// "_width", "_height", "_frame"?}), a ROS CameraInfo ({"width", "height", "K" or "k": 3 x 3
/// row-major}), Open3D's PinholeCameraIntrinsic ({"width", "height", "intrinsic_matrix": 3 x 3
/// column-major}) or librealsense's intrinsics ({"width", "height", "fx", "fy", "ppx", "ppy"}).
/// kInvalidArgument (field = the key at fault, "intrinsics" when no layout matches) when
/// malformed, missing or non-positive, or when a matrix's last row is not (0, 0, 1).
core::Result<core::Camera> ParseIntrinsicsJson(std::string_view json);

/// Float32 little-endian .npy, shape (H, W).
std::string EncodeNpy(const cv::Mat1f& image);
/// Lossless PNG of an 8-bit (1 or 3 channel, BGR) or 16-bit single-channel image.
/// @throws std::invalid_argument for other types.
std::string EncodePng(const cv::Mat& image);
/// Float32 TIFF, one channel (used by tests and tools).
std::string EncodeTiffFloat(const cv::Mat1f& image);

}  // namespace softgrasp::io
