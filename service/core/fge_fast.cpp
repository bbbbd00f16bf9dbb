// Fast FGE: per angle, rotate a 16-bit "level" image so the closing axis is the x axis; per
// slice, threshold it, build integral images and read the templates as axis-aligned box sums
// around each object; blur the candidates on coarse cells and read their peaks.
// See docs/fge.md, section "Fast implementation".
#include "service/core/fge_fast.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace softgrasp::core::fge_detail {
namespace {

// A level word holds in bits 0-6 how many threshold levels the (pooled) height exceeds, in bit 7
// whether the surface may be contacted (part of a free object) and in bits 8-15 how many levels
// the seam level exceeds.
constexpr std::uint16_t kGraspableBit = 0x80;
constexpr std::uint16_t kLevelMask = 0x7f;
constexpr std::uint16_t kLowByte = 0xff;
constexpr std::uint16_t kSeamMask = 0xff00;
constexpr int kSeamShift = 8;
constexpr std::uint16_t kOutsideLevel = 0x7f;  // outside the image: above every level, no contact
constexpr int kMaxLevels = kOutsideLevel - 1;
constexpr float kLevelMergeM = 1e-7f;  // levels closer than this are one level
// Image pixels around a pixel that its pooled seam level depends on (SeamLevels' pairs read one
// pixel beyond the pair, ConservativePool grows by one).
constexpr int kSeamReachPx = 3;
// The graspability blur runs on cells of d x d work pixels, d in {1, 2, 4} as large as keeps
// sigma >= kMinBlurSigmaCells cells.
constexpr double kMinBlurSigmaCells = 2.5;
constexpr int kMaxBlurDownscale = 4;
constexpr double kHalfPi = 1.5707963267948966;

int WorkScale(const Plane& floor, const Camera& camera, const Gripper& gripper) {
  const GripperPx at_floor = GripperAtScale(gripper, PxPerMetre(floor, camera, 0.0));
  const int scale = static_cast<int>(at_floor.finger_thickness_px / kMinFingerThicknessWorkPx);
  return std::clamp(scale, 1, kMaxWorkScale);
}

// dst[c] = max(dst[c], max of src[c s .. c s + s - 1]) for the `cols` full blocks of a row.
template <class T>
void PoolRow(const T* __restrict src, T* __restrict dst, int cols, int scale) {
  if (scale == 2) {  // the common case, written to auto-vectorise
    for (int c = 0; c < cols; ++c) dst[c] = std::max(dst[c], std::max(src[2 * c], src[2 * c + 1]));
    return;
  }
  for (int c = 0; c < cols; ++c) {
    for (int k = 0; k < scale; ++k) dst[c] = std::max(dst[c], src[c * scale + k]);
  }
}

// Block maximum: work pixel (r, c) holds the maximum of image pixels [r s, r s + s) x [c s,
// c s + s) after growing the image by `grow_px` (3x3 dilations).
template <class T>
cv::Mat_<T> PoolMax(const cv::Mat_<T>& image, int scale, int grow_px, T lowest) {
  cv::Mat_<T> grown;  // a new buffer: dilating into `image`'s would change the caller's data
  if (grow_px > 0) {
    cv::dilate(image, grown, cv::Mat(), cv::Point(-1, -1), grow_px, cv::BORDER_CONSTANT,
               cv::Scalar(lowest));
  } else {
    grown = image;
  }
  if (scale == 1) return grown;
  cv::Mat_<T> pooled((image.rows + scale - 1) / scale, (image.cols + scale - 1) / scale, lowest);
  const int full_cols = image.cols / scale;
  for (int v = 0; v < image.rows; ++v) {
    const T* src = grown.template ptr<T>(v);
    T* dst = pooled.template ptr<T>(v / scale);
    PoolRow(src, dst, full_cols, scale);
    for (int u = full_cols * scale; u < image.cols; ++u) {  // partial last block
      dst[full_cols] = std::max(dst[full_cols], src[u]);
    }
  }
  return pooled;
}

// Growing heights by one image pixel before pooling keeps the fast path conservative: anything
// that collides at full resolution also collides at work resolution, even after the
// nearest-neighbour rotation (which may shift a boundary by half a work pixel).
cv::Mat1f ConservativePool(const cv::Mat1f& image, int scale) {
  return PoolMax<float>(image, scale, 1, -std::numeric_limits<float>::infinity());
}

// Sorted, de-duplicated heights at which the fast path thresholds (contact, tip and palm levels).
std::vector<float> CollectLevels(const std::vector<Slice>& slices) {
  std::vector<float> levels;
  for (const Slice& s : slices) {
    levels.push_back(static_cast<float>(s.contact_height_m));
    levels.push_back(static_cast<float>(s.tip_height_m));
    levels.push_back(static_cast<float>(s.palm_height_m));
  }
  std::sort(levels.begin(), levels.end());
  levels.erase(std::unique(levels.begin(), levels.end(),
                           [](float a, float b) { return b - a < kLevelMergeM; }),
               levels.end());
  CV_Assert(static_cast<int>(levels.size()) <= kMaxLevels);
  return levels;
}

int LevelIndex(const std::vector<float>& levels, double height_m) {
  const auto h = static_cast<float>(height_m);
  const auto it = std::min_element(levels.begin(), levels.end(), [h](float a, float b) {
    return std::abs(a - h) < std::abs(b - h);
  });
  return static_cast<int>(it - levels.begin());
}

void CountAbove(const float* __restrict src, float level, std::uint8_t* __restrict count, int n) {
  for (int i = 0; i < n; ++i) count[i] = static_cast<std::uint8_t>(count[i] + (src[i] > level));
}

// Number of levels each value lies strictly above (value > levels[j]  <=>  result > j), plus
// kGraspableBit where `graspable` is set (if given).
cv::Mat1b LevelImage(const cv::Mat1f& values, const std::vector<float>& levels,
                     const cv::Mat1b& graspable = {}) {
  cv::Mat1b out = cv::Mat1b::zeros(values.size());
  for (int v = 0; v < values.rows; ++v) {
    std::uint8_t* dst = out.ptr<std::uint8_t>(v);
    for (const float level : levels) CountAbove(values.ptr<float>(v), level, dst, values.cols);
    if (graspable.empty()) continue;
    const std::uint8_t* g = graspable.ptr<std::uint8_t>(v);
    for (int u = 0; u < values.cols; ++u) {
      if (g[u] && dst[u] > 0) dst[u] = static_cast<std::uint8_t>(dst[u] | kGraspableBit);
    }
  }
  return out;
}

// `rect` of `image`, with `outside` where the rect leaves the image.
cv::Mat1b CropWithBorder(const cv::Mat1b& image, const cv::Rect& rect, std::uint8_t outside) {
  const cv::Rect inside = rect & cv::Rect(cv::Point(0, 0), image.size());
  cv::Mat1b out;
  cv::copyMakeBorder(image(inside), out, inside.y - rect.y, rect.br().y - inside.br().y,
                     inside.x - rect.x, rect.br().x - inside.br().x, cv::BORDER_CONSTANT,
                     cv::Scalar(outside));
  return out;
}

// How far the box sums of a candidate reach from the I_t pixel that makes it possible: the
// candidate lies within (A, B) of it and its sums read up to (F + 1, B + 1) further.
int ReachPx(const TemplateBoxes& b) {
  return static_cast<int>(
             std::ceil(std::hypot(b.contact_half_len + b.finger_outer + 1, 2 * b.half_width + 1))) +
         1;
}

// The top-left `size` of `buffer`, which grows when too small (buffers are reused, so large
// images are not allocated and page-faulted again for every slice and angle).
template <class M>
M View(M& buffer, cv::Size size) {
  if (buffer.rows < size.height || buffer.cols < size.width) {
    buffer.create(std::max(buffer.rows, size.height), std::max(buffer.cols, size.width));
  }
  return buffer(cv::Rect(cv::Point(0, 0), size));
}

int BlurDownscale(double sigma_px) {
  int d = 1;
  while (2 * d <= kMaxBlurDownscale && sigma_px / (2 * d) >= kMinBlurSigmaCells) d *= 2;
  return d;
}

cv::Rect RoundUp(const cv::Rect& r, int multiple) {
  auto up = [multiple](int n) { return (n + multiple - 1) / multiple * multiple; };
  return {r.x, r.y, up(r.width), up(r.height)};
}

// Binary image (0/1) of (word & mask) > level, written to auto-vectorise.
void ThresholdMasked(const std::uint16_t* __restrict src, std::uint8_t* __restrict dst, int n,
                     std::uint16_t mask, std::uint16_t level) {
  for (int i = 0; i < n; ++i) dst[i] = static_cast<std::uint8_t>((src[i] & mask) > level);
}

// Level words: height levels (+ graspable bit) in the low byte, seam levels in the high byte.
cv::Mat1w PackLevels(const cv::Mat1b& height_levels, const cv::Mat1b& seam_levels) {
  cv::Mat1w out(height_levels.size());
  for (int y = 0; y < out.rows; ++y) {
    const std::uint8_t* h = height_levels.ptr<std::uint8_t>(y);
    const std::uint8_t* s = seam_levels.ptr<std::uint8_t>(y);
    std::uint16_t* o = out.ptr<std::uint16_t>(y);
    for (int x = 0; x < out.cols; ++x)
      o[x] = static_cast<std::uint16_t>(h[x] | (s[x] << kSeamShift));
  }
  return out;
}

}  // namespace

