#include "service/core/fge_geometry.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace softgrasp::core::fge_detail {
namespace {

constexpr double kRoundingSlackPx = 1e-9;  // 21.9999999 px counts as 22 px
constexpr double kHistogramBinM = 0.001;
constexpr double kHistogramTopM = 2.0;
// A clamped last slice is added only if it lies at least this far below the previous one.
constexpr double kMinSliceGapM = 0.002;
constexpr int kRegionSampleRows = 120;  // free objects are found on ~120 rows of blocks
// The lower side of a seam is flat: its next pixel differs by less than this times seam_step.
constexpr double kSeamFlatFraction = 0.5;

void Require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("FGE: " + what);
}

int FloorPx(double px) { return static_cast<int>(std::floor(px + kRoundingSlackPx)); }

// Height of the n-th highest positive pixel inside `mask`, from a 1 mm histogram (heights above
// kHistogramTopM share the last bin) refined inside its bin.
std::optional<double> NthHighestHeight(const cv::Mat1f& height_m, const cv::Mat1b& mask, int n) {
  const int bins = static_cast<int>(kHistogramTopM / kHistogramBinM) + 1;
  std::vector<int> count(static_cast<std::size_t>(bins), 0);
  auto bin_of = [&](float h) {
    return std::min(bins - 1, static_cast<int>(h / static_cast<float>(kHistogramBinM)));
  };
  for (int v = 0; v < height_m.rows; ++v) {
    const float* h = height_m.ptr<float>(v);
    const std::uint8_t* m = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < height_m.cols; ++u) {
      if (h[u] > 0 && m[u]) ++count[static_cast<std::size_t>(bin_of(h[u]))];
    }
  }
  int above = 0;  // pixels in bins higher than b
  for (int b = bins - 1; b >= 0; --b) {
    const int in_bin = count[static_cast<std::size_t>(b)];
    if (above + in_bin < n) {
      above += in_bin;
      continue;
    }
    std::vector<float> values;
    values.reserve(static_cast<std::size_t>(in_bin));
    for (int v = 0; v < height_m.rows; ++v) {
      const float* h = height_m.ptr<float>(v);
      const std::uint8_t* m = mask.ptr<std::uint8_t>(v);
      for (int u = 0; u < height_m.cols; ++u) {
        if (h[u] > 0 && m[u] && bin_of(h[u]) == b) values.push_back(h[u]);
      }
    }
    auto nth = values.begin() + (n - above - 1);
    std::nth_element(values.begin(), nth, values.end(), std::greater<>());
    return *nth;
  }
  return std::nullopt;
}

// Pixels of free objects: connected regions of (height > level_m) that do not touch the image
// border, found on a block-max-pooled copy (blocks of `step` pixels keep thin connections).
// Robot parts, bin walls and objects cut by the image border are not free.
cv::Mat1b FreeObjectPixels(const cv::Mat1f& height_m, double level_m) {
  const int step = std::max(1, std::min(height_m.rows, height_m.cols) / kRegionSampleRows);
  const auto level = static_cast<float>(level_m);
  cv::Mat1b blocks((height_m.rows + step - 1) / step, (height_m.cols + step - 1) / step,
                   static_cast<std::uint8_t>(0));
  for (int v = 0; v < height_m.rows; ++v) {
    const float* h = height_m.ptr<float>(v);
    std::uint8_t* b = blocks.ptr<std::uint8_t>(v / step);
    for (int u = 0; u < height_m.cols; ++u) b[u / step] |= h[u] > level ? 1 : 0;
  }
  cv::Mat1i labels, stats;
  cv::Mat1d centroids;
  const int n = cv::connectedComponentsWithStats(blocks, labels, stats, centroids, 8, CV_32S);
  std::vector<std::uint8_t> free_label(static_cast<std::size_t>(n), 0);
  for (int i = 1; i < n; ++i) {
    const int x = stats(i, cv::CC_STAT_LEFT), y = stats(i, cv::CC_STAT_TOP);
    const bool touches = x == 0 || y == 0 || x + stats(i, cv::CC_STAT_WIDTH) == blocks.cols ||
                         y + stats(i, cv::CC_STAT_HEIGHT) == blocks.rows;
    free_label[static_cast<std::size_t>(i)] = touches ? 0 : 255;
  }
  cv::Mat1b free_pixels(height_m.size());
  for (int v = 0; v < height_m.rows; ++v) {
    const float* h = height_m.ptr<float>(v);
    const int* label = labels.ptr<int>(v / step);
    std::uint8_t* out = free_pixels.ptr<std::uint8_t>(v);
    for (int u = 0; u < height_m.cols; ++u) {
      out[u] = h[u] > level ? free_label[static_cast<std::size_t>(label[u / step])] : 0;
    }
  }
  return free_pixels;
}

