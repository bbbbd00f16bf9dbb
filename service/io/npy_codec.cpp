// NumPy .npy depth images, shape (H, W) or (H, W, 1), either byte order: float32 or float64 in
// metres, or uint16 counts of png_unit_m (a raw sensor frame saved with numpy.save).
// Format: "\x93NUMPY", major, minor, header length (2 bytes LE in 1.0, 4 bytes in 2.0/3.0),
// a Python dict literal padded with spaces and '\n', then the raw array data.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "service/io/depth_codec.h"
#include "service/io/depth_codec_internal.h"

namespace softgrasp::io {
namespace {

using core::ErrorCode;
using detail::DepthError;

constexpr std::size_t kMagicSize = 6;  // "\x93NUMPY"
constexpr std::size_t kMaxDims = 32;   // numpy's own limit is 32 (64 in numpy 2)
constexpr const char* kAcceptedDtypes =
    "expected float32 or float64 in metres ('<f4', '>f4', '<f8', '>f8') or uint16 counts of "
    "png_unit_m ('<u2', '>u2')";

struct NpyHeader {
  std::string descr;
  bool fortran_order = false;
  std::vector<std::int64_t> shape;
};

/// Parses the header dict by hand, e.g. {'descr': '<f4', 'fortran_order': False, 'shape': (4, 5), }
class NpyHeaderParser {
 public:
  explicit NpyHeaderParser(std::string_view text) : text_(text) {}

  core::Result<NpyHeader> Parse() {
    NpyHeader header;
    SkipSpace();
    if (!Consume('{')) return Malformed("'{'");
    SkipSpace();
    while (!Consume('}')) {
      if (auto error = ParseEntry(header)) return *error;
      SkipSpace();
      if (!Consume(',') && Peek() != '}') return Malformed("',' or '}'");
      SkipSpace();
    }
    SkipSpace();
    if (pos_ != text_.size()) return Malformed("the end of the header");
    for (const char* key : {"descr", "fortran_order", "shape"}) {
      if (!seen_[KeyIndex(key)]) {
        return DepthError(ErrorCode::kInvalidArgument,
                          std::string("malformed NPY header: the key '") + key + "' is missing");
      }
    }
    return header;
  }

 private:
  static int KeyIndex(std::string_view key) {
    if (key == "descr") return 0;
    if (key == "fortran_order") return 1;
    if (key == "shape") return 2;
    return -1;
  }

  std::optional<core::Error> ParseEntry(NpyHeader& header) {
    const auto key = ParseString();
    if (!key) return Malformed("a quoted key");
    const int index = KeyIndex(*key);
    if (index < 0) {
      return DepthError(ErrorCode::kInvalidArgument,
                        "malformed NPY header: unexpected key '" + detail::Printable(*key) + "'");
    }
    seen_[index] = true;
    SkipSpace();
    if (!Consume(':')) return Malformed("':'");
    SkipSpace();
    if (index == 0) return ParseDescr(header.descr);
    if (index == 1 && !ParseBool(header.fortran_order)) return Malformed("True or False");
    if (index == 2 && !ParseTuple(header.shape)) return Malformed("a tuple of integers");
    return std::nullopt;
  }

  std::optional<core::Error> ParseDescr(std::string& descr) {
    if (Peek() == '[') {
      return DepthError(ErrorCode::kUnsupportedFormat,
                        std::string("NPY structured dtypes are not supported; ") + kAcceptedDtypes);
    }
    auto value = ParseString();
    if (!value) return Malformed("a quoted dtype");
    descr = std::move(*value);
    return std::nullopt;
  }

  std::optional<std::string> ParseString() {
    const char quote = Peek();
    if (quote != '\'' && quote != '"') return std::nullopt;
    const std::size_t end = text_.find(quote, pos_ + 1);
    if (end == std::string_view::npos) return std::nullopt;
    std::string value(text_.substr(pos_ + 1, end - pos_ - 1));
    pos_ = end + 1;
    return value;
  }

  bool ParseBool(bool& value) {
    if (ConsumeWord("True")) {
      value = true;
    } else if (ConsumeWord("False")) {
      value = false;
    } else {
      return false;
    }
    return true;
  }

  /// "(480, 640)", "(480, 640, 1)", "(5,)", "()"; Python 2 numpy wrote "480L".
  bool ParseTuple(std::vector<std::int64_t>& dims) {
    dims.clear();
    if (!Consume('(')) return false;
    SkipSpace();
    while (!Consume(')')) {
      if (dims.size() >= kMaxDims || !IsDigit(Peek())) return false;
      dims.push_back(ParseInt());
      Consume('L');
      SkipSpace();
      if (!Consume(',') && Peek() != ')') return false;
      SkipSpace();
    }
    return true;
  }