struct FastFge::Workspace {
  cv::Mat1w levels, turned_levels;
  cv::Mat1b binary;
  std::vector<cv::Mat1i> integrals;
  cv::Mat1f candidate, small, blurred, grasp;
  std::vector<int> strip_contact, strip_tip, strip_palm, strip_seam;
  std::vector<int> row_contact, row_collision;
  cv::Mat2f region_map;   // Candidates: a pooled map rotated onto the canvas
  cv::Mat2d region_sums;  // Candidates: its integral image around a cluster's candidates
};

struct FastFge::Canvas {
  cv::Mat1w levels;  // view into the workspace: level words
  cv::Matx23d crop_from_canvas;
  cv::Matx23d canvas_from_crop;
  cv::Rect safe;                  // centres whose box sums stay inside the canvas
  std::vector<cv::Rect> objects;  // FastFge::objects_ boxes, rotated (canvas pixels)
};

namespace {

// Integral images of the canvas' binary images over `region`, each computed once per angle.
class IntegralCache {
 public:
  /// `next_slot`: the next free integral buffer of the workspace, shared by all caches of an angle.
  IntegralCache(const FastFge::Canvas& canvas, const cv::Rect& region, FastFge::Workspace& ws,
                std::size_t& next_slot)
      : canvas_(canvas), region_(region), ws_(ws), next_slot_(next_slot) {}

  const cv::Rect& region() const { return region_; }

  /// Any surface above level j (obstacles; the outside of the image included).
  cv::Mat1i ObstaclesAbove(int level) { return Above(Kind::kObstacle, level); }
  /// Graspable surface above level j (I_t).
  cv::Mat1i ContactAbove(int level) { return Above(Kind::kContact, level); }
  /// Seams whose both sides lie above level j.
  cv::Mat1i SeamsAbove(int level) { return Above(Kind::kSeam, level); }

 private:
  enum class Kind { kObstacle, kContact, kSeam };
  struct Entry {
    Kind kind;
    int level;
    cv::Mat1i sums;
  };

  cv::Mat1i Above(Kind kind, int level) {
    for (const Entry& e : entries_) {
      if (e.kind == kind && e.level == level) return e.sums;
    }
    const cv::Mat1w src = canvas_.levels(region_);
    cv::Mat1b binary = View(ws_.binary, region_.size());
    std::uint16_t mask = kLevelMask;
    int above = level;
    if (kind == Kind::kContact) {  // low byte > graspable bit + j  <=>  graspable and level > j
      mask = kLowByte;
      above = kGraspableBit + level;
    } else if (kind == Kind::kSeam) {  // high byte > j
      mask = kSeamMask;
      above = (level << kSeamShift) | kLowByte;
    }
    for (int y = 0; y < src.rows; ++y) {
      ThresholdMasked(src.ptr<std::uint16_t>(y), binary.ptr<std::uint8_t>(y), src.cols, mask,
                      static_cast<std::uint16_t>(above));
    }
    const std::size_t slot = next_slot_++;
    if (ws_.integrals.size() <= slot) ws_.integrals.resize(slot + 1);
    cv::Mat1i sums = View(ws_.integrals[slot], region_.size() + cv::Size(1, 1));
    cv::integral(binary, sums, CV_32S);
    entries_.push_back({kind, level, sums});
    return sums;
  }

  const FastFge::Canvas& canvas_;
  cv::Rect region_;
  FastFge::Workspace& ws_;
  std::size_t& next_slot_;
  std::vector<Entry> entries_;  // a handful of levels: a vector beats a map
};

struct SliceIntegrals {  // headers sharing the workspace buffers
  cv::Point origin;      // canvas pixel of the integrals' first row and column
  cv::Mat1i contact;     // I_t
  cv::Mat1i tip;         // I_c
  cv::Mat1i palm;        // empty: nothing reaches the palm
  cv::Mat1i seam;        // empty: no seam
};

void StripSums(const int* __restrict top, const int* __restrict bottom, int* __restrict out,
               std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) out[i] = bottom[i] - top[i];
}

// out[i] = number of set pixels in columns < x0 + i of rows [y - b, y + b] (zeros if absent).
void Strip(const cv::Mat1i& integral, int y, int b, int x0, std::vector<int>& out) {
  if (integral.empty()) {
    std::fill(out.begin(), out.end(), 0);
    return;
  }
  StripSums(integral.ptr<int>(y - b) + x0, integral.ptr<int>(y + b + 1) + x0, out.data(),
            out.size());
}

// Candidate test for `width` pixels of a row over strip sums: index i + f is the candidate's own
// column, its closing region spans [i + f - a, i + f + a] and its fingers [i, i + f - a - 1] and
// [i + f + a + 1, i + 2f]. Restrict parameters let GCC vectorise the loop.
int EvaluateRow(const int* __restrict st, const int* __restrict sc, const int* __restrict sp,
                const int* __restrict ss, int a, int f, int min_contact, int width,
                float* __restrict candidate, int* __restrict contact_out,
                int* __restrict collision_out) {
  const int lo = f - a, hi = f + a + 1, outer = 2 * f + 1;
  int count = 0;
  for (int i = 0; i < width; ++i) {
    const int contact = st[i + hi] - st[i + lo];
    const int tips_inside = sc[i + hi] - sc[i + lo];
    const int collision = sc[i + outer] - sc[i + hi] + sc[i + lo] - sc[i];
    const int blocked = collision | (sp[i + outer] - sp[i]) | (ss[i + hi] - ss[i + lo]);
    const int ok = (contact >= min_contact) & (blocked == 0) &
                   (tips_inside * kSlipRatioDen <= contact * kSlipRatioNum);
    candidate[i] = static_cast<float>(ok);
    contact_out[i] = contact;
    collision_out[i] = collision;
    count += ok;
  }
  return count;
}