// Maxima of height_m over the blocks FreeObjectPixels and FreeAtSomeLevel label.
cv::Mat1f BlockMax(const cv::Mat1f& height_m) {
  const int step = std::max(1, std::min(height_m.rows, height_m.cols) / kRegionSampleRows);
  const cv::Size grid((height_m.cols + step - 1) / step, (height_m.rows + step - 1) / step);
  cv::Mat1f block_max(grid, -std::numeric_limits<float>::infinity());
  for (int v = 0; v < height_m.rows; ++v) {
    const float* h = height_m.ptr<float>(v);
    float* b = block_max.ptr<float>(v / step);
    for (int u = 0; u < height_m.cols; ++u) b[u / step] = std::max(b[u / step], h[u]);
  }
  return block_max;
}

// Pixels that are part of a free region at some level from lowest_m up to top_m (in steps): an
// object leaning on a bin wall, or a pile that reaches the walls, is joined to them low down but
// stands free higher up, and its surface there may be grasped. Levels stop at the objects' top so
// that robot parts reaching in from the border, which only separate from it near their own (higher)
// tops, stay obstacles. A region free at one level stays free at every higher level (its part above
// that level touches the border even less), so each block records the lowest level at which it is
// free, and a pixel is free where it rises above that.
// `block_max`: BlockMax(height_m).
cv::Mat1b FreeAtSomeLevel(const cv::Mat1f& height_m, const cv::Mat1f& block_max, double lowest_m,
                          double top_m, double step_m) {
  const int step = std::max(1, std::min(height_m.rows, height_m.cols) / kRegionSampleRows);
  const cv::Size grid = block_max.size();
  cv::Mat1f free_from(grid, std::numeric_limits<float>::infinity());
  cv::Mat1i labels, stats;
  cv::Mat1d centroids;
  for (double level = lowest_m; level < top_m; level += step_m) {
    const cv::Mat1b above = block_max > static_cast<float>(level);
    const int n = cv::connectedComponentsWithStats(above, labels, stats, centroids, 8, CV_32S);
    std::vector<bool> free_label(static_cast<std::size_t>(n), false);
    for (int i = 1; i < n; ++i) {
      const int x = stats(i, cv::CC_STAT_LEFT), y = stats(i, cv::CC_STAT_TOP);
      free_label[static_cast<std::size_t>(i)] = x > 0 && y > 0 &&
                                                x + stats(i, cv::CC_STAT_WIDTH) < grid.width &&
                                                y + stats(i, cv::CC_STAT_HEIGHT) < grid.height;
    }
    for (int y = 0; y < grid.height; ++y) {
      const int* label = labels.ptr<int>(y);
      float* from = free_from.ptr<float>(y);
      for (int x = 0; x < grid.width; ++x) {
        if (free_label[static_cast<std::size_t>(label[x])] && !std::isfinite(from[x])) {
          from[x] = static_cast<float>(level);
        }
      }
    }
  }
  cv::Mat1b free_pixels(height_m.size());
  for (int v = 0; v < height_m.rows; ++v) {
    const float* h = height_m.ptr<float>(v);
    const float* from = free_from.ptr<float>(v / step);
    std::uint8_t* out = free_pixels.ptr<std::uint8_t>(v);
    for (int u = 0; u < height_m.cols; ++u) out[u] = h[u] > from[u / step] ? 255 : 0;
  }
  return free_pixels;
}

