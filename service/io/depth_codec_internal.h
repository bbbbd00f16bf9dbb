#pragma once
/// Private to softgrasp_io: the per-format decoders behind DecodeDepth and the helpers they share.
/// Every decoder returns the raw float image (missing values not yet normalised to NaN).

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "service/core/status.h"
#include "service/io/depth_codec.h"

namespace softgrasp::io::detail {

/// An error about the uploaded depth image (field = "depth").
core::Error DepthError(core::ErrorCode code, std::string message);

/// Refuses zero-size images (kInvalidArgument) and images over `max_pixels` or too large for
/// cv::Mat (kTooLarge). `what` names the format in the message, e.g. "NPY".
std::optional<core::Error> CheckImageSize(std::int64_t height, std::int64_t width,
                                          std::int64_t max_pixels, std::string_view what);

/// Refuses a png_unit_m that is not a positive finite number of metres per count (16-bit PNG and
/// uint16 NPY counts), field = "png_unit_m".
std::optional<core::Error> CheckCountUnit(double png_unit_m);

/// `text` cut to `max_chars` with non-printable bytes replaced, safe to quote in a JSON message.
std::string Printable(std::string_view text, std::size_t max_chars = 24);

/// uint16 NPY counts are png_unit_m metres each, as 16-bit PNG counts are.
core::Result<cv::Mat1f> DecodeNpy(std::string_view bytes, const DepthDecodeOptions& options);
core::Result<cv::Mat1f> DecodePng16(std::string_view bytes, const DepthDecodeOptions& options);
core::Result<cv::Mat1f> DecodeTiff(std::string_view bytes, std::int64_t max_pixels);

}  // namespace softgrasp::io::detail