// One row of the candidate map (1 where A_t >= min, A_c = 0, no slip, no palm collision and no
// seam) for canvas pixels [x0, x0 + width) of row y; A_t and A_c per pixel go to the workspace.
// Returns the number of candidates.
int CandidateRow(const SliceIntegrals& in, const FastFge::SliceWork& w, int y, int x0, int width,
                 FastFge::Workspace& ws, float* candidate) {
  const int a = w.boxes.contact_half_len;
  const int f = w.boxes.finger_outer;
  const int b = w.boxes.half_width;
  const auto n = static_cast<std::size_t>(width + 2 * f + 1);
  for (auto* s : {&ws.strip_contact, &ws.strip_tip, &ws.strip_palm, &ws.strip_seam}) s->resize(n);
  ws.row_contact.resize(static_cast<std::size_t>(width));
  ws.row_collision.resize(static_cast<std::size_t>(width));
  const int iy = y - in.origin.y, ix = x0 - f - in.origin.x;
  Strip(in.contact, iy, b, ix, ws.strip_contact);
  Strip(in.tip, iy, b, ix, ws.strip_tip);
  Strip(in.palm, iy, b, ix, ws.strip_palm);
  Strip(in.seam, iy, b, ix, ws.strip_seam);
  return EvaluateRow(ws.strip_contact.data(), ws.strip_tip.data(), ws.strip_palm.data(),
                     ws.strip_seam.data(), a, f, w.min_contact_px, width, candidate,
                     ws.row_contact.data(), ws.row_collision.data());
}

void BlurSmall(const cv::Mat1f& candidate, double sigma_px, int d, FastFge::Workspace& ws,
               cv::Mat1f& small, cv::Mat1f& blurred);

// Gaussian blur of the candidate map times the candidate map, clamped to [0, 1]. The blur runs
// on cells of d x d pixels (area averages, sigma scaled alike) and is upsampled bicubically.
// `candidate` (sides divisible by d) must hold every candidate of the map (the blur sees zeros
// around it: exact at every candidate).
void Graspability(const cv::Mat1f& candidate, double sigma_px, int d, FastFge::Workspace& ws,
                  cv::Mat1f& grasp) {
  cv::Mat1f small, blurred_small;
  BlurSmall(candidate, sigma_px, d, ws, small, blurred_small);
  cv::Mat1f blurred;
  cv::resize(blurred_small, blurred, candidate.size(), 0, 0, cv::INTER_CUBIC);
  for (int y = 0; y < candidate.rows; ++y) {
    const float* c = candidate.ptr<float>(y);
    const float* g = blurred.ptr<float>(y);
    float* out = grasp.ptr<float>(y);
    for (int x = 0; x < candidate.cols; ++x) out[x] = c[x] * std::clamp(g[x], 0.0f, 1.0f);
  }
}

struct CanvasPeak {
  cv::Point2d canvas_px;
  float score;
};

// Rectangles that overlap once grown by `gap` pixels are merged until none do: the results are
// disjoint and at least `gap` apart.
std::vector<cv::Rect> MergeRects(std::vector<cv::Rect> rects, int gap) {
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i < rects.size() && !merged; ++i) {
      const cv::Rect grown(rects[i].x - gap, rects[i].y - gap, rects[i].width + 2 * gap,
                           rects[i].height + 2 * gap);
      for (std::size_t j = i + 1; j < rects.size(); ++j) {
        if ((grown & rects[j]).empty()) continue;
        rects[i] |= rects[j];
        rects.erase(rects.begin() + static_cast<std::ptrdiff_t>(j));
        merged = true;
        break;
      }
    }
  }
  return rects;
}

// Where one slice is evaluated: box sums run on `rois` (objects reaching the slice's contact
// level, grown by the closing region; overlapping ones merged), the blur on `clusters` (rois
// closer than the blur radius merged: the blur of one cluster never reaches another).
int BlurRadius(const FastFge::SliceWork& w);

struct SliceRegions {
  std::vector<cv::Rect> rois;
  std::vector<cv::Rect> clusters;
};

SliceRegions RegionsOfSlice(const FastFge::Canvas& canvas,
                            const std::vector<FastFge::Object>& objects,
                            const FastFge::SliceWork& w) {
  std::vector<cv::Rect> rois;
  const int a = w.boxes.contact_half_len, b = w.boxes.half_width;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    if (objects[i].max_contact_level <= w.contact_level) continue;
    const cv::Rect& r = canvas.objects[i];
    const cv::Rect roi =
        cv::Rect(r.x - a, r.y - b, r.width + 2 * a, r.height + 2 * b) & canvas.safe;
    if (!roi.empty()) rois.push_back(roi);
  }
  SliceRegions regions;
  regions.rois = MergeRects(std::move(rois), 0);
  regions.clusters = MergeRects(regions.rois, BlurRadius(w));
  return regions;
}

// Bounding box of the non-zero pixels of rows [y0, y1] of `map` (rows known to hold some).
cv::Rect NonZeroBox(const cv::Mat1f& map, int y0, int y1) {
  int x0 = map.cols, x1 = -1;
  for (int y = y0; y <= y1; ++y) {
    const float* row = map.ptr<float>(y);
    for (int x = 0; x < x0; ++x) {
      if (row[x] != 0) {
        x0 = x;
        break;
      }
    }
    for (int x = map.cols - 1; x > x1; --x) {
      if (row[x] != 0) {
        x1 = x;
        break;
      }
    }
  }
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

TemplateBoxes LargestBoxes(const std::vector<FastFge::SliceWork>& work) {
  TemplateBoxes largest;
  for (const FastFge::SliceWork& w : work) {
    largest.contact_half_len = std::max(largest.contact_half_len, w.boxes.contact_half_len);
    largest.finger_outer = std::max(largest.finger_outer, w.boxes.finger_outer);
    largest.half_width = std::max(largest.half_width, w.boxes.half_width);
  }
  return largest;
}

// Axis-aligned boxes (canvas pixels) of the objects' crop boxes turned into the canvas: the
// corners (pixel edges) are transformed and the result is rounded outwards.
std::vector<cv::Rect> RotatedBoxes(const std::vector<FastFge::Object>& objects,
                                   const cv::Matx23d& t) {
  std::vector<cv::Rect> boxes;
  for (const FastFge::Object& o : objects) {
    const cv::Rect& r = o.crop_box;
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const cv::Point2d corner :
         {cv::Point2d(r.x - 0.5, r.y - 0.5), cv::Point2d(r.x + r.width - 0.5, r.y - 0.5),
          cv::Point2d(r.x - 0.5, r.y + r.height - 0.5),
          cv::Point2d(r.x + r.width - 0.5, r.y + r.height - 0.5)}) {
      const double x = t(0, 0) * corner.x + t(0, 1) * corner.y + t(0, 2);
      const double y = t(1, 0) * corner.x + t(1, 1) * corner.y + t(1, 2);
      x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
    }
    boxes.emplace_back(
        cv::Point(static_cast<int>(std::floor(x0)), static_cast<int>(std::floor(y0))),
        cv::Point(static_cast<int>(std::ceil(x1)) + 1, static_cast<int>(std::ceil(y1)) + 1));
  }
  return boxes;
}