// Surfaces above `level_m` cut into pieces along steep slopes (object sides and wall faces seen
// from above) and height jumps, on a blurred copy so that sensor noise does not cut faces apart.
// Pieces that do not touch the image border and cover at least `min_area_px` are free, grown back
// over the cut by its width so that an object keeps its rim. In a dense pile objects touch each
// other, so the regions above a level reach the walls and the border everywhere; their top faces
// still meet along steep sides. Bin walls, robot parts and objects cut by the frame have faces
// that run to the border.
cv::Mat1b FreeSmoothPieces(const cv::Mat1f& height_m, double level_m, double px_per_m,
                           int min_area_px) {
  constexpr double kMaxSlope = 1.5;  // rise over run: faces steeper than ~56 degrees are sides
  constexpr int kBlurPx = 5;
  cv::Mat1f smooth_h;
  cv::blur(height_m, smooth_h, cv::Size(kBlurPx, kBlurPx));
  cv::Mat1f du, dv;
  cv::Sobel(smooth_h, du, CV_32F, 1, 0, 3, 1.0 / 8);  // metres per pixel
  cv::Sobel(smooth_h, dv, CV_32F, 0, 1, 3, 1.0 / 8);
  const auto max_step = static_cast<float>(kMaxSlope / px_per_m);  // metres per pixel
  const auto level = static_cast<float>(level_m);
  cv::Mat1b flat(height_m.size());
  for (int v = 0; v < height_m.rows; ++v) {
    const float* h = height_m.ptr<float>(v);
    const float* gu = du.ptr<float>(v);
    const float* gv = dv.ptr<float>(v);
    std::uint8_t* out = flat.ptr<std::uint8_t>(v);
    for (int u = 0; u < height_m.cols; ++u) {
      out[u] = h[u] > level && gu[u] * gu[u] + gv[u] * gv[u] < max_step * max_step ? 255 : 0;
    }
  }
  cv::Mat1i labels, stats;
  cv::Mat1d centroids;
  const int n = cv::connectedComponentsWithStats(flat, labels, stats, centroids, 4, CV_32S);
  const int rows = height_m.rows, cols = height_m.cols;
  std::vector<std::uint8_t> free_label(static_cast<std::size_t>(n), 0);
  for (int i = 1; i < n; ++i) {
    const int x = stats(i, cv::CC_STAT_LEFT), y = stats(i, cv::CC_STAT_TOP);
    const bool touches = x == 0 || y == 0 || x + stats(i, cv::CC_STAT_WIDTH) == cols ||
                         y + stats(i, cv::CC_STAT_HEIGHT) == rows;
    free_label[static_cast<std::size_t>(i)] =
        !touches && stats(i, cv::CC_STAT_AREA) >= min_area_px ? 255 : 0;
  }
  cv::Mat1b free_pixels(height_m.size());
  for (int v = 0; v < rows; ++v) {
    const int* label = labels.ptr<int>(v);
    std::uint8_t* out = free_pixels.ptr<std::uint8_t>(v);
    for (int u = 0; u < cols; ++u) out[u] = free_label[static_cast<std::size_t>(label[u])];
  }
  cv::dilate(free_pixels, free_pixels,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kBlurPx, kBlurPx)));
  free_pixels &= height_m > level;
  return free_pixels;
}

// The n of "the n-th highest pixel" and the least area of a free piece.
int MinAreaPx(const FgeParams& params) {
  return std::max(1, static_cast<int>(std::ceil(params.min_object_area_px)));
}

// Nothing lower than this can start a slice whose fingertips clear the floor.
double LowestLevelM(const FgeParams& params) {
  return params.floor_clearance_m + params.grip_depth_m;
}

struct FreeObjects {
  double top_m = 0;  // n-th highest free-object pixel at the lowest level with free objects
  cv::Mat1b pixels;  // every pixel free at some level (FreeAtSomeLevel)
};

// The top comes from the free objects at the lowest level (from lowest_m up in steps) where they
// cover n pixels: robot parts reaching into the image only separate near their tops, so objects
// on the floor set it. Graspable are the pixels free at any level. Only pixels in `allowed` (if
// not empty; none outside `roi`) count.
std::optional<FreeObjects> FindFreeObjects(FreeSpace& free_space, const cv::Mat1b& allowed,
                                           const cv::Rect& roi, double step_m, int n) {
  const cv::Mat1f& height_m = free_space.height_m();
  if (roi.empty()) return std::nullopt;  // nothing allowed
  double level = 0;
  for (int k = 0;; ++k) {
    const cv::Mat1b* free_objects = free_space.FreeObjectsAtLevel(k, &level);
    if (free_objects == nullptr) return std::nullopt;
    cv::Mat1b pixels = (*free_objects)(roi);
    if (!allowed.empty()) {
      cv::Mat1b both;
      cv::bitwise_and(pixels, allowed(roi), both);
      pixels = both;
    }
    if (auto top = NthHighestHeight(height_m(roi), pixels, n)) {
      cv::Mat1b graspable = FreeAtSomeLevel(height_m, free_space.block_max(), level, *top, step_m);
      if (!allowed.empty()) graspable &= allowed;
      return FreeObjects{*top, graspable};
    }
  }
}

}  // namespace

}  // namespace softgrasp::core::fge_detail