  /// Digits at pos_ (at least one); saturates at INT64_MAX, which the size check then refuses.
  std::int64_t ParseInt() {
    constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
    std::int64_t value = 0;
    while (IsDigit(Peek())) {
      const int digit = text_[pos_++] - '0';
      value = value > (kMax - digit) / 10 ? kMax : value * 10 + digit;
    }
    return value;
  }

  static bool IsDigit(char c) { return c >= '0' && c <= '9'; }
  char Peek() const { return pos_ < text_.size() ? text_[pos_] : '\0'; }
  bool Consume(char c) {
    if (Peek() != c || pos_ >= text_.size()) return false;
    ++pos_;
    return true;
  }
  bool ConsumeWord(std::string_view word) {
    if (text_.substr(pos_, word.size()) != word) return false;
    pos_ += word.size();
    return true;
  }
  void SkipSpace() {
    while (Peek() == ' ' || Peek() == '\t' || Peek() == '\n' || Peek() == '\r') ++pos_;
  }
  core::Error Malformed(std::string_view expected) const {
    return DepthError(ErrorCode::kInvalidArgument, "malformed NPY header: expected " +
                                                       std::string(expected) + " at byte " +
                                                       std::to_string(pos_));
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  bool seen_[3] = {false, false, false};
};

struct NpyLayout {
  NpyHeader header;
  std::string_view data;  ///< everything after the header
};

std::uint32_t ReadLittleEndian(std::string_view bytes) {
  std::uint32_t value = 0;
  for (std::size_t i = bytes.size(); i-- > 0;) {
    value = (value << 8) | static_cast<unsigned char>(bytes[i]);
  }
  return value;
}

core::Result<NpyLayout> ReadLayout(std::string_view bytes) {
  constexpr std::size_t kVersionEnd = kMagicSize + 2;
  if (bytes.size() < kVersionEnd + 2) {
    return DepthError(ErrorCode::kInvalidArgument, "NPY file is truncated inside its preamble");
  }
  const int major = static_cast<unsigned char>(bytes[kMagicSize]);
  const int minor = static_cast<unsigned char>(bytes[kMagicSize + 1]);
  if (major < 1 || major > 3 || minor != 0) {
    return DepthError(ErrorCode::kUnsupportedFormat,
                      "NPY format version " + std::to_string(major) + "." + std::to_string(minor) +
                          " is not supported; expected 1.0, 2.0 or 3.0");
  }
  const std::size_t length_size = major == 1 ? 2 : 4;
  const std::size_t header_start = kVersionEnd + length_size;
  if (bytes.size() < header_start) {
    return DepthError(ErrorCode::kInvalidArgument, "NPY file is truncated inside its preamble");
  }
  const std::size_t header_length = ReadLittleEndian(bytes.substr(kVersionEnd, length_size));
  if (header_length > bytes.size() - header_start) {
    return DepthError(ErrorCode::kInvalidArgument,
                      "NPY header length " + std::to_string(header_length) +
                          " runs past the end of the file (" + std::to_string(bytes.size()) +
                          " bytes): truncated header");
  }
  auto header = NpyHeaderParser(bytes.substr(header_start, header_length)).Parse();
  if (!header) return header.error();
  return NpyLayout{std::move(header).value(), bytes.substr(header_start + header_length)};
}

std::string ShapeText(const std::vector<std::int64_t>& shape) {
  std::string text = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    text += (i ? ", " : "") + std::to_string(shape[i]);
  }
  return text + (shape.size() == 1 ? ",)" : ")");
}

/// A supported element type: its size, byte order and kind.
struct Dtype {
  std::size_t bytes = 4;
  bool big_endian = false;
  bool unsigned_integer = false;  ///< uint16 counts; otherwise IEEE floating point
};

core::Result<Dtype> CheckDtype(const std::string& descr) {
  if (descr.size() == 3 && (descr[0] == '<' || descr[0] == '>')) {
    const bool big = descr[0] == '>';
    const std::string_view kind(descr.data() + 1, 2);
    if (kind == "f4") return Dtype{4, big, false};
    if (kind == "f8") return Dtype{8, big, false};
    if (kind == "u2") return Dtype{2, big, true};
  }
  return DepthError(ErrorCode::kUnsupportedFormat, "NPY dtype '" + detail::Printable(descr) +
                                                       "' is not supported; " + kAcceptedDtypes);
}

/// (H, W) or (H, W, 1), within max_pixels; returns the size as (rows, cols).
core::Result<cv::Size> CheckShape(const std::vector<std::int64_t>& shape, std::int64_t max_pixels) {
  const bool image_shape = shape.size() == 2 || (shape.size() == 3 && shape[2] == 1);
  if (!image_shape) {
    const bool empty = shape.size() == 3 && shape[2] == 0;
    return DepthError(empty ? ErrorCode::kInvalidArgument : ErrorCode::kUnsupportedFormat,
                      "NPY shape " + ShapeText(shape) + " is not a depth image; expected (H, W) " +
                          "or (H, W, 1)");
  }
  if (auto error = detail::CheckImageSize(shape[0], shape[1], max_pixels, "NPY")) return *error;
  return cv::Size(static_cast<int>(shape[1]), static_cast<int>(shape[0]));
}

/// The element at `p` (dtype.bytes bytes, reversed first when `swap`) as a float; counts times
/// `count_unit_m`.
float ReadElement(const char* p, const Dtype& dtype, bool swap, double count_unit_m) {
  unsigned char raw[8];
  std::memcpy(raw, p, dtype.bytes);
  if (swap) std::reverse(raw, raw + dtype.bytes);
  switch (dtype.bytes) {
    case 2: {
      std::uint16_t count;
      std::memcpy(&count, raw, 2);
      return static_cast<float>(count * count_unit_m);
    }
    case 8: {
      double value;
      std::memcpy(&value, raw, 8);
      return static_cast<float>(value);
    }
    default: {
      float value;
      std::memcpy(&value, raw, 4);
      return value;
    }
  }
}

/// Copies `rows` x `cols` elements stored row after row in `data` as floats.
cv::Mat1f CopyPixels(std::string_view data, int rows, int cols, const Dtype& dtype,
                     double count_unit_m) {
  cv::Mat1f image(rows, cols);
  const char* p = data.data();
  const bool swap = dtype.big_endian != (std::endian::native == std::endian::big);
  if (dtype.bytes == sizeof(float) && !dtype.unsigned_integer && !swap) {
    std::memcpy(image.data, p, image.total() * sizeof(float));  // the usual case: as stored
    return image;
  }
  for (int r = 0; r < rows; ++r) {
    float* row = image[r];
    for (int c = 0; c < cols; ++c, p += dtype.bytes)
      row[c] = ReadElement(p, dtype, swap, count_unit_m);
  }
  return image;
}

void AppendLittleEndian(std::string& out, std::uint32_t value, std::size_t size) {
  for (std::size_t i = 0; i < size; ++i) out += static_cast<char>((value >> (8 * i)) & 0xffu);
}

}  // namespace

namespace detail {

core::Result<cv::Mat1f> DecodeNpy(std::string_view bytes, const DepthDecodeOptions& options) {
  auto layout = ReadLayout(bytes);
  if (!layout) return layout.error();
  const NpyHeader& header = layout.value().header;
  const auto dtype = CheckDtype(header.descr);
  if (!dtype) return dtype.error();
  if (dtype.value().unsigned_integer) {
    if (auto error = detail::CheckCountUnit(options.png_unit_m)) return *error;
  }
  const auto size = CheckShape(header.shape, options.max_pixels);
  if (!size) return size.error();

  const auto [cols, rows] = size.value();
  const std::string_view data = layout.value().data;
  const std::uint64_t needed =
      static_cast<std::uint64_t>(rows) * static_cast<std::uint64_t>(cols) * dtype.value().bytes;
  if (data.size() < needed) {
    return DepthError(ErrorCode::kInvalidArgument,
                      "NPY data is truncated: shape " + ShapeText(header.shape) + " needs " +
                          std::to_string(needed) + " bytes, the file has " +
                          std::to_string(data.size()));
  }
  if (!header.fortran_order) {
    return CopyPixels(data, rows, cols, dtype.value(), options.png_unit_m);
  }
  // Fortran (column-major) order: the data is the transposed image stored row-major.
  cv::Mat1f image;
  cv::transpose(CopyPixels(data, cols, rows, dtype.value(), options.png_unit_m), image);
  return image;
}

}  // namespace detail

std::string EncodeNpy(const cv::Mat1f& image) {
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" +
                       std::to_string(image.rows) + ", " + std::to_string(image.cols) + "), }";
  // Magic, version, 2-byte length, dict, '\n': padded with spaces to a multiple of 64 bytes.
  constexpr std::size_t kPreamble = kMagicSize + 2 + 2;
  const std::size_t unpadded = kPreamble + header.size() + 1;
  header.append((unpadded + 63) / 64 * 64 - unpadded, ' ');
  header += '\n';

  std::string out("\x93NUMPY\x01\x00", kMagicSize + 2);
  AppendLittleEndian(out, static_cast<std::uint32_t>(header.size()), 2);
  out += header;
  out.reserve(out.size() + image.total() * sizeof(float));
  for (int r = 0; r < image.rows; ++r) {
    const float* row = image[r];
    for (int c = 0; c < image.cols; ++c) {
      AppendLittleEndian(out, std::bit_cast<std::uint32_t>(row[c]), sizeof(float));
    }
  }
  return out;
}

}  // namespace softgrasp::io