// Candidate centres whose box sums stay inside a canvas of `size`.
cv::Rect SafeRect(cv::Size size, const TemplateBoxes& largest) {
  const int mx = largest.finger_outer + 1, my = largest.half_width + 1;
  return {mx, my, size.width - 2 * mx, size.height - 2 * my};
}

// Connected graspable regions of `contact` (crop level words) above `level`.
std::vector<FastFge::Object> FindObjects(const cv::Mat1w& levels, int level) {
  cv::Mat1b mask(levels.size());
  for (int y = 0; y < levels.rows; ++y) {
    const std::uint16_t* l = levels.ptr<std::uint16_t>(y);
    std::uint8_t* m = mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < levels.cols; ++x)
      m[x] = (l[x] & kLowByte) > kGraspableBit + level ? 255 : 0;
  }
  cv::Mat1i labels, stats;
  cv::Mat1d centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<FastFge::Object> objects(static_cast<std::size_t>(std::max(0, n - 1)));
  for (int i = 1; i < n; ++i) {
    objects[static_cast<std::size_t>(i - 1)].crop_box =
        cv::Rect(stats(i, cv::CC_STAT_LEFT), stats(i, cv::CC_STAT_TOP), stats(i, cv::CC_STAT_WIDTH),
                 stats(i, cv::CC_STAT_HEIGHT));
  }
  for (int y = 0; y < levels.rows; ++y) {
    const std::uint16_t* l = levels.ptr<std::uint16_t>(y);
    const int* lab = labels.ptr<int>(y);
    for (int x = 0; x < levels.cols; ++x) {
      if (lab[x] == 0) continue;
      int& top = objects[static_cast<std::size_t>(lab[x] - 1)].max_contact_level;
      top = std::max(top, (l[x] & kLowByte) - kGraspableBit);
    }
  }
  return objects;
}

// Whether any surface (or the outside of the image) in the level words is not graspable.
bool HasUngraspableSurface(const cv::Mat1w& levels) {
  for (int y = 0; y < levels.rows; ++y) {
    const std::uint16_t* l = levels.ptr<std::uint16_t>(y);
    for (int x = 0; x < levels.cols; ++x) {
      if ((l[x] & kLevelMask) > 0 && !(l[x] & kGraspableBit)) return true;
    }
  }
  return false;
}

}  // namespace

FastFge::FastFge(const Scene& scene, const Camera& camera, const Gripper& gripper,
                 const FgeParams& params, std::vector<Slice> slices, const cv::Mat1b& graspable)
    : image_size_(scene.height_m.size()),
      slices_(std::move(slices)),
      ws_(std::make_unique<Workspace>()) {
  if (slices_.empty() || scene.height_m.empty()) return;
  scale_ = WorkScale(scene.floor, camera, gripper);
  const std::vector<float> levels = CollectLevels(slices_);
  for (const Slice& s : slices_) {
    const double px_per_m = PxPerMetre(scene.floor, camera, s.contact_height_m) / scale_;
    const GripperPx g = GripperAtScale(gripper, px_per_m);
    SliceWork w;
    w.boxes = RasteriseTemplates(g);
    w.min_contact_px = MinContactCount(w.boxes.ContactArea());
    w.blur_sigma_px = BlurSigmaPx(g);
    w.blur_downscale = BlurDownscale(w.blur_sigma_px);
    w.contact_level = LevelIndex(levels, s.contact_height_m);
    w.tip_level = LevelIndex(levels, s.tip_height_m);
    w.palm_level = LevelIndex(levels, s.palm_height_m);
    margin_px_ = std::max(margin_px_, ReachPx(w.boxes));
    work_.push_back(w);
  }
  min_contact_level_ = work_.back().contact_level;  // slices descend: the last is the lowest

  const cv::Mat1f height = ConservativePool(scene.height_m, scale_);
  work_size_ = height.size();
  const cv::Mat1b graspable_work = PoolMax<std::uint8_t>(graspable, scale_, 0, 0);
  // The crop below lies within a template's reach of the lowest I_t, which is graspable: the
  // levels are only needed within that reach of the graspable pixels (a target's mask is
  // usually a small part of the image).
  const cv::Rect whole(cv::Point(0, 0), work_size_);
  const cv::Rect g = graspable_work.empty() ? cv::Rect() : cv::boundingRect(graspable_work);
  if (g.empty()) return;
  const cv::Rect near = cv::Rect(g.x - margin_px_, g.y - margin_px_, g.width + 2 * margin_px_,
                                 g.height + 2 * margin_px_) &
                        whole;
  cv::Mat1b work_levels = cv::Mat1b::zeros(work_size_);
  LevelImage(height(near), levels, graspable_work(near)).copyTo(work_levels(near));
  // Candidates need contact with I_t at some slice; obstacles farther than a template's reach
  // from every I_t pixel cannot change any candidate, so the crop follows the lowest I_t.
  cv::Mat1b lowest_contact;
  cv::threshold(work_levels, lowest_contact, kGraspableBit + min_contact_level_, 255,
                cv::THRESH_BINARY);
  const cv::Rect occupied = cv::boundingRect(lowest_contact);
  if (occupied.empty()) return;
  // The crop may reach past the image: there the gripper would be blind, so it is an obstacle.
  crop_ = cv::Rect(occupied.x - margin_px_, occupied.y - margin_px_,
                   occupied.width + 2 * margin_px_, occupied.height + 2 * margin_px_);
  // Seams only where the crop needs them: whole work pixels covering kSeamReachPx image pixels
  // more on every side give the crop the values of the whole image.
  const int pad_work = (kSeamReachPx + scale_ - 1) / scale_;
  const cv::Rect work_roi = cv::Rect(crop_.x - pad_work, crop_.y - pad_work,
                                     crop_.width + 2 * pad_work, crop_.height + 2 * pad_work) &
                            cv::Rect(cv::Point(0, 0), work_size_);
  const cv::Rect image_roi = cv::Rect(work_roi.x * scale_, work_roi.y * scale_,
                                      work_roi.width * scale_, work_roi.height * scale_) &
                             cv::Rect(cv::Point(0, 0), scene.height_m.size());
  const cv::Mat1b missing =
      scene.missing_mask.empty() ? scene.missing_mask : scene.missing_mask(image_roi);
  const cv::Mat1f seams =
      ConservativePool(SeamLevels(scene.height_m(image_roi), missing, params.seam_step_m), scale_);
  const cv::Mat1b seam_levels = CropWithBorder(LevelImage(seams, levels), crop_ - work_roi.tl(), 0);
  levels_ = PackLevels(CropWithBorder(work_levels, crop_, kOutsideLevel), seam_levels);

  double max_seam = 0;
  cv::minMaxLoc(seam_levels, nullptr, &max_seam);
  max_seam_level_ = static_cast<int>(max_seam);
  for (int y = 0; y < levels_.rows; ++y) {
    const std::uint16_t* l = levels_.ptr<std::uint16_t>(y);
    for (int x = 0; x < levels_.cols; ++x) {
      max_level_ = std::max(max_level_, l[x] & kLevelMask);
      if (l[x] & kGraspableBit) {
        max_contact_level_ = std::max(max_contact_level_, (l[x] & kLowByte) - kGraspableBit);
      }
    }
  }
  contact_is_obstacle_ = !HasUngraspableSurface(levels_);
  objects_ = FindObjects(levels_, min_contact_level_);
}