namespace softgrasp::core {

std::optional<Error> ValidateFgeInputs(const Camera& camera, const Gripper& gripper,
                                       const FgeParams& params) {
  struct Check {
    bool ok;
    const char* field;
    std::string what;
  };
  const Check checks[] = {
      {std::isfinite(camera.fx) && camera.fx > 0 && std::isfinite(camera.fy) && camera.fy > 0 &&
           std::isfinite(camera.cx) && std::isfinite(camera.cy),
       "camera", "camera intrinsics must be finite with fx, fy > 0"},
      {gripper.opening_stroke_m > 0 && gripper.finger_width_m > 0 &&
           gripper.finger_thickness_m > 0 && gripper.finger_length_m > 0,
       "gripper", "gripper sizes must be > 0"},
      {params.num_angles >= 1, "num_angles", "num_angles must be >= 1"},
      {params.num_height_steps >= 1 && params.num_height_steps <= kMaxHeightSteps,
       "num_height_steps",
       "num_height_steps must be in [1, " + std::to_string(kMaxHeightSteps) + "]"},
      {params.height_step_m > 0, "height_step_m", "height_step_m must be > 0"},
      {params.grip_depth_m >= 0, "grip_depth_m", "grip_depth_m must be >= 0"},
      {params.grip_depth_m <= gripper.finger_length_m, "grip_depth_m",
       "grip_depth_m must not exceed the finger length"},
      {params.min_object_area_px >= 0, "min_object_area_px", "min_object_area_px must be >= 0"},
      {std::isfinite(params.floor_clearance_m), "floor_clearance_m",
       "floor_clearance_m must be finite"},
      {params.seam_step_m > 0, "seam_step_m", "seam_step_m must be > 0"},
      {params.top_k >= 1, "top_k", "top_k must be >= 1"},
      {params.nms_radius_px >= 0, "nms_radius_px", "nms_radius_px must be >= 0"},
  };
  for (const Check& c : checks) {
    if (!c.ok) return MakeError(ErrorCode::kInvalidArgument, "FGE: " + c.what, c.field);
  }
  return std::nullopt;
}

}  // namespace softgrasp::core