FastFge::~FastFge() = default;

FastFge::Canvas FastFge::MakeCanvas(double angle_rad, bool whole, Workspace& ws) const {
  const double c = std::cos(angle_rad);
  const double s = std::sin(angle_rad);
  const double w = crop_.width;
  const double h = crop_.height;
  const int m = margin_px_;
  const cv::Size size(static_cast<int>(std::ceil(w * std::abs(c) + h * std::abs(s))) + 2 * m,
                      static_cast<int>(std::ceil(w * std::abs(s) + h * std::abs(c))) + 2 * m);
  const cv::Point2d p((w - 1) / 2, (h - 1) / 2);                         // crop centre
  const cv::Point2d q((size.width - 1) / 2.0, (size.height - 1) / 2.0);  // canvas centre
  // canvas = R(-angle) (crop - p) + q: the closing axis becomes +x.
  const cv::Matx23d canvas_from_crop(c, s, q.x - c * p.x - s * p.y, -s, c, q.y + s * p.x - c * p.y);
  std::vector<cv::Rect> objects = RotatedBoxes(objects_, canvas_from_crop);
  // Only the objects' neighbourhood is read: grow their union by the reach of the box sums (the
  // same on both axes, so that the 90-degree turn of this canvas is valid as well).
  cv::Rect region(cv::Point(0, 0), size);
  const TemplateBoxes largest = LargestBoxes(work_);
  if (!whole && !objects.empty()) {
    const int reach =
        std::max(largest.contact_half_len + largest.finger_outer + 1, 2 * largest.half_width + 1);
    cv::Rect all = objects.front();
    for (const cv::Rect& r : objects) all |= r;
    region = cv::Rect(all.x - reach, all.y - reach, all.width + 2 * reach, all.height + 2 * reach);
  }
  Canvas canvas;
  canvas.canvas_from_crop = canvas_from_crop;
  canvas.canvas_from_crop(0, 2) -= region.x;
  canvas.canvas_from_crop(1, 2) -= region.y;
  canvas.crop_from_canvas = cv::Matx23d(c, -s, 0, s, c, 0);
  const cv::Point2d origin(region.x - q.x, region.y - q.y);  // canvas pixel (0, 0) minus q
  canvas.crop_from_canvas(0, 2) = p.x + c * origin.x - s * origin.y;
  canvas.crop_from_canvas(1, 2) = p.y + s * origin.x + c * origin.y;
  canvas.levels = View(ws.levels, region.size());
  cv::warpAffine(levels_, canvas.levels, canvas.canvas_from_crop, region.size(), cv::INTER_NEAREST,
                 cv::BORDER_CONSTANT, 0);
  for (cv::Rect& r : objects) r -= region.tl();
  canvas.objects = std::move(objects);
  canvas.safe = SafeRect(region.size(), largest);
  return canvas;
}

FastFge::Canvas FastFge::TurnedCanvas(const Canvas& canvas) const {
  // turned(x, y) = canvas(W - 1 - y, x): the canvas axis +y (angle + pi/2) becomes +x.
  const double w1 = canvas.levels.cols - 1;
  Canvas turned;
  turned.levels = View(ws_->turned_levels, cv::Size(canvas.levels.rows, canvas.levels.cols));
  cv::rotate(canvas.levels, turned.levels, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Matx33d turn(0, 1, 0, -1, 0, w1, 0, 0, 1);    // turned from canvas
  const cv::Matx33d unturn(0, -1, w1, 1, 0, 0, 0, 0, 1);  // canvas from turned
  const cv::Matx33d from_crop(canvas.canvas_from_crop(0, 0), canvas.canvas_from_crop(0, 1),
                              canvas.canvas_from_crop(0, 2), canvas.canvas_from_crop(1, 0),
                              canvas.canvas_from_crop(1, 1), canvas.canvas_from_crop(1, 2), 0, 0,
                              1);
  const cv::Matx33d to_crop(canvas.crop_from_canvas(0, 0), canvas.crop_from_canvas(0, 1),
                            canvas.crop_from_canvas(0, 2), canvas.crop_from_canvas(1, 0),
                            canvas.crop_from_canvas(1, 1), canvas.crop_from_canvas(1, 2), 0, 0, 1);
  turned.canvas_from_crop = (turn * from_crop).get_minor<2, 3>(0, 0);
  turned.crop_from_canvas = (to_crop * unturn).get_minor<2, 3>(0, 0);
  turned.safe = SafeRect(turned.levels.size(), LargestBoxes(work_));
  for (const cv::Rect& r : canvas.objects) {
    turned.objects.emplace_back(r.y, static_cast<int>(w1) + 1 - r.x - r.width, r.height, r.width);
  }
  return turned;
}

cv::Point2d FastFge::ToImage(const Canvas& canvas, cv::Point2d q) const {
  const cv::Matx23d& t = canvas.crop_from_canvas;
  const double x = t(0, 0) * q.x + t(0, 1) * q.y + t(0, 2) + crop_.x;
  const double y = t(1, 0) * q.x + t(1, 1) * q.y + t(1, 2) + crop_.y;
  const double offset = (scale_ - 1) / 2.0;  // centre of the work pixel's block
  return {x * scale_ + offset, y * scale_ + offset};
}

namespace {

struct LevelLimits {
  int max_level;       // highest obstacle level (palm checks above it are skipped)
  int max_seam_level;  // highest seam level
  bool contact_is_obstacle;
};

SliceIntegrals IntegralsFor(const FastFge::SliceWork& w, IntegralCache& cache, cv::Point origin,
                            const LevelLimits& limits) {
  SliceIntegrals in;
  in.origin = origin;
  in.contact = limits.contact_is_obstacle ? cache.ObstaclesAbove(w.contact_level)
                                          : cache.ContactAbove(w.contact_level);
  in.tip = cache.ObstaclesAbove(w.tip_level);
  if (w.palm_level < limits.max_level) in.palm = cache.ObstaclesAbove(w.palm_level);
  if (w.tip_level < limits.max_seam_level) in.seam = cache.SeamsAbove(w.tip_level);
  return in;
}

// The candidate map blurred on cells of d x d pixels: `small` holds the cells' area averages of
// the candidate map (> 0 where a cell holds a candidate), `blurred` their Gaussian blur.
void BlurSmall(const cv::Mat1f& candidate, double sigma_px, int d, FastFge::Workspace& ws,
               cv::Mat1f& small, cv::Mat1f& blurred) {
  small = View(ws.small, candidate.size() / d);
  cv::resize(candidate, small, small.size(), 0, 0, cv::INTER_AREA);
  blurred = View(ws.blurred, small.size());
  const double sigma_small = sigma_px / d;
  const int k = GaussianKernelSize(sigma_small);
  // BORDER_ISOLATED: the views lie in reused buffers; never read the pixels around them.
  cv::GaussianBlur(small, blurred, cv::Size(k, k), sigma_small, sigma_small,
                   cv::BORDER_CONSTANT | cv::BORDER_ISOLATED);
}

// Vertex of the parabola through (-1, lo), (0, mid), (1, hi): offset in [-0.5, 0.5] and value.
std::pair<double, double> ParabolaPeak(double lo, double mid, double hi) {
  const double curvature = lo - 2 * mid + hi;
  if (!(curvature < 0)) return {0.0, mid};
  const double offset = std::clamp(0.5 * (lo - hi) / curvature, -0.5, 0.5);
  return {offset, mid - 0.25 * (lo - hi) * offset};
}

// Peaks of the graspability at cell resolution: cells holding a candidate whose blurred value is
// >= that of every neighbouring cell holding one. Each is refined with parabolas through its
// neighbours and moved to the nearest candidate pixel of its cell; its score is the parabolas'
// peak value. `offset` maps candidate-map pixels to canvas pixels.
void CellPeaks(const cv::Mat1f& candidate, const cv::Mat1f& small, const cv::Mat1f& blurred, int d,
               cv::Point offset, std::vector<CanvasPeak>& peaks) {
  const int rows = small.rows, cols = small.cols;
  auto value = [&](int r, int c) {  // blurred value where a candidate lies, else 0
    return small(r, c) > 0 ? blurred(r, c) : 0.0f;
  };
  auto clamped = [&](int r, int c) {
    return blurred(std::clamp(r, 0, rows - 1), std::clamp(c, 0, cols - 1));
  };
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if (!(small(r, c) > 0)) continue;
      const float g = blurred(r, c);
      bool peak = g > 0;
      for (int rr = std::max(0, r - 1); rr <= std::min(rows - 1, r + 1) && peak; ++rr) {
        for (int cc = std::max(0, c - 1); cc <= std::min(cols - 1, c + 1); ++cc) {
          if (value(rr, cc) > g) {
            peak = false;
            break;
          }
        }
      }
      if (!peak) continue;
      const auto [dx, vx] = ParabolaPeak(clamped(r, c - 1), g, clamped(r, c + 1));
      const auto [dy, vy] = ParabolaPeak(clamped(r - 1, c), g, clamped(r + 1, c));
      const double x = (c + 0.5 + dx) * d - 0.5, y = (r + 0.5 + dy) * d - 0.5;
      cv::Point best(-1, -1);
      double best_d2 = 1e18;
      for (int py = r * d; py < (r + 1) * d; ++py) {
        for (int px = c * d; px < (c + 1) * d; ++px) {
          const double d2 = (px - x) * (px - x) + (py - y) * (py - y);
          if (candidate(py, px) > 0 && d2 < best_d2) best = {px, py}, best_d2 = d2;
        }
      }
      const double score = std::clamp(vx + vy - g, 0.0, 1.0);
      peaks.push_back(
          {cv::Point2d(offset.x + best.x, offset.y + best.y), static_cast<float>(score)});
    }
  }
}

// The candidate map of one slice inside one cluster and its blur: `box` (cluster pixels) bounds
// the candidates; `candidates` holds them from the box's top-left (padded with zeros to whole
// blur cells), `small`/`blurred` are the cell blur of that.
struct BlurredCandidates {
  cv::Rect box;
  cv::Mat1f candidates, small, blurred;
};

// Candidates of one slice inside one cluster (canvas pixels), box sums on the rois inside it and
// zeros elsewhere, then blurred on the candidates' bounding box only. False when there is none.
bool BlurCandidatesInCluster(const SliceIntegrals& in, const FastFge::SliceWork& w,
                             const cv::Rect& cluster, const std::vector<cv::Rect>& rois,
                             FastFge::Workspace& ws, BlurredCandidates& out) {
  cv::Mat1f candidate = View(ws.candidate, cluster.size());
  candidate.setTo(0);
  int first_row = cluster.height, last_row = -1;
  for (const cv::Rect& roi : rois) {
    if ((roi & cluster) != roi) continue;  // another cluster's
    for (int y = 0; y < roi.height; ++y) {
      const int row = roi.y - cluster.y + y;
      float* dst = candidate.ptr<float>(row) + (roi.x - cluster.x);
      if (CandidateRow(in, w, roi.y + y, roi.x, roi.width, ws, dst) > 0) {
        first_row = std::min(first_row, row);
        last_row = std::max(last_row, row);
      }
    }
  }
  if (last_row < 0) return false;
  // Sides divisible by the cell size.
  out.box = NonZeroBox(candidate, first_row, last_row);
  const cv::Rect padded = RoundUp(out.box, w.blur_downscale);
  out.candidates = View(ws.grasp, padded.size());
  out.candidates.setTo(0);
  candidate(out.box).copyTo(out.candidates(cv::Rect(cv::Point(0, 0), out.box.size())));
  BlurSmall(out.candidates, w.blur_sigma_px, w.blur_downscale, ws, out.small, out.blurred);
  return true;
}

// Candidates, graspability and peaks of one slice inside one cluster (canvas pixels).
void PeaksInCluster(const SliceIntegrals& in, const FastFge::SliceWork& w, const cv::Rect& cluster,
                    const std::vector<cv::Rect>& rois, FastFge::Workspace& ws,
                    std::vector<CanvasPeak>& peaks) {
  BlurredCandidates b;
  if (!BlurCandidatesInCluster(in, w, cluster, rois, ws, b)) return;
  CellPeaks(b.candidates, b.small, b.blurred, w.blur_downscale, cluster.tl() + b.box.tl(), peaks);
}

int BlurRadius(const FastFge::SliceWork& w) {
  const int d = w.blur_downscale;
  return d * (GaussianKernelSize(w.blur_sigma_px / d) / 2 + 1);
}

int MaxBlurRadius(const std::vector<FastFge::SliceWork>& work) {
  int radius = 0;
  for (const FastFge::SliceWork& w : work) radius = std::max(radius, BlurRadius(w));
  return radius;
}

// Every slice's clusters (RegionsOfSlice) lie inside one of these groups.
std::vector<cv::Rect> ObjectGroups(const FastFge::Canvas& canvas, const TemplateBoxes& largest,
                                   int blur_radius) {
  std::vector<cv::Rect> grown;
  const int a = largest.contact_half_len, b = largest.half_width;
  for (const cv::Rect& r : canvas.objects) {
    const cv::Rect roi =
        cv::Rect(r.x - a, r.y - b, r.width + 2 * a, r.height + 2 * b) & canvas.safe;
    if (!roi.empty()) grown.push_back(roi);
  }
  return MergeRects(std::move(grown), blur_radius);
}

// Objects whose neighbourhoods (largest template, largest blur radius) are close form one
// group; each group has its own integral images, over the group grown by the box sums' reach.
// The caches share `next_slot` (they keep a reference to it: it must outlive them).
std::vector<IntegralCache> GroupCaches(const FastFge::Canvas& canvas,
                                       const std::vector<FastFge::SliceWork>& work,
                                       FastFge::Workspace& ws, std::size_t& next_slot) {
  const TemplateBoxes largest = LargestBoxes(work);
  std::vector<IntegralCache> caches;
  for (const cv::Rect& group : ObjectGroups(canvas, largest, MaxBlurRadius(work))) {
    const int reach_x = largest.finger_outer + 1, reach_y = largest.half_width + 1;
    const cv::Rect region = cv::Rect(group.x - reach_x, group.y - reach_y,
                                     group.width + 2 * reach_x, group.height + 2 * reach_y) &
                            cv::Rect(cv::Point(0, 0), canvas.levels.size());
    caches.emplace_back(canvas, region, ws, next_slot);
  }
  return caches;
}