namespace softgrasp::core::fge_detail {

void CheckInputs(const Camera& camera, const Gripper& gripper, const FgeParams& params) {
  if (auto error = ValidateFgeInputs(camera, gripper, params)) {
    throw std::invalid_argument(error->message);
  }
}

double FloorDepthOnAxisM(const Plane& floor) {
  if (!(std::abs(floor.n[2]) > 1e-9)) return std::numeric_limits<double>::quiet_NaN();
  return -floor.d / floor.n[2];
}

double PxPerMetre(const Plane& floor, const Camera& camera, double height_m) {
  const double z_m = FloorDepthOnAxisM(floor) - height_m;
  if (!(z_m > 0)) throw std::invalid_argument("FGE: slice height is not in front of the camera");
  return camera.fx / z_m;
}

GripperPx GripperAtScale(const Gripper& gripper, double px_per_m) {
  return {gripper.opening_stroke_m * px_per_m, gripper.finger_width_m * px_per_m,
          gripper.finger_thickness_m * px_per_m};
}

TemplateBoxes RasteriseTemplates(const GripperPx& g) {
  TemplateBoxes boxes;
  boxes.contact_half_len = FloorPx(g.opening_px / 2);
  // A finger is never thinner than one pixel, so collisions are always checked.
  boxes.finger_outer =
      std::max(boxes.contact_half_len + 1, FloorPx(g.opening_px / 2 + g.finger_thickness_px));
  boxes.half_width = FloorPx(g.finger_width_px / 2);
  return boxes;
}

int MinContactCount(int contact_area_px) {
  return std::max(1, static_cast<int>(std::ceil(kMinContactFraction * contact_area_px)));
}

double BlurSigmaPx(const GripperPx& g) { return kBlurSigmaPerOpening * g.opening_px; }

int GaussianKernelSize(double sigma_px) {
  return 2 * static_cast<int>(std::ceil(3 * sigma_px)) + 1;
}

Slice SliceAt(double contact_height_m, const Gripper& gripper, const FgeParams& params, int index) {
  const double tip_height_m = contact_height_m - params.grip_depth_m;
  return {index, contact_height_m, tip_height_m, tip_height_m + gripper.finger_length_m};
}

FreeSpace::FreeSpace(const cv::Mat1f& height_m, double floor_px_per_m, const FgeParams& params)
    : height_m_(height_m),
      min_area_px_(MinAreaPx(params)),
      lowest_m_(LowestLevelM(params)),
      step_m_(params.height_step_m) {
  if (height_m.empty()) return;
  cv::minMaxLoc(height_m, nullptr, &max_height_m_);
  smooth_pieces_ = FreeSmoothPieces(height_m, lowest_m_, floor_px_per_m, min_area_px_);
  block_max_ = BlockMax(height_m);
}

bool FreeSpace::Serves(const FgeParams& params) const {
  return MinAreaPx(params) == min_area_px_ && LowestLevelM(params) == lowest_m_ &&
         params.height_step_m == step_m_;
}

const cv::Mat1b* FreeSpace::FreeObjectsAtLevel(int k, double* level_m) {
  while (static_cast<int>(levels_m_.size()) <= k) {
    const double level = levels_m_.empty() ? lowest_m_ : levels_m_.back() + step_m_;
    if (!(level < max_height_m_)) return nullptr;
    levels_m_.push_back(level);
    free_objects_.push_back(FreeObjectPixels(height_m_, level));
  }
  *level_m = levels_m_[static_cast<std::size_t>(k)];
  return &free_objects_[static_cast<std::size_t>(k)];
}

SliceSearch SearchSlices(const cv::Mat1f& height_m, const cv::Mat1b& contact_allowed,
                         double floor_px_per_m, const Gripper& gripper, const FgeParams& params) {
  FreeSpace free_space(height_m, floor_px_per_m, params);
  return SearchSlices(free_space, contact_allowed, gripper, params);
}

SliceSearch SearchSlices(FreeSpace& free_space, const cv::Mat1b& contact_allowed,
                         const Gripper& gripper, const FgeParams& params) {
  Require(free_space.Serves(params), "SearchSlices: the free space was made with other params");
  const cv::Mat1f& height_m = free_space.height_m();
  const int n = MinAreaPx(params);
  const double lowest_m = LowestLevelM(params);
  SliceSearch search;
  // Every pixel that can count lies in the contact mask's bounding box.
  const cv::Rect roi = contact_allowed.empty() ? cv::Rect(cv::Point(0, 0), height_m.size())
                                               : cv::boundingRect(contact_allowed);
  std::optional<double> top;
  cv::Mat1b pieces = contact_allowed.empty() ? free_space.smooth_pieces().clone()
                                             : free_space.smooth_pieces() & contact_allowed;
  const auto free = FindFreeObjects(free_space, contact_allowed, roi, params.height_step_m, n);
  if (free) {
    search.graspable = free->pixels | pieces;
    top = std::max(free->top_m, NthHighestHeight(height_m(roi), pieces(roi), n).value_or(0.0));
  } else if (cv::countNonZero(pieces) >= n) {
    search.graspable = pieces;
    top = NthHighestHeight(height_m(roi), pieces(roi), n);
  } else {  // every object touches the border at every level: let them all count
    search.graspable =
        contact_allowed.empty() ? cv::Mat1b(height_m.size(), 255) : contact_allowed.clone();
    top = NthHighestHeight(height_m(roi), search.graspable(roi), n);
  }
  if (!top) return search;
  const double h0 = *top - kTopSliceMarginM;
  std::vector<Slice>& slices = search.slices;
  for (int k = 0;; ++k) {
    Slice slice = SliceAt(h0 - k * params.height_step_m, gripper, params, k);
    if (slice.tip_height_m < params.floor_clearance_m) {
      // The step would put the fingertips under the clearance: one last slice with the tips
      // exactly at the clearance, unless the previous slice is (almost) there already.
      const bool room =
          !slices.empty() && slices.back().tip_height_m > params.floor_clearance_m + kMinSliceGapM;
      if (room) slices.push_back(SliceAt(lowest_m, gripper, params, k));
      break;
    }
    slices.push_back(slice);
  }
  return search;
}

namespace {

// Seam test for the pair (p, q) of neighbours, p before q along a row or column; `before_p` and
// `after_q` are the next pixels beyond them (NaN when outside the image).
inline float SeamLevel(float before_p, float hp, float hq, float after_q, float step, float flat) {
  if (!(std::abs(hp - hq) >= step)) return 0.0f;
  // The lower side must continue flat away from the step.
  const float beyond = hp < hq ? before_p : after_q;
  const float low = std::min(hp, hq);
  return std::abs(beyond - low) < flat ? low : 0.0f;
}

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> SliceBatches(std::size_t num_slices,
                                                              const FgeParams& params) {
  std::vector<std::pair<std::size_t, std::size_t>> batches;
  const auto size = static_cast<std::size_t>(params.num_height_steps);
  for (std::size_t first = 0; first < num_slices; first += size) {
    batches.emplace_back(first, std::min(num_slices, first + size));
  }
  return batches;
}

cv::Mat1f SeamLevels(const cv::Mat1f& height_m_in, const cv::Mat1b& missing, double seam_step_m) {
  // Filled-in pixels are no evidence of a surface: as NaN they take part in no pair and are no
  // flat continuation (sensors drop pixels along object edges, and the fill bridges the step
  // with runs of in-between heights that would look like a lower surface).
  cv::Mat1f measured;
  if (!missing.empty() && cv::countNonZero(missing) > 0) {
    height_m_in.copyTo(measured);
    measured.setTo(std::numeric_limits<float>::quiet_NaN(), missing);
  }
  const cv::Mat1f& height_m = measured.empty() ? height_m_in : measured;
  const auto step = static_cast<float>(seam_step_m);
  const auto flat = static_cast<float>(seam_step_m * kSeamFlatFraction);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int rows = height_m.rows, cols = height_m.cols;
  cv::Mat1f seam(height_m.size(), 0.0f);
  for (int v = 0; v < rows; ++v) {  // horizontal pairs (u, u + 1)
    const float* h = height_m.ptr<float>(v);
    float* s = seam.ptr<float>(v);
    for (int u = 0; u + 1 < cols; ++u) {
      const float level = SeamLevel(u > 0 ? h[u - 1] : nan, h[u], h[u + 1],
                                    u + 2 < cols ? h[u + 2] : nan, step, flat);
      s[u] = std::max(s[u], level);
      s[u + 1] = std::max(s[u + 1], level);
    }
  }
  for (int v = 0; v + 1 < rows; ++v) {  // vertical pairs (v, v + 1)
    const float* above = v > 0 ? height_m.ptr<float>(v - 1) : nullptr;
    const float* h0 = height_m.ptr<float>(v);
    const float* h1 = height_m.ptr<float>(v + 1);
    const float* below = v + 2 < rows ? height_m.ptr<float>(v + 2) : nullptr;
    float* s0 = seam.ptr<float>(v);
    float* s1 = seam.ptr<float>(v + 1);
    for (int u = 0; u < cols; ++u) {
      if (!(std::abs(h0[u] - h1[u]) >= step)) continue;
      const float level =
          SeamLevel(above ? above[u] : nan, h0[u], h1[u], below ? below[u] : nan, step, flat);
      s0[u] = std::max(s0[u], level);
      s1[u] = std::max(s1[u], level);
    }
  }
  return seam;
}

std::array<double, 3> PointOnRayAtHeight(const Camera& camera, const Plane& floor, double u_px,
                                         double v_px, double height_m) {
  const double rx = (u_px - camera.cx) / camera.fx;
  const double ry = (v_px - camera.cy) / camera.fy;
  const double n_dot_r = floor.n[0] * rx + floor.n[1] * ry + floor.n[2];
  const double t = (height_m - floor.d) / n_dot_r;  // n . (t r) + d = height
  return {t * rx, t * ry, t};
}

std::array<double, 4> QuaternionAboutZ(double angle_rad) {
  return {std::cos(angle_rad / 2), 0.0, 0.0, std::sin(angle_rad / 2)};
}

}  // namespace softgrasp::core::fge_detail