IntegralCache& CacheHolding(std::vector<IntegralCache>& caches, const cv::Rect& cluster) {
  for (IntegralCache& cache : caches) {
    if ((cache.region() & cluster) == cluster) return cache;
  }
  CV_Error(cv::Error::StsInternal, "FGE: a slice cluster outside every object group");
}

}  // namespace

std::vector<std::vector<LocalMaximum>> FastFge::LocalMaxima(double angle_rad) {
  std::vector<std::vector<LocalMaximum>> result(slices_.size());
  if (crop_.empty()) return result;
  const bool turn = last_canvas_ && std::abs(angle_rad - last_angle_rad_ - kHalfPi) < 1e-9;
  const Canvas canvas = turn ? TurnedCanvas(*last_canvas_) : MakeCanvas(angle_rad, false, *ws_);
  if (turn) {
    last_canvas_.reset();
  } else {
    last_canvas_ = std::make_unique<Canvas>(canvas);
    last_angle_rad_ = angle_rad;
  }
  std::size_t next_slot = 0;
  std::vector<IntegralCache> caches = GroupCaches(canvas, work_, *ws_, next_slot);
  const LevelLimits limits{max_level_, max_seam_level_, contact_is_obstacle_};
  std::vector<CanvasPeak> peaks;
  for (std::size_t i = 0; i < slices_.size(); ++i) {
    const SliceWork& w = work_[i];
    if (w.contact_level >= max_contact_level_) continue;  // nothing above the contact height
    const SliceRegions regions = RegionsOfSlice(canvas, objects_, w);
    peaks.clear();
    for (const cv::Rect& cluster : regions.clusters) {
      IntegralCache& cache = CacheHolding(caches, cluster);
      const SliceIntegrals in = IntegralsFor(w, cache, cache.region().tl(), limits);
      PeaksInCluster(in, w, cluster, regions.rois, *ws_, peaks);
    }
    for (const CanvasPeak& peak : peaks) {
      const cv::Point2d p = ToImage(canvas, peak.canvas_px);
      result[i].push_back({p.x, p.y, peak.score});
    }
  }
  return result;
}

namespace {

struct CanvasCandidate {
  cv::Point canvas_px;
  float graspability;
  cv::Vec2d sums;
};

// `out` (size of `rect`) = `crop_map` at the crop pixels nearest to the canvas pixels of `rect`
// (zeros outside the crop).
void RotateNearest(const cv::Mat2f& crop_map, const cv::Matx23d& crop_from_canvas,
                   const cv::Rect& rect, cv::Mat2f& out) {
  const cv::Matx23d& t = crop_from_canvas;
  const cv::Vec2f zero(0, 0);
  for (int y = 0; y < rect.height; ++y) {
    const double cy = rect.y + y;
    double sx = t(0, 0) * rect.x + t(0, 1) * cy + t(0, 2);
    double sy = t(1, 0) * rect.x + t(1, 1) * cy + t(1, 2);
    cv::Vec2f* dst = out.ptr<cv::Vec2f>(y);
    for (int x = 0; x < rect.width; ++x, sx += t(0, 0), sy += t(1, 0)) {
      const int ix = static_cast<int>(std::floor(sx + 0.5));
      const int iy = static_cast<int>(std::floor(sy + 0.5));
      const bool inside = ix >= 0 && iy >= 0 && ix < crop_map.cols && iy < crop_map.rows;
      dst[x] = inside ? crop_map(iy, ix) : zero;
    }
  }
}

// Bilinear read of `cells` (a blurred map on cells of d x d pixels) at pixel (x, y).
float CellValue(const cv::Mat1f& cells, int d, int x, int y) {
  const double fx = std::clamp((x + 0.5) / d - 0.5, 0.0, cells.cols - 1.0);
  const double fy = std::clamp((y + 0.5) / d - 0.5, 0.0, cells.rows - 1.0);
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  const int x1 = std::min(x0 + 1, cells.cols - 1), y1 = std::min(y0 + 1, cells.rows - 1);
  const double ax = fx - x0, ay = fy - y0;
  const double top = (1 - ax) * cells(y0, x0) + ax * cells(y0, x1);
  const double bottom = (1 - ax) * cells(y1, x0) + ax * cells(y1, x1);
  return static_cast<float>((1 - ay) * top + ay * bottom);
}

// Candidates of one slice inside one cluster (canvas pixels) on the grid of `step` canvas pixels,
// with their graspability (the candidate map's blur, as in Maps but read bilinearly from the
// cells) and the box sums of `crop_map` (crop pixels, may be empty) over their closing regions.
void CandidatesInCluster(const SliceIntegrals& in, const FastFge::SliceWork& w,
                         const cv::Rect& cluster, const std::vector<cv::Rect>& rois,
                         const cv::Mat2f& crop_map, const cv::Matx23d& crop_from_canvas, int step,
                         FastFge::Workspace& ws, std::vector<CanvasCandidate>& out) {
  BlurredCandidates blurred;
  if (!BlurCandidatesInCluster(in, w, cluster, rois, ws, blurred)) return;
  const cv::Rect& box = blurred.box;
  // Candidates lie in the canvas' safe rect: their closing regions stay inside the canvas.
  const int a = w.boxes.contact_half_len, b = w.boxes.half_width;
  const cv::Point box_tl = cluster.tl() + box.tl();
  cv::Mat2d sums;
  if (!crop_map.empty()) {
    const cv::Rect reach(box_tl.x - a, box_tl.y - b, box.width + 2 * a, box.height + 2 * b);
    cv::Mat2f map = View(ws.region_map, reach.size());
    RotateNearest(crop_map, crop_from_canvas, reach, map);
    sums = View(ws.region_sums, reach.size() + cv::Size(1, 1));
    cv::integral(map, sums, CV_64F);
  }
  const int w_box = 2 * a + 1, h_box = 2 * b + 1;
  for (int y = 0; y < box.height; ++y) {
    if ((box_tl.y + y) % step != 0) continue;
    const float* c = blurred.candidates.ptr<float>(y);
    for (int x = 0; x < box.width; ++x) {
      if (!(c[x] > 0) || (box_tl.x + x) % step != 0) continue;
      cv::Vec2d s(0, 0);
      if (!sums.empty()) {  // the integral's (x, y) is the closing region's top-left corner
        s = sums(y + h_box, x + w_box) - sums(y, x + w_box) - sums(y + h_box, x) + sums(y, x);
      }
      const float g = std::clamp(CellValue(blurred.blurred, w.blur_downscale, x, y), 0.0f, 1.0f);
      out.push_back({box_tl + cv::Point(x, y), g, s});
    }
  }
}

}  // namespace

cv::Mat2f FastFge::PoolSums(const cv::Mat1f& values, const cv::Mat1b& mask) const {
  cv::Mat2f out = cv::Mat2f::zeros(crop_.size());
  if (crop_.empty()) return out;
  CV_Assert(values.size() == image_size_ && mask.size() == image_size_);
  const int u0 = std::max(0, crop_.x * scale_);
  const int u1 = std::min(values.cols, (crop_.x + crop_.width) * scale_);
  for (int v = 0; v < values.rows; ++v) {
    const int y = v / scale_ - crop_.y;
    if (y < 0 || y >= crop_.height) continue;
    const float* value = values.ptr<float>(v);
    const std::uint8_t* set = mask.ptr<std::uint8_t>(v);
    cv::Vec2f* dst = out.ptr<cv::Vec2f>(y);
    for (int u = u0; u < u1; ++u) {
      if (!set[u]) continue;
      cv::Vec2f& d = dst[u / scale_ - crop_.x];
      d[0] += value[u] >= 0.0f ? std::min(value[u], 1.0f) : 0.0f;  // NaN fails the test
      d[1] += 1.0f;
    }
  }
  return out;
}

std::vector<std::vector<std::vector<FastFge::RegionCandidate>>> FastFge::CandidatesAtAngles(
    const std::vector<double>& angles_rad, const std::vector<cv::Mat2f>& pooled, int grid_step) {
  last_canvas_.reset();  // LocalMaxima's pending turn: its buffer is not read any more
  std::vector<std::vector<std::vector<RegionCandidate>>> result(angles_rad.size());
  const int n = static_cast<int>(angles_rad.size());
  const int stripes = std::max(1, std::min(n, cv::getNumThreads()));
  // One workspace per stripe: each angle only writes its own buffers and result entry.
  cv::parallel_for_(
      cv::Range(0, n),
      [&](const cv::Range& range) {
        Workspace own;
        for (int i = range.start; i < range.end; ++i) {
          const auto k = static_cast<std::size_t>(i);
          result[k] = CandidatesWith(angles_rad[k], pooled, grid_step, own);
        }
      },
      stripes);
  return result;
}

std::vector<std::vector<FastFge::RegionCandidate>> FastFge::CandidatesWith(
    double angle_rad, const std::vector<cv::Mat2f>& pooled, int grid_step, Workspace& ws) const {
  std::vector<std::vector<RegionCandidate>> result(slices_.size());
  if (crop_.empty()) return result;
  CV_Assert(grid_step >= 1);
  const Canvas canvas = MakeCanvas(angle_rad, false, ws);
  std::size_t next_slot = 0;
  std::vector<IntegralCache> caches = GroupCaches(canvas, work_, ws, next_slot);
  const LevelLimits limits{max_level_, max_seam_level_, contact_is_obstacle_};
  std::vector<CanvasCandidate> found;
  for (std::size_t i = 0; i < slices_.size(); ++i) {
    const SliceWork& w = work_[i];
    if (w.contact_level >= max_contact_level_) continue;  // nothing above the contact height
    const SliceRegions regions = RegionsOfSlice(canvas, objects_, w);
    if (regions.clusters.empty()) continue;
    cv::Mat2f crop_map;
    if (i < pooled.size() && !pooled[i].empty()) {
      CV_Assert(pooled[i].size() == crop_.size());
      crop_map = pooled[i];
    }
    found.clear();
    for (const cv::Rect& cluster : regions.clusters) {
      IntegralCache& cache = CacheHolding(caches, cluster);
      const SliceIntegrals in = IntegralsFor(w, cache, cache.region().tl(), limits);
      CandidatesInCluster(in, w, cluster, regions.rois, crop_map, canvas.crop_from_canvas,
                          grid_step, ws, found);
    }
    result[i].reserve(found.size());
    for (const CanvasCandidate& c : found) {
      const cv::Point2d p = ToImage(canvas, cv::Point2d(c.canvas_px));
      result[i].push_back({p.x, p.y, c.graspability, c.sums});
    }
  }
  return result;
}

namespace {

// Canvas map -> image-size map: rotate back onto the crop, paste into the work image, upsample.
cv::Mat1f CanvasToImage(const cv::Mat1f& canvas_map, const cv::Matx23d& canvas_from_crop,
                        const cv::Rect& crop, cv::Size work_size, int scale, cv::Size image_size,
                        double value_scale) {
  cv::Mat1f crop_map;
  cv::warpAffine(canvas_map, crop_map, canvas_from_crop, crop.size(),
                 cv::INTER_NEAREST | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT, 0);
  cv::Mat1f work = cv::Mat1f::zeros(work_size);
  const cv::Rect inside = crop & cv::Rect(cv::Point(0, 0), work_size);
  crop_map(inside - crop.tl()).copyTo(work(inside));
  cv::Mat1f upsampled;
  cv::resize(work, upsampled, cv::Size(work_size.width * scale, work_size.height * scale), 0, 0,
             cv::INTER_NEAREST);
  cv::Mat1f image = upsampled(cv::Rect(cv::Point(0, 0), image_size)).clone();
  if (value_scale != 1.0) image *= value_scale;
  return image;
}

}  // namespace

FgeMaps FastFge::Maps(double angle_rad, std::size_t slice_pos) {
  FgeMaps maps{cv::Mat1f::zeros(image_size_), cv::Mat1f::zeros(image_size_),
               cv::Mat1f::zeros(image_size_)};
  if (crop_.empty() || slice_pos >= slices_.size()) return maps;
  const Canvas canvas = MakeCanvas(angle_rad, true, *ws_);
  const cv::Rect whole(cv::Point(0, 0), canvas.levels.size());
  std::size_t next_slot = 0;
  IntegralCache cache(canvas, whole, *ws_, next_slot);
  const SliceWork& w = work_[slice_pos];
  const SliceIntegrals in = IntegralsFor(
      w, cache, whole.tl(), LevelLimits{max_level_, max_seam_level_, contact_is_obstacle_});
  const cv::Rect roi = canvas.safe;
  cv::Mat1f contact = cv::Mat1f::zeros(whole.size()), collision = cv::Mat1f::zeros(whole.size());
  cv::Mat1f candidate = cv::Mat1f::zeros(RoundUp(roi, w.blur_downscale).size());
  for (int y = 0; y < roi.height; ++y) {
    CandidateRow(in, w, roi.y + y, roi.x, roi.width, *ws_, candidate.ptr<float>(y));
    for (int x = 0; x < roi.width; ++x) {
      const auto i = static_cast<std::size_t>(x);
      contact(roi.y + y, roi.x + x) = static_cast<float>(ws_->row_contact[i]);
      collision(roi.y + y, roi.x + x) = static_cast<float>(ws_->row_collision[i]);
    }
  }
  cv::Mat1f grasp(candidate.size());
  Graspability(candidate, w.blur_sigma_px, w.blur_downscale, *ws_, grasp);
  cv::Mat1f grasp_canvas = cv::Mat1f::zeros(whole.size());
  grasp(cv::Rect(cv::Point(0, 0), roi.size())).copyTo(grasp_canvas(roi));

  const double area_scale = static_cast<double>(scale_) * scale_;
  auto to_image = [&](const cv::Mat1f& m, double value_scale) {
    return CanvasToImage(m, canvas.canvas_from_crop, crop_, work_size_, scale_, image_size_,
                         value_scale);
  };
  maps.contact = to_image(contact, area_scale);
  maps.collision = to_image(collision, area_scale);
  maps.graspability = to_image(grasp_canvas, 1.0);
  return maps;
}

}  // namespace softgrasp::core::fge_detail
