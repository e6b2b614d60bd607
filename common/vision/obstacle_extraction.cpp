#include "vision/obstacle_extraction.hpp"

#include "vision/window_sad.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "config/errors.hpp"
#include "vision/simd_match.hpp"

namespace sg {

namespace {

// Of the offsets within +-span of `centre` (and inside [0, cols)), the one with the largest
// count(d); ties go to the one nearest `centre`, then to the smaller.
template <class Count>
int offsetWithMostMatches(int centre, int span, int cols, Count count) {
  int best = centre;
  long best_count = -1;
  for (int k = 0; k <= 2 * span; ++k) {
    const int d = centre + (k % 2 == 0 ? k / 2 : -(k + 1) / 2);  // centre, centre - 1, centre + 1, ...
    if (d < 0 || d >= cols) continue;
    const long n = count(d);
    if (n > best_count) {
      best = d;
      best_count = n;
    }
  }
  return best;
}

// Left pixel x matches the right row at some offset in [d0, d1]: every feature pixel of the
// window [x - half, x + half] (inside the row, at least the centre) has a right feature within tol.
// (Always inlined: a call per pixel costs more than the test in the face-growing loops.)
[[gnu::always_inline]] inline bool matchAt(const std::uint8_t* l, const std::uint8_t* r, int x, int d0, int d1,
                                           int tol, int half, int width) {
  const int a0 = l[x];
  if (a0 == 0) return false;
  const int k0 = std::max(-half, -x);
  const int k1 = std::min(half, width - 1 - x);
  for (int d = std::max(d0, 0); d <= d1 && d <= x; ++d) {
    // The centre first: at most offsets it already fails.
    const int b0 = r[x - d];
    if (b0 == 0 || std::abs(a0 - b0) > tol) continue;
    bool ok = true;
    for (int k = std::max(k0, d - x); k <= k1 && ok; ++k) {
      if (k == 0) continue;
      const int a = l[x + k];
      const int b = r[x + k - d];
      ok = a == 0 || (b != 0 && std::abs(a - b) <= tol);
    }
    if (ok) return true;
  }
  return false;
}

// matchAt without an early exit: every offset and window pixel is tested, so that the
// outcome is computed rather than branched on pixel by pixel (the same function).
inline bool matchAtEvery(const std::uint8_t* l, const std::uint8_t* r, int x, int d0, int d1, int tol, int half,
                         int width) {
  const int k0 = std::max(-half, -x);
  const int k1 = std::min(half, width - 1 - x);
  bool any = false;
  for (int d = std::max(d0, 0); d <= std::min(d1, x); ++d) {
    bool ok = true;
    for (int k = std::max(k0, d - x); k <= k1; ++k) {
      const int a = l[x + k];
      const int b = r[x + k - d];
      const bool present = a != 0;
      const bool good = (b != 0) & (std::abs(a - b) <= tol);
      ok &= (present & good) | (!present & (k != 0));
    }
    any |= ok;
  }
  return any;
}

// Number of ones in the 0/1 bytes p[0, n): eight bytes at a time (each byte of the product's
// top byte sums the eight, at most 8).
int countOnes(const std::uint8_t* p, int n) {
  int sum = 0, x = 0;
  for (; x + 8 <= n; x += 8) {
    std::uint64_t v;
    std::memcpy(&v, p + x, sizeof v);
    sum += static_cast<int>((v * 0x0101010101010101ull) >> 56);
  }
  for (; x < n; ++x) sum += p[x];
  return sum;
}

// The offset of what is behind (y, x) when nothing stands there: the ground line below the
// horizon, the background above; -1 when unknown.
int offsetBehind(const GroundProfile& ground, int y, int x) {
  float b = ground.background_offset;
  if (y >= ground.horizon_row && y < static_cast<int>(ground.offset_per_row.size()) &&
      std::isfinite(ground.offset_per_row[static_cast<std::size_t>(y)]))
    b = ground.offset_per_row[static_cast<std::size_t>(y)] + ground.offset_per_column * (x - ground.reference_column);
  return std::isfinite(b) ? static_cast<int>(std::lround(b)) : -1;
}

// Left feature pixel x pins an offset: its horizontal neighbours are features whose grey levels
// differ by more than the matching tolerance (along a horizontal edge they do not, and a match
// holds at any offset). The image's first and last columns have nothing to compare: they do not.
inline bool pinsOffset(const std::uint8_t* l, int x, int width, int tol) {
  if (x <= 0 || x >= width - 1 || l[x] == 0 || l[x - 1] == 0 || l[x + 1] == 0) return false;
  return std::abs(static_cast<int>(l[x + 1]) - static_cast<int>(l[x - 1])) > tol;
}

// Feature pixels (any label but none) of column x over rows y0..y1, clipped to the image.
int featuresInColumn(const cv::Mat& labels, int x, int y0, int y1) {
  int n = 0;
  for (int y = std::max(0, y0); y <= std::min(labels.rows - 1, y1); ++y)
    n += labels.ptr<std::uint8_t>(y)[x] != kLabelNone;
  return n;
}

// Feature pixels of column x over rows y0..y1 (clipped to the image) that pin an offset.
int pinningInColumn(const cv::Mat& left, const cv::Mat& labels, int x, int y0, int y1, int tol) {
  int n = 0;
  for (int y = std::max(0, y0); y <= std::min(labels.rows - 1, y1); ++y)
    n += labels.ptr<std::uint8_t>(y)[x] != kLabelNone && pinsOffset(left.ptr<std::uint8_t>(y), x, left.cols, tol);
  return n;
}

// Is `label` a ground or background feature (the removal's, step 4)?
bool groundOrBackground(std::uint8_t label) {
  static_assert(kLabelBackground == kLabelGround + 1, "ground and background labels are one range");
  return static_cast<std::uint8_t>(label - kLabelGround) <= 1u;
}

// Ground and background features in row y of `labels` (summed in byte lanes over blocks of 128
// columns, which the compiler vectorises).
int groundOrBackgroundInRow(const cv::Mat& labels, int y) {
  const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
  int n = 0, x = 0;
  for (; x + 128 <= labels.cols; x += 128) {
    std::uint8_t block = 0;
    for (int k = 0; k < 128; ++k) block = static_cast<std::uint8_t>(block + groundOrBackground(lab[x + k]));
    n += block;
  }
  for (; x < labels.cols; ++x) n += groundOrBackground(lab[x]);
  return n;
}

// Is `label` a pixel of another obstacle than the one labelled `own`, with its offset (from
// ObstacleExtractor::offsetsOfLabels) more than tol from d?
bool ofAnotherObstacle(const std::array<int, 256>& offset_of_label, std::uint8_t label, int own, int d, int tol) {
  if (label < kLabelFirstObstacle || label == own) return false;
  const int e = offset_of_label[label];
  return e >= 0 && std::abs(e - d) > tol;
}

// Widens `box` to columns x0..x1 (x0 <= its left column, x1 >= its right one); returns the
// number of columns added.
int widenBox(cv::Rect& box, int x0, int x1) {
  const int added = box.x - x0 + x1 - (box.x + box.width - 1);
  box.width = x1 - x0 + 1;
  box.x = x0;
  return added;
}

// A column is plain over rows y0..y1 when at most a quarter of them are features.
bool plainColumn(const cv::Mat& labels, int x, int y0, int y1) {
  return 4 * featuresInColumn(labels, x, y0, y1) <= y1 - y0 + 1;
}

// ... and plain of pinning features when at most a quarter of them are features that pin an offset
// (horizontal edges, a window band's or a panel's, match at every offset).
bool plainOfPinning(const cv::Mat& left, const cv::Mat& labels, int x, int y0, int y1, int tol) {
  return 4 * pinningInColumn(left, labels, x, y0, y1, tol) <= y1 - y0 + 1;
}

// Share of features beside a plain gap, over the same rows, above which the surroundings are textured.
constexpr double kPlainSurroundFraction = 0.2;

// A renumbering of label values: map[v] is what label v becomes.
using LabelMap = std::array<std::uint8_t, 256>;

LabelMap unchangedLabels() {
  LabelMap map{};
  for (int v = 0; v < 256; ++v) map[static_cast<std::size_t>(v)] = static_cast<std::uint8_t>(v);
  return map;
}

// Pixels of obstacle o in columns [x0, x1] of its box's rows (counted row by row: the rows are
// contiguous in memory).
int pixelsOf(const cv::Mat& labels, const ObstacleCluster& o, int x0, int x1) {
  int n = 0;
  for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
    const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    for (int x = x0; x <= x1; ++x) n += lab[x] == o.label ? 1 : 0;
  }
  return n;
}

// The left and right feature images and the label image: mono8, all of one size.
void requireMono8Pair(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels) {
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size() || labels.size() != left.size() ||
      labels.type() != CV_8UC1)
    throw InputError("obstacles: feature and label images must be mono8 of the same size");
}

// Maps every label inside `area` (the whole image by default).
void relabel(cv::Mat& labels, const LabelMap& map, cv::Rect area = cv::Rect(0, 0, INT_MAX, INT_MAX)) {
  area &= cv::Rect(0, 0, labels.cols, labels.rows);
  for (int y = area.y; y < area.y + area.height; ++y) {
    std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    for (int c = area.x; c < area.x + area.width; ++c) lab[c] = map[lab[c]];
  }
}

// Offset d lies at obstacle o's offsets, widened by the tolerance and one more pixel (a part of it).
bool atOffsetsOf(int d, const ObstacleCluster& o, int tol) {
  return d >= o.min_offset_px - tol - 1 && d <= o.max_offset_px + tol + 1;
}

double overlapOfSmaller(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double smaller = std::min(a.area(), b.area());
  return smaller > 0 ? inter / smaller : 0.0;
}

}  // namespace

void windowMatchRowReference(const std::uint8_t* left, const std::uint8_t* right, int width, int x0, int x1, int d0,
                             int d1, int grey_tolerance, int half, std::uint8_t* out) {
  for (int x = x0; x < x1; ++x)
    out[x] = matchAt(left, right, x, d0, d1, grey_tolerance, half, width) ? 1 : 0;
}

ObstacleExtractor::ObstacleExtractor(const ObstacleParams& params, bool fast) : params_(params), fast_(fast) {
  params_.validate();
}

void ObstacleExtractor::matchRow(const std::uint8_t* l, const std::uint8_t* r, int x0, int x1, int d0, int d1,
                                 std::uint8_t* out) {
  matchRow(l, r, x0, x1, d0, d1, params_.match_half_window_px, out);
}

void ObstacleExtractor::matchRow(const std::uint8_t* l, const std::uint8_t* r, int x0, int x1, int d0, int d1,
                                 int half, std::uint8_t* out) {
  if (fast_) {
    simd::windowMatchRow(l, r, cols_, x0, x1, d0, d1, params_.grey_tolerance, half, match_scratch_.data(), out);
  } else {
    windowMatchRowReference(l, r, cols_, x0, x1, d0, d1, params_.grey_tolerance, half, out);
  }
}

void ObstacleExtractor::matchRows(const cv::Mat& remaining, const cv::Mat& right, int y0, int y1, int x0, int x1,
                                  int d0, int d1, int half, std::uint8_t* out) {
  if (y1 <= y0) return;
  if (fast_) {
    simd::windowMatchRows(remaining.ptr<std::uint8_t>(y0), remaining.step[0], right.ptr<std::uint8_t>(y0),
                          right.step[0], cols_, y1 - y0, x0, x1, d0, d1, params_.grey_tolerance, half,
                          match_scratch_.data(), out + static_cast<std::size_t>(y0) * static_cast<std::size_t>(cols_),
                          static_cast<std::size_t>(cols_));
    return;
  }
  for (int y = y0; y < y1; ++y)
    matchRow(remaining.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x0, x1, d0, d1, half,
             out + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols_));
}

void ObstacleExtractor::firstMaskSpan(int& a, int& b) const {
  if (b - a >= kMaskChunk) return;
  // A narrow first request (cells, a block of columns): a chunk around it, vector-wide.
  a = std::max(0, std::min(a, (a + b - kMaskChunk) / 2));
  b = std::min(cols_, std::max(b, a + kMaskChunk));
}

void ObstacleExtractor::fillMaskRows(RowMasks& masks, const cv::Mat& remaining, const cv::Mat& right, int y0, int y1,
                                     int x0, int x1) {
  int a = x0, b = x1;
  firstMaskSpan(a, b);
  for (int y = y0; y <= y1;) {
    if (masks.hi[static_cast<std::size_t>(y)] > masks.lo[static_cast<std::size_t>(y)]) {
      ++y;
      continue;
    }
    int e = y + 1;
    while (e <= y1 && masks.hi[static_cast<std::size_t>(e)] <= masks.lo[static_cast<std::size_t>(e)]) ++e;
    matchRows(remaining, right, y, e, a, b, masks.d0, masks.d1, params_.match_half_window_px, masks.bits.data());
    for (int k = y; k < e; ++k) {
      masks.lo[static_cast<std::size_t>(k)] = a;
      masks.hi[static_cast<std::size_t>(k)] = b;
    }
    y = e;
  }
}

int ObstacleExtractor::ownOffset(const cv::Mat& remaining, const cv::Mat& right, const cv::Rect& box, int best) {
  // d* is the peak of whole rows, which everything on them shares; the cluster found there
  // matches at d* within the offset tolerance, and its own pixels may match best at a
  // neighbour of d*. Of the offsets within the tolerance, the one with the most matching
  // feature pixels inside the box (ties: the one nearest d*, then the smaller).
  return offsetWithMostMatches(best, params_.offset_tolerance_px, cols_, [&](int d) {
    // Each pixel on its own (the correlation's count, vectorised): chance matches spread
    // evenly over neighbouring offsets, the cluster's own offset stands out.
    long count = 0;
    const int x0 = std::max(box.x, d);
    for (int y = box.y; y < box.y + box.height && x0 < box.x + box.width; ++y)
      count += countRowMatches(remaining.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x0, box.x + box.width, d,
                               params_.grey_tolerance);
    return count;
  });
}

void ObstacleExtractor::resetMasks(RowMasks& masks, int d0, int d1) {
  masks.d0 = d0;
  masks.d1 = d1;
  masks.bits.resize(static_cast<std::size_t>(rows_) * static_cast<std::size_t>(cols_));
  masks.lo.assign(static_cast<std::size_t>(rows_), 0);
  masks.hi.assign(static_cast<std::size_t>(rows_), 0);
}

const std::uint8_t* ObstacleExtractor::fillMaskRow(RowMasks& masks, const cv::Mat& remaining, const cv::Mat& right,
                                                   int y, int x0, int x1) {
  std::uint8_t* row = masks.bits.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols_);
  int& lo = masks.lo[static_cast<std::size_t>(y)];
  int& hi = masks.hi[static_cast<std::size_t>(y)];
  // Grow the valid span to cover [x0, x1), by at least a chunk on each side that grows
  // (columns are often asked for one by one while a cluster's sides are searched). Only the
  // columns added are computed: a mask column does not depend on the span it is computed in.
  const std::uint8_t* l = remaining.ptr<std::uint8_t>(y);
  const std::uint8_t* r = right.ptr<std::uint8_t>(y);
  if (hi > lo) {
    if (x0 < lo) {
      const int a = std::max(0, std::min(x0, lo - kMaskChunk));
      matchRow(l, r, a, lo, masks.d0, masks.d1, row);
      lo = a;
    }
    if (x1 > hi) {
      const int b = std::min(cols_, std::max(x1, hi + kMaskChunk));
      matchRow(l, r, hi, b, masks.d0, masks.d1, row);
      hi = b;
    }
    return row;
  }
  int a = x0, b = x1;
  firstMaskSpan(a, b);
  matchRow(l, r, a, b, masks.d0, masks.d1, row);
  lo = a;
  hi = b;
  return row;
}

void ObstacleExtractor::prepareContactRows(const GroundProfile& ground, int rows, int offsets) {
  rows_ = rows;
  per_column_ = 0.0f;
  reference_column_ = 0.0f;
  ground_top_ = rows;
  ground_reach_.assign(static_cast<std::size_t>(rows), -std::numeric_limits<float>::infinity());
  row_limit_.assign(static_cast<std::size_t>(offsets), rows - 1);
  if (ground.source == GroundSource::kNone || static_cast<int>(ground.offset_per_row.size()) != rows) return;
  if (std::isfinite(ground.offset_per_column) && std::isfinite(ground.reference_column)) {
    per_column_ = ground.offset_per_column;
    reference_column_ = ground.reference_column;
  }
  // Running maximum of the ground offset from the horizon down: the first row whose ground
  // reaches an offset is then a binary search (the polyline need not be monotonic).
  ground_top_ = std::clamp(ground.horizon_row, 0, rows);
  float reach = -std::numeric_limits<float>::infinity();
  for (int y = ground_top_; y < rows; ++y) {
    const float g = ground.offset_per_row[static_cast<std::size_t>(y)];
    if (std::isfinite(g)) reach = std::max(reach, g);
    ground_reach_[static_cast<std::size_t>(y)] = reach;
  }
  // The offset histograms count whole rows: there the most permissive column decides (the
  // per-column limits below then keep the ground residue out of the clusters).
  const float spread = std::abs(per_column_) * static_cast<float>(std::max(reference_column_, 0.0f) + 1.0f);
  const float spread_right = std::abs(per_column_) * std::abs(static_cast<float>(cols_) - reference_column_);
  const float widest = std::max(spread, spread_right);
  for (int d = 0; d < offsets; ++d)
    row_limit_[static_cast<std::size_t>(d)] =
        firstRowReaching(static_cast<float>(d) + widest - static_cast<float>(params_.ground_clearance_px)) - 1;
}

int ObstacleExtractor::firstRowReaching(float offset) const {
  const auto begin = ground_reach_.begin() + ground_top_;
  const auto it = std::lower_bound(begin, ground_reach_.end(), offset);
  return static_cast<int>(it - ground_reach_.begin());
}

float ObstacleExtractor::groundRelative(int offset, int x) const {
  // An obstacle at `offset` in column x meets the ground where the ground offset at the
  // reference column equals offset minus the transversal change between the two columns.
  return static_cast<float>(offset) - per_column_ * (static_cast<float>(x) - reference_column_);
}

int ObstacleExtractor::rowLimitAt(int offset, int x) const {
  return std::min(rows_ - 1,
                  firstRowReaching(groundRelative(offset, x) - static_cast<float>(params_.ground_clearance_px)) - 1);
}

void ObstacleExtractor::rowLimitsAt(int offset, int* out) const {
  // rowLimitAt of every column. The query changes linearly along the row and ground_reach_ is
  // sorted, so each column's row is found by stepping from the previous column's (the same
  // row as the binary search); without a transversal slope every column has the first one.
  const float clearance = static_cast<float>(params_.ground_clearance_px);
  int i = firstRowReaching(groundRelative(offset, 0) - clearance);  // column 0's, as rowLimitAt
  if (per_column_ == 0.0f) {
    std::fill(out, out + cols_, std::min(rows_ - 1, i - 1));
    return;
  }
  const float* reach = ground_reach_.data();
  for (int x = 0; x < cols_; ++x) {
    const float v = groundRelative(offset, x) - clearance;
    while (i < rows_ && reach[i] < v) ++i;
    while (i > ground_top_ && reach[i - 1] >= v) --i;
    out[x] = std::min(rows_ - 1, i - 1);
  }
}

double ObstacleExtractor::contactTolerance(int height) const {
  return std::max(static_cast<double>(params_.contact_tolerance_px), params_.contact_tolerance_fraction * height);
}

int ObstacleExtractor::contactRowAt(int offset, int x) const { return firstRowReaching(groundRelative(offset, x) - 0.5f); }

int ObstacleExtractor::lowestContact(const cv::Rect& box, int offset) const {
  int contact = -1;
  for (int x = std::max(0, box.x); x < std::min(cols_, box.x + box.width); ++x)
    contact = std::max(contact, std::min(contactRowAt(offset, x), rows_ - 1));
  return contact;
}

int ObstacleExtractor::rowLimit(int offset) const { return row_limit_[static_cast<std::size_t>(offset)]; }

void ObstacleExtractor::offsetHistogram(const cv::Mat& matches, const GroundProfile& ground) {
  const int rows = matches.rows;
  const int offsets = matches.cols;
  const double background =
      std::isfinite(ground.background_offset) ? static_cast<double>(ground.background_offset) : -1e9;
  // Per offset: the last row its histogram counts, -1 when it is left out. The fast path
  // leaves out the banned offsets at the end, from sums it keeps over the iterations.
  hist_limit_.resize(static_cast<std::size_t>(offsets));
  for (int d = 0; d < offsets; ++d) {
    const bool skip =
        (!fast_ && banned_[static_cast<std::size_t>(d)]) || d <= background + params_.background_margin_px ||
        d < nearest_offset_;
    hist_limit_[static_cast<std::size_t>(d)] = skip ? -1 : rowLimit(d);
  }
  const int* lim = hist_limit_.data();
  const int min_excess = params_.min_row_excess;
  const int k = offsets / 2;
  for (int y = 0; y < rows; ++y) {
    // Only rows whose counts changed since the last histogram need a new median.
    if (!median_stale_[static_cast<std::size_t>(y)]) continue;
    median_stale_[static_cast<std::size_t>(y)] = 0;
    const int* m = matches.ptr<int>(y);
    if (fast_) {
      // Removals lower a few counts by a little: the median is the previous one or one of
      // the next values below it (a few vector passes), else it is selected. The row's
      // excess then replaces its previous one in the kept sums.
      constexpr int kMedianSteps = 16;
      int& median = row_median_[static_cast<std::size_t>(y)];
      if (!simd::kthSmallestFrom(m, offsets, k, median, kMedianSteps, median)) median = simd::kthSmallest(m, offsets, k);
      simd::replaceRowExcess(m, median, min_excess, y, lim, offsets,
                             row_excess_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(offsets),
                             hist_sum_.data());
      continue;
    }
    // Removals change a few counts by a little: the previous median usually still is the
    // (offsets / 2)-th smallest, which one counting pass shows.
    const int previous = row_median_[static_cast<std::size_t>(y)];
    int below = 0, at_most = 0;
    for (int d = 0; d < offsets; ++d) {
      below += m[d] < previous;
      at_most += m[d] <= previous;
    }
    if (below <= k && k < at_most) continue;
    row_values_.assign(m, m + offsets);
    const auto mid = row_values_.begin() + k;
    std::nth_element(row_values_.begin(), mid, row_values_.end());
    row_median_[static_cast<std::size_t>(y)] = *mid;
  }
  offset_hist_.assign(static_cast<std::size_t>(offsets), 0.0f);
  if (fast_) {
    for (int d = 0; d < offsets; ++d)
      if (!banned_[static_cast<std::size_t>(d)])
        offset_hist_[static_cast<std::size_t>(d)] = static_cast<float>(hist_sum_[static_cast<std::size_t>(d)]);
    return;
  }
  // Row by row, summed as integers: whole numbers.
  hist_sum_.assign(static_cast<std::size_t>(offsets), 0);
  int* sum = hist_sum_.data();
  for (int y = 0; y < rows; ++y) {
    const int* m = matches.ptr<int>(y);
    const int median = row_median_[static_cast<std::size_t>(y)];
    for (int d = 0; d < offsets; ++d) {
      const int excess = m[d] - median;
      if (excess >= min_excess && y <= lim[d]) sum[d] += excess;
    }
  }
  for (int d = 0; d < offsets; ++d) offset_hist_[static_cast<std::size_t>(d)] = static_cast<float>(sum[d]);
}

template <class Hist>
ObstacleExtractor::Extent ObstacleExtractor::extentOf(const Hist& hist, int lo, int hi, int peak_lo,
                                                      int peak_hi) const {
  Extent e;
  if (hi < lo) return e;
  const int r = params_.smooth_px;
  // Box-filtered bin i: the same additions in the same order wherever it is asked for.
  auto smooth = [&](int i) {
    float s = 0.0f;
    for (int k = std::max(lo, i - r); k <= std::min(hi, i + r); ++k) s += hist(k);
    return s;
  };
  // The fast path slides the window instead: the bins are whole numbers (match counts) whose
  // sums stay far below 2^24, so every float sum is exact in any order and the same.
  auto binOrZero = [&](int k) { return k >= lo && k <= hi ? hist(k) : 0.0f; };
  // Bin i from bin i - dir (dir = +1 or -1), whose smoothed value is `previous`.
  auto next = [&](float previous, int i, int dir) {
    return fast_ ? previous + binOrZero(i + dir * r) - binOrZero(i - dir * (r + 1)) : smooth(i);
  };
  peak_lo = std::max(peak_lo, lo);
  peak_hi = std::min(peak_hi, hi);
  if (peak_hi < peak_lo) return e;
  int peak = peak_lo;
  float top = smooth(peak_lo);
  float v = top;
  for (int i = peak_lo + 1; i <= peak_hi; ++i) {
    v = next(v, i, +1);
    if (v > top) {
      top = v;
      peak = i;
    }
  }
  if (top <= 0.0f) return e;
  const float thr = static_cast<float>(params_.extent_fraction) * top;
  // Walks outwards from the peak while no more than gap_px bins in a row fall short.
  auto walk = [&](int dir) {
    int end = peak, gap = 0;
    float w = top;
    for (int i = peak + dir; i >= lo && i <= hi; i += dir) {
      w = next(w, i, dir);
      if (w >= thr) {
        end = i;
        gap = 0;
      } else if (++gap > params_.gap_px) {
        break;
      }
    }
    return end;
  };
  int a = walk(-1);
  int b = walk(+1);
  // Smoothing widens the extent by up to smooth_px: shrink to the raw evidence.
  while (a < b && hist(a) <= 0.0f) ++a;
  while (b > a && hist(b) <= 0.0f) --b;
  e.lo = a;
  e.hi = b;
  return e;
}

ObstacleExtractor::Extent ObstacleExtractor::extent(const std::vector<float>& hist, int lo, int hi, int peak_lo,
                                                    int peak_hi) {
  return extentOf([&hist](int i) { return hist[static_cast<std::size_t>(i)]; }, lo, hi, peak_lo, peak_hi);
}

void ObstacleExtractor::compute(cv::Mat& remaining, const cv::Mat& right, const GroundProfile& ground,
                                Correlator& correlator, cv::Mat& score, cv::Mat& matches,
                                std::vector<std::uint8_t>& changed_rows, cv::Mat& labels,
                                std::vector<ObstacleCluster>& obstacles, double baseline_m, double focal_px) {
  requireMono8Pair(remaining, right, labels);
  const int rows = remaining.rows;
  const int cols = remaining.cols;
  const int offsets = correlator.params().offsets;
  const int tol = params_.offset_tolerance_px;
  const int half = params_.match_half_window_px;
  obstacles.clear();
  // Capacity for every obstacle a frame can hold (the steps after the loop append split parts).
  obstacles.reserve(static_cast<std::size_t>(std::max(0, params_.max_obstacles)));
  nearest_offset_ = params_.max_range_m > 0.0 && baseline_m > 0.0 && focal_px > 0.0
                        ? focal_px * baseline_m / params_.max_range_m
                        : 0.0;
  banned_.assign(static_cast<std::size_t>(offsets), 0);
  floating_.clear();
  floating_.reserve(static_cast<std::size_t>(std::max(0, params_.max_iterations)));
  row_median_.assign(static_cast<std::size_t>(rows), 0);
  median_stale_.assign(static_cast<std::size_t>(rows), 1);
  mask_stale_.assign(static_cast<std::size_t>(rows), 0);
  candidate_masks_kept_ = false;  // a new frame: none of the previous one's masks holds
  if (fast_) {  // every row is added to the offset histogram's sums afresh
    row_excess_.assign(static_cast<std::size_t>(rows) * static_cast<std::size_t>(offsets), 0);
    hist_sum_.assign(static_cast<std::size_t>(offsets), 0);
  }
  cols_ = cols;
  prepareContactRows(ground, rows, offsets);
  match_scratch_.resize(static_cast<std::size_t>(simd::windowMatchScratchSize(cols, std::max(half, params_.share_half_window_px))));
  sweep_row_.resize(static_cast<std::size_t>(cols));
  if (fast_) sweep_rows_.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
  offset_runs_.reserve(static_cast<std::size_t>(cols));  // a box sweep has at most a run per column
  col_count_.resize(static_cast<std::size_t>(cols));
  col_count_bytes_.resize(static_cast<std::size_t>(cols));
  if (params_.cell_px > 0) {
    const std::size_t cells = static_cast<std::size_t>((cols + params_.cell_px - 1) / params_.cell_px) *
                              static_cast<std::size_t>((rows + params_.cell_px - 1) / params_.cell_px);
    if (cell_.size() != cells) {  // a new image size; otherwise each candidate resets the cells it touched
      cell_.assign(cells, Cell{});
      touched_cells_.clear();
    }
  }
  const bool ground_known = ground.source != GroundSource::kNone;
  const double background =
      std::isfinite(ground.background_offset) ? static_cast<double>(ground.background_offset) : -1e9;
  if (static_cast<int>(changed_rows.size()) != rows) changed_rows.assign(static_cast<std::size_t>(rows), 1);

  // Removing a left pixel takes its matches out of the correlation counts: it matched
  // offset d when the right pixel x - d is a feature within the correlation's grey
  // tolerance. Counting down is exact and far cheaper than recomputing the row.
  // A row's cleared pixels are collected and counted out together: the fast path with the
  // correlation's vector kernel (right rows with its zero padding in front), the reference
  // pixel by pixel.
  const int corr_tol = correlator.params().grey_tolerance;
  const int pad = simd::rightPadding(offsets);
  if (fast_) {
    right_padded_.create(rows, pad + cols, CV_8UC1);  // kept between frames of one size
    for (int y = 0; y < rows; ++y) {
      std::uint8_t* rp = right_padded_.ptr<std::uint8_t>(y);
      std::memset(rp, 0, static_cast<std::size_t>(pad));
      std::memcpy(rp + pad, right.ptr<std::uint8_t>(y), static_cast<std::size_t>(cols));
    }
    removed_counts_.resize(static_cast<std::size_t>(offsets));
  }
  cleared_.assign(static_cast<std::size_t>(cols), 0);
  auto uncount = [&](int y, int x, int a) {
    int* m = matches.ptr<int>(y);
    const std::uint8_t* r = right.ptr<std::uint8_t>(y);
    const int dmax_row = std::min(offsets - 1, x);
    for (int d = 0; d <= dmax_row; ++d) {
      const int b = r[x - d];
      m[d] -= (b != 0) & (std::abs(a - b) <= corr_tol);
    }
  };
  auto uncountRow = [&](int y, int xa, int xb) {  // cleared_ holds the row's cleared pixels in [xa, xb)
    if (fast_) {
      std::fill(removed_counts_.begin(), removed_counts_.end(), 0);
      simd::accumulateMatches(cleared_.data(), nullptr, right_padded_.ptr<std::uint8_t>(y) + pad, xa, xb, offsets,
                              corr_tol, removed_counts_.data());
      int* m = matches.ptr<int>(y);
      const int* removed = removed_counts_.data();
      int d = 0;
      for (; d + 4 <= offsets; d += 4) {  // four counts at a time (SSE2, every x86-64)
        typedef int I32x4 __attribute__((vector_size(16)));
        I32x4 a, b;
        std::memcpy(&a, m + d, sizeof(a));
        std::memcpy(&b, removed + d, sizeof(b));
        a -= b;
        std::memcpy(m + d, &a, sizeof(a));
      }
      for (; d < offsets; ++d) m[d] -= removed[d];
    } else {
      for (int x = xa; x < xb; ++x)
        if (cleared_[static_cast<std::size_t>(x)]) uncount(y, x, cleared_[static_cast<std::size_t>(x)]);
    }
    std::fill(cleared_.begin() + xa, cleared_.begin() + xb, std::uint8_t{0});
  };
  // Matched pixels of the box, optionally cleared and labelled. At the candidate's offset
  // (+-tol) they come from its masks; with `per_column`, column x matches around
  // col_offset_[x] only (grown clusters: each column of a receding wall has its own offset).
  int best = 0;
  auto sweepBox = [&](const cv::Rect& box, int clear_label, bool per_column) {
    // Per column, counting (the matched share) takes each pixel on its own at the column's offset
    // +-(tol + share_offset_slack_px); clearing takes the window, one offset further.
    const int run_slack = clear_label < 0 ? tol + params_.share_offset_slack_px : tol + 1;
    const int run_half = clear_label < 0 ? params_.share_half_window_px : half;
    int count = 0;
    const int bx1 = box.x + box.width;
    // Runs of columns sharing an offset (the same on every row of the box).
    offset_runs_.clear();
    if (per_column) {
      for (int xa = box.x; xa < bx1;) {
        const int d = col_offset_[static_cast<std::size_t>(xa)];
        int xb = xa + 1;
        while (xb < bx1 && col_offset_[static_cast<std::size_t>(xb)] == d) ++xb;
        offset_runs_.push_back(OffsetRun{xa, xb, d});
        xa = xb;
      }
    }
    // Fast path: each run's matches over all the box's rows in one kernel call (a row's
    // matches depend on that row only, and it is cleared only after they are taken).
    if (per_column && fast_)
      for (const OffsetRun& run : offset_runs_)
        matchRows(remaining, right, box.y, box.y + box.height, run.x0,
                  std::min(cols, std::max(run.x1, run.x0 + simd::kLanes)), run.d - run_slack, run.d + run_slack,
                  run_half, sweep_rows_.data());
    for (int y = box.y; y < box.y + box.height; ++y) {
      std::uint8_t* l = remaining.ptr<std::uint8_t>(y);
      const std::uint8_t* r = right.ptr<std::uint8_t>(y);
      std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
      const std::uint8_t* mk = sweep_row_.data();
      if (!per_column) {
        mk = maskRow(candidate_masks_, remaining, right, y, box.x, bx1);
      } else if (fast_) {
        mk = sweep_rows_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      } else {
        for (const OffsetRun& run : offset_runs_) {
          // At least a vector wide: columns to the right of the run belong to runs not
          // computed yet, which overwrite them.
          matchRow(l, r, run.x0, std::min(cols, std::max(run.x1, run.x0 + simd::kLanes)), run.d - run_slack,
                   run.d + run_slack, run_half, sweep_row_.data());
        }
      }
      if (clear_label < 0) {  // counting only: the matches as they are (mk holds 0/1)
        count += countOnes(mk + box.x, box.width);
        continue;
      }
      bool changed = false;
      int first_cleared = -1;
      int last_cleared = std::numeric_limits<int>::min() / 2;
      for (int x = box.x; x < bx1; ++x) {
        // Pixels are cleared left to right, and a cleared pixel no longer spoils the windows
        // of the pixels after it: a miss within `half` of the last cleared pixel is matched
        // again on the row as it is now (a clearing never turns a match into a miss).
        bool matched = mk[x] != 0;
        if (!matched && x - last_cleared <= half && l[x] != 0) {
          const int c = per_column ? col_offset_[static_cast<std::size_t>(x)] : best;
          const int slack = per_column ? tol + 1 : tol;
          matched = fast_ ? matchAtEvery(l, r, x, c - slack, c + slack, params_.grey_tolerance, half, cols)
                          : matchAt(l, r, x, c - slack, c + slack, params_.grey_tolerance, half, cols);
        }
        if (!matched) {
          // Fast path: past the window of the last cleared pixel only matched pixels are
          // cleared, so runs of unmatched ones are stepped over eight mask bytes at a time.
          if (fast_ && x - last_cleared >= half) {
            int next = x + 1;
            std::uint64_t word = 0;
            while (next + 8 <= bx1 && (std::memcpy(&word, mk + next, sizeof(word)), word == 0)) next += 8;
            x = next - 1;
          }
          continue;
        }
        ++count;
        last_cleared = x;
        cleared_[static_cast<std::size_t>(x)] = l[x];
        if (first_cleared < 0) first_cleared = x;
        l[x] = 0;
        lab[x] = static_cast<std::uint8_t>(clear_label);
        changed = true;
      }
      if (changed) {
        uncountRow(y, first_cleared, last_cleared + 1);
        changed_rows[static_cast<std::size_t>(y)] = 1;
        median_stale_[static_cast<std::size_t>(y)] = 1;
        mask_stale_[static_cast<std::size_t>(y)] = 1;
      }
    }
    return count;
  };

  // Pending rows (features changed before this stage) are recomputed once; from then on the
  // counts follow the removals and `changed_rows` only collects the rows whose score is stale.
  correlator.computeRows(remaining, right, changed_rows, score, matches);
  std::fill(changed_rows.begin(), changed_rows.end(), std::uint8_t{0});

  // Person-sized clusters below the obstacle thresholds are sought when the rig's baseline sizes them.
  const bool weak_search = params_.weak_peak_matches > 0 && baseline_m > 0.0;
  for (int iteration = 0;
       iteration < params_.max_iterations && static_cast<int>(obstacles.size()) < params_.max_obstacles;
       ++iteration) {
    offsetHistogram(matches, ground);
    best = static_cast<int>(std::max_element(offset_hist_.begin(), offset_hist_.end()) - offset_hist_.begin());
    const float peak = offset_hist_[static_cast<std::size_t>(best)];
    const bool strong_peak = peak >= static_cast<float>(params_.min_peak_matches);
    if (!strong_peak && (!weak_search || peak < static_cast<float>(params_.weak_peak_matches))) break;
    const int limit = rowLimit(best);

    // Matched pixels at d* (+-tol), a row at a time on first use, kept for this candidate:
    // the histograms below need whole rows only where the offset shows, elsewhere the stripe.
    if (fast_ && candidate_masks_kept_ && candidate_masks_.d0 == best - tol && candidate_masks_.d1 == best + tol) {
      // The previous candidate's offset again: its masks still hold on every row no sweep has
      // changed since.
      for (int y = 0; y < rows; ++y)
        if (mask_stale_[static_cast<std::size_t>(y)])
          candidate_masks_.lo[static_cast<std::size_t>(y)] = candidate_masks_.hi[static_cast<std::size_t>(y)] = 0;
    } else {
      resetMasks(candidate_masks_, best - tol, best + tol);
    }
    std::fill(mask_stale_.begin(), mask_stale_.end(), std::uint8_t{0});
    candidate_masks_kept_ = true;
    auto maskAt = [&](int y, int x) -> int { return maskRow(candidate_masks_, remaining, right, y, x, x + 1)[x]; };
    // Per column, the rows above the ground of d* (on a transversal slope they differ).
    col_limit_.resize(static_cast<std::size_t>(cols));
    if (fast_) {
      rowLimitsAt(best, col_limit_.data());
    } else {
      for (int x = 0; x < cols; ++x) col_limit_[static_cast<std::size_t>(x)] = rowLimitAt(best, x);
    }
    const int stripe_floor = *std::min_element(col_limit_.begin(), col_limit_.end());
    auto inStripe = [&](int y, int x) { return y <= col_limit_[static_cast<std::size_t>(x)]; };
    // Matches inside the stripe (a match implies a left feature) counted per column over rows.
    // Columns xa..xb of it: col_hist_ there (elsewhere unchanged).
    auto columnHistogram = [&](int ya, int yb, bool showing_rows_only, int xa, int xb) {
      std::uint16_t* h = col_count_.data();
      std::fill(h + xa, h + xb + 1, std::uint16_t{0});
      // Fast path: rows every column shows are counted in bytes, taken into h every 255 rows.
      std::uint8_t* h8 = col_count_bytes_.data();
      const int n = xb - xa + 1;
      int in_bytes = 0;
      if (fast_) std::fill(h8 + xa, h8 + xb + 1, std::uint8_t{0});
      const int* lim = col_limit_.data();
      for (int y = ya; y <= yb; ++y) {
        if (showing_rows_only &&
            matches.ptr<int>(y)[best] - row_median_[static_cast<std::size_t>(y)] < params_.min_row_excess)
          continue;
        const std::uint8_t* mk = maskRow(candidate_masks_, remaining, right, y, xa, xb + 1);
        if (y <= stripe_floor && fast_) {  // every column shows this row
          simd::addBytesToBytes(mk + xa, h8 + xa, n);
          if (++in_bytes == 255) {
            simd::addBytes(h8 + xa, h + xa, n);
            std::fill(h8 + xa, h8 + xb + 1, std::uint8_t{0});
            in_bytes = 0;
          }
        } else if (y <= stripe_floor) {
          for (int x = xa; x <= xb; ++x) h[x] = static_cast<std::uint16_t>(h[x] + mk[x]);
        } else {
          for (int x = xa; x <= xb; ++x) h[x] = static_cast<std::uint16_t>(h[x] + (y <= lim[x] ? mk[x] : 0));
        }
      }
      if (in_bytes > 0) simd::addBytes(h8 + xa, h + xa, n);
      col_hist_.resize(static_cast<std::size_t>(cols));
      for (int x = xa; x <= xb; ++x) col_hist_[static_cast<std::size_t>(x)] = static_cast<float>(h[x]);
    };
    // Column histogram over the rows that show the offset.
    columnHistogram(0, limit, true, 0, cols - 1);
    Extent cx = extent(col_hist_, 0, cols - 1, 0, cols - 1);
    Extent cy;
    if (cx.hi >= cx.lo) {
      // Row histogram inside the stripe, then the columns again over those rows.
      row_hist_.assign(static_cast<std::size_t>(rows), 0.0f);
      const int* lim = col_limit_.data();
      for (int y = 0; y <= limit; ++y) {
        const std::uint8_t* mk = maskRow(candidate_masks_, remaining, right, y, cx.lo, cx.hi + 1);
        int sum = 0;
        if (y <= stripe_floor) {  // every column shows this row
          sum = countOnes(mk + cx.lo, cx.hi - cx.lo + 1);
        } else {
          for (int x = cx.lo; x <= cx.hi; ++x) sum += y <= lim[x] ? mk[x] : 0;
        }
        row_hist_[static_cast<std::size_t>(y)] = static_cast<float>(sum);
      }
      cy = extent(row_hist_, 0, limit, 0, limit);
      if (cy.hi >= cy.lo && !fast_) {
        columnHistogram(cy.lo, cy.hi, false, 0, cols - 1);
        cx = extent(col_hist_, 0, cols - 1, cx.lo, cx.hi);
      } else if (cy.hi >= cy.lo) {
        // The same columns over the rows cy.lo..cy.hi, summed only where the extent looks:
        // around the first borders and as far as its walk outwards goes, in blocks. Only the
        // columns done_lo..done_hi of col_hist_ are this candidate's (the cluster's columns
        // lie among them).
        int done_lo = cols, done_hi = -1;
        auto cover = [&](int a, int b) {  // sums what [a, b] adds to [done_lo, done_hi], one span
          if (done_hi < done_lo) {
            columnHistogram(cy.lo, cy.hi, false, a, b);
            done_lo = a;
            done_hi = b;
            return;
          }
          if (a < done_lo) columnHistogram(cy.lo, cy.hi, false, a, done_lo - 1);
          if (b > done_hi) columnHistogram(cy.lo, cy.hi, false, done_hi + 1, b);
          done_lo = std::min(done_lo, a);
          done_hi = std::max(done_hi, b);
        };
        constexpr int kBlock = 32;
        auto column = [&](int x) {
          if (x < done_lo) cover(std::max(0, std::min(x, done_lo - kBlock)), done_hi);
          if (x > done_hi) cover(done_lo, std::min(cols - 1, std::max(x, done_hi + kBlock)));
          return col_hist_[static_cast<std::size_t>(x)];
        };
        cover(std::max(0, cx.lo - params_.smooth_px), std::min(cols - 1, cx.hi + params_.smooth_px));
        cx = extentOf(column, 0, cols - 1, cx.lo, cx.hi);
      }
    }
    if (cx.hi < cx.lo || cy.hi < cy.lo) {
      banned_[static_cast<std::size_t>(best)] = 1;
      continue;
    }
    // Not an obstacle: drop the evidence of d* in `region` (the box and the place its histograms
    // pointed at) so that the next candidate comes up; an offset that leaves nothing is done.
    auto rejectCandidate = [&](const cv::Rect& region) {
      if (sweepBox(region, kLabelUnassigned, false) == 0) banned_[static_cast<std::size_t>(best)] = 1;
    };
    int x0 = cx.lo, x1 = cx.hi, y0 = cy.lo, y1 = cy.hi;
    float cluster_matches = 0.0f;  // matched pixels of the cluster at d*
    if (params_.cell_px > 0) {
      // The histograms locate the cluster; its extent is the connected set of cells that
      // match at d* (closed outlines of plainly coloured objects hold together, while chance
      // matches of texture at other depths stay below the cell's matched share).
      const int cs = params_.cell_px;
      const int gw = (cols + cs - 1) / cs;
      const int gh = (limit + 1 + cs - 1) / cs;
      for (const int k : touched_cells_) cell_[static_cast<std::size_t>(k)] = Cell{};
      touched_cells_.clear();
      // A cell is active when enough of its pixels match, and most of its features.
      auto activeCell = [&](int matched, int present) {
        return matched >= params_.min_cell_matches && matched >= params_.min_match_fraction * present;
      };
      auto cellAt = [&](int i, int j) -> Cell& {
        const int k = j * gw + i;
        Cell& c = cell_[static_cast<std::size_t>(k)];
        if (c.state != kCellUnknown) return c;
        touched_cells_.push_back(k);
        int matched = 0, present = 0;
        c.x0 = cols;
        c.y0 = rows;
        const int cx0 = i * cs;
        const int cy1 = std::min((j + 1) * cs, limit + 1);  // one past the cell's last row
        if (std::endian::native == std::endian::little && fast_ && cs == 4 && cx0 + 4 <= cols &&
            cy1 - 1 <= stripe_floor) {
          // A cell row's four pixels as the bytes of one word, without a branch per pixel (the
          // pixels' features and matches are what the branches would guess at): the features
          // are the nonzero bytes, a match counts where its pixel is a feature.
          std::uint32_t any = 0;
          for (int y = j * cs; y < cy1; ++y) {
            std::uint32_t lw, mw;
            std::memcpy(&lw, remaining.ptr<std::uint8_t>(y) + cx0, sizeof(lw));
            std::memcpy(&mw, maskRow(candidate_masks_, remaining, right, y, cx0, cx0 + 4) + cx0, sizeof(mw));
            const std::uint32_t feature = simd::nonZeroBytes(lw);
            const std::uint32_t hit = mw & feature;  // mask bytes are 0 or 1
            // The four flags summed by a multiplication into the top byte (the baseline x86-64
            // build has no popcount instruction: std::popcount is a library call there).
            const int n = static_cast<int>((hit * 0x01010101u) >> 24);
            present += static_cast<int>((feature * 0x01010101u) >> 24);
            matched += n;
            c.y0 = n != 0 && y < c.y0 ? y : c.y0;
            c.y1 = n != 0 ? y : c.y1;
            any |= hit;
          }
          if (any != 0) {
            c.x0 = cx0 + std::countr_zero(any) / 8;
            c.x1 = cx0 + (31 - std::countl_zero(any)) / 8;
          }
        } else {
          for (int y = j * cs; y < cy1; ++y) {
            const std::uint8_t* l = remaining.ptr<std::uint8_t>(y);
            const std::uint8_t* mk =
                maskRow(candidate_masks_, remaining, right, y, i * cs, std::min((i + 1) * cs, cols));
            for (int x = i * cs; x < std::min((i + 1) * cs, cols); ++x) {
              if (!l[x] || !inStripe(y, x)) continue;
              ++present;
              if (mk[x]) {
                ++matched;
                c.x0 = std::min(c.x0, x);
                c.x1 = std::max(c.x1, x);
                c.y0 = std::min(c.y0, y);
                c.y1 = std::max(c.y1, y);
              }
            }
          }
        }
        c.matched = matched;
        c.state = activeCell(matched, present) ? kCellActive : kCellInactive;
        return c;
      };
      // The cluster: of the connected sets of active cells (within cell_reach cells of each
      // other) that reach into the histogram box, the one with the most matched pixels among
      // those at least min_height_px tall (a shorter set cannot stand as an obstacle: an
      // outline's top edge, a strip of texture), else among all. The strongest single cell can
      // lie in a small set beside the object the histograms point at.
      const int reach = params_.cell_reach;
      struct Component {
        int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
        float matched = 0.0f;
      };
      auto flood = [&](int seed, int id) {
        Component comp{cols, rows, -1, -1, 0.0f};
        flood_.clear();
        flood_.push_back(seed);
        cell_[static_cast<std::size_t>(seed)].component = id;
        while (!flood_.empty()) {
          const int k = flood_.back();
          flood_.pop_back();
          const Cell& c = cell_[static_cast<std::size_t>(k)];
          comp.x0 = std::min(comp.x0, c.x0);
          comp.x1 = std::max(comp.x1, c.x1);
          comp.y0 = std::min(comp.y0, c.y0);
          comp.y1 = std::max(comp.y1, c.y1);
          comp.matched += static_cast<float>(c.matched);
          const int ci = k % gw, cj = k / gw;
          for (int j = std::max(0, cj - reach); j <= std::min(gh - 1, cj + reach); ++j)
            for (int i = std::max(0, ci - reach); i <= std::min(gw - 1, ci + reach); ++i) {
              Cell& n = cellAt(i, j);
              if (n.state != kCellActive || n.component != 0) continue;
              n.component = id;
              flood_.push_back(j * gw + i);
            }
        }
        return comp;
      };
      // Fast path: the cells of the histogram box, and those within reach around it, are counted
      // a band of cell rows at a time over whole spans (present and matched pixels per column,
      // summed per cell); cellAt then adds the matched pixels' box of the active ones only, which
      // alone the connected sets read. Cells beyond the band, or with rows below the stripe's
      // floor, are left to cellAt.
      if (fast_ && cs == 4) {
        const int i0 = std::max(0, x0 / cs - reach), i1 = std::min(std::min(gw - 1, x1 / cs + reach), cols / cs - 1);
        const int j0 = std::max(0, y0 / cs - reach), j1 = std::min(gh - 1, std::min(y1 / cs, gh - 1) + reach);
        const int xa = i0 * cs, xb = (i1 + 1) * cs;  // one past the last column
        band_present_.resize(static_cast<std::size_t>(cols));
        band_matched_.resize(static_cast<std::size_t>(cols));
        std::uint8_t* fp = band_present_.data();
        std::uint8_t* hp = band_matched_.data();
        for (int j = j0; j <= j1 && i0 <= i1; ++j) {
          const int cy1 = std::min((j + 1) * cs, limit + 1);
          if (cy1 - 1 > stripe_floor) break;  // this band and the ones below it: cellAt
          std::fill(fp + xa, fp + xb, std::uint8_t{0});
          std::fill(hp + xa, hp + xb, std::uint8_t{0});
          for (int y = j * cs; y < cy1; ++y) {
            const std::uint8_t* l = remaining.ptr<std::uint8_t>(y);
            const std::uint8_t* mk = maskRow(candidate_masks_, remaining, right, y, xa, xb);
            for (int x = xa; x < xb; ++x) {
              const std::uint8_t f = l[x] != 0 ? 1 : 0;
              fp[x] = static_cast<std::uint8_t>(fp[x] + f);
              hp[x] = static_cast<std::uint8_t>(hp[x] + (mk[x] & f));  // mask bytes are 0 or 1
            }
          }
          for (int i = i0; i <= i1; ++i) {
            const int k = j * gw + i;
            Cell& c = cell_[static_cast<std::size_t>(k)];
            if (c.state != kCellUnknown) continue;
            const int x = i * cs;
            const int matched = hp[x] + hp[x + 1] + hp[x + 2] + hp[x + 3];
            const int present = fp[x] + fp[x + 1] + fp[x + 2] + fp[x + 3];
            if (activeCell(matched, present)) {
              cellAt(i, j);  // active: its box too
              continue;
            }
            touched_cells_.push_back(k);
            c.matched = matched;
            c.state = kCellInactive;
          }
        }
      }
      Component strongest, strongest_tall;
      int components = 0;
      for (int j = y0 / cs; j <= std::min(y1 / cs, gh - 1); ++j)
        for (int i = x0 / cs; i <= x1 / cs; ++i) {
          const Cell& c = cellAt(i, j);
          if (c.state != kCellActive || c.component != 0) continue;
          const Component comp = flood(j * gw + i, ++components);
          if (comp.matched > strongest.matched) strongest = comp;
          if (comp.y1 - comp.y0 + 1 >= params_.min_height_px && comp.matched > strongest_tall.matched)
            strongest_tall = comp;
        }
      if (components == 0) {
        rejectCandidate(cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1));
        continue;
      }
      const Component& chosen = strongest_tall.x1 >= 0 ? strongest_tall : strongest;
      x0 = chosen.x0;
      y0 = chosen.y0;
      x1 = chosen.x1;
      y1 = chosen.y1;
      cluster_matches = chosen.matched;
      // The columns stay within the histogram's lateral borders. Beside an object the flood
      // reaches cells of chance matches: left of it in the band the right camera cannot see
      // (as wide as its offset minus the offset behind it), and streaked texture on either
      // side; they widen a narrow person's box by up to half its width. (A plainly coloured
      // object whose far outline lies beyond the histogram's border is cut at the border.)
      x0 = std::max(x0, cx.lo);
      x1 = std::min(x1, cx.hi);
      // The flood misses the top of an object whose top cells hold less than the cell's matched
      // share (a head against textured background): rows above it, within the row histogram's
      // extent, join while they hold top_row_matches matches in the cluster's columns (with up
      // to top_gap_rows rows without).
      if (params_.top_row_matches > 0 && x1 >= x0) {
        for (int y = y0 - 1, gap = 0; y >= cy.lo; --y) {
          const std::uint8_t* mk = maskRow(candidate_masks_, remaining, right, y, x0, x1 + 1);
          int n = 0;
          for (int x = x0; x <= x1; ++x) n += mk[x] != 0 && inStripe(y, x) ? 1 : 0;
          if (n >= params_.top_row_matches) {
            y0 = y;
            gap = 0;
          } else if (++gap > params_.top_gap_rows) {
            break;
          }
        }
      }
      if (x1 < x0) {
        rejectCandidate(cv::Rect(cx.lo, cy.lo, cx.hi - cx.lo + 1, cy.hi - cy.lo + 1));
        continue;
      }
    } else {
      for (int x = x0; x <= x1; ++x) cluster_matches += col_hist_[static_cast<std::size_t>(x)];
    }
    int dmin = best, dmax = best;
    col_offset_.assign(static_cast<std::size_t>(cols), best);
    const int own_x0 = x0, own_x1 = x1, own_y0 = y0, own_y1 = y1;  // the cluster before any growth

    if (params_.grow_walls) {
      // Mean column evidence of the cluster: an extension needs a fraction of it.
      const float mean_col = cluster_matches / static_cast<float>(x1 - x0 + 1);
      const float thr_col = std::max(2.0f, static_cast<float>(params_.extent_fraction) * mean_col);
      auto tryGrow = [&](int d) {
        if (d < 0 || d >= offsets || d <= background + params_.background_margin_px) return false;
        const int ya = y0;
        const int yb = rowLimit(d);
        if (yb < ya) return false;
        resetMasks(growth_masks_, d - tol, d + tol);
        // Column evidence at d, computed only for the columns a run walks over.
        // A column whose features mostly do not match at d shows texture at other depths.
        // The fast path counts eight columns at a time, row by row (the run asks for the next
        // ones in its direction): each row's features and matches as the bytes of one word.
        constexpr int kBlock = 8;
        int block_x0 = 0, block_x1 = -1;  // the columns block_count_ and block_present_ hold
        // A row's first mask request covers the first block on both sides of the cluster: one
        // kernel call instead of two (a call's fixed cost is most of a block's).
        const int both_lo = std::max(0, x0 - kBlock), both_hi = std::min(cols, x1 + 1 + kBlock);
        auto countBlock = [&](int xa) {
          block_x0 = std::max(0, xa);
          block_x1 = std::min(cols - 1, xa + kBlock - 1);
          const int n = block_x1 - block_x0 + 1;
          int yc[kBlock];
          int common = yb;  // rows every column of the block counts
          for (int i = 0; i < n; ++i) {
            yc[i] = std::min(yb, rowLimitAt(d, block_x0 + i));
            common = std::min(common, yc[i]);
            block_count_[static_cast<std::size_t>(i)] = 0;
            block_present_[static_cast<std::size_t>(i)] = 0;
          }
          int y = ya;
          if (n == kBlock && std::endian::native == std::endian::little) {
            const int req_lo = std::min(block_x0, both_lo), req_hi = std::max(block_x0 + kBlock, both_hi);
            fillMaskRows(growth_masks_, remaining, right, ya, common, req_lo, req_hi);
            // Byte counters of at most 255 rows, then added to the columns' totals.
            while (y <= common) {
              const int y_end = std::min(common, y + 254);
              std::uint64_t present = 0, matched = 0;
              for (; y <= y_end; ++y) {
                std::uint64_t lw, mw;
                std::memcpy(&lw, remaining.ptr<std::uint8_t>(y) + block_x0, sizeof(lw));
                std::memcpy(&mw, maskRow(growth_masks_, remaining, right, y, req_lo, req_hi) + block_x0, sizeof(mw));
                const std::uint64_t feature = simd::nonZeroBytes(lw);
                present += feature;
                matched += mw & feature;  // mask bytes are 0 or 1
              }
              for (int i = 0; i < kBlock; ++i) {
                block_present_[static_cast<std::size_t>(i)] += static_cast<int>((present >> (8 * i)) & 0xff);
                block_count_[static_cast<std::size_t>(i)] += static_cast<int>((matched >> (8 * i)) & 0xff);
              }
            }
          }
          for (int i = 0; i < n; ++i) {
            const int x = block_x0 + i;
            for (int yy = y; yy <= yc[i]; ++yy) {
              if (!remaining.ptr<std::uint8_t>(yy)[x]) continue;
              ++block_present_[static_cast<std::size_t>(i)];
              block_count_[static_cast<std::size_t>(i)] += maskRow(growth_masks_, remaining, right, yy, x, x + 1)[x];
            }
          }
        };
        auto columnAt = [&](int x, int step) {
          int count = 0, present = 0;
          if (fast_) {
            if (x < block_x0 || x > block_x1) countBlock(step > 0 ? x : x - kBlock + 1);
            count = block_count_[static_cast<std::size_t>(x - block_x0)];
            present = block_present_[static_cast<std::size_t>(x - block_x0)];
          } else {
            const int yc = std::min(yb, rowLimitAt(d, x));
            for (int y = ya; y <= yc; ++y) {
              if (!remaining.ptr<std::uint8_t>(y)[x]) continue;
              ++present;
              count += maskRow(growth_masks_, remaining, right, y, x, x + 1)[x];
            }
          }
          if (count < params_.min_match_fraction * present) count = 0;
          col_hist_[static_cast<std::size_t>(x)] = static_cast<float>(count);
          return static_cast<float>(count);
        };
        // Runs of strong columns starting within gap_px of the cluster's sides.
        auto run = [&](int start, int step) {
          int end = start - step;  // last accepted column
          float sum = 0.0f;
          int gap = 0;
          for (int x = start; x >= 0 && x < cols; x += step) {
            const float v = columnAt(x, step);
            if (v >= thr_col) {
              end = x;
              gap = 0;
              sum += v;
            } else if (++gap > params_.gap_px) {
              break;
            }
          }
          return std::pair<int, float>{end, sum};
        };
        const auto [right_end, right_sum] = run(x1 + 1, +1);
        const auto [left_end, left_sum] = run(x0 - 1, -1);
        const bool grow_right = right_end > x1 && right_sum >= static_cast<float>(params_.min_growth_matches);
        const bool grow_left = left_end < x0 && left_sum >= static_cast<float>(params_.min_growth_matches);
        if (!grow_right && !grow_left) return false;
        const int ex0 = grow_left ? left_end : x1 + 1;
        const int ex1 = grow_right ? right_end : x0 - 1;
        // Rows of the extension.
        row_hist_.assign(static_cast<std::size_t>(rows), 0.0f);
        // Column by column: each column's ground limit is looked up once (whole counts, so the
        // order of the additions does not matter).
        for (int x = ex0; x <= ex1; ++x) {
          if (x >= x0 && x <= x1) continue;
          const int yc = std::min(yb, rowLimitAt(d, x));
          for (int y = ya; y <= yc; ++y)
            if (maskRow(growth_masks_, remaining, right, y, x, x + 1)[x]) row_hist_[static_cast<std::size_t>(y)] += 1.0f;
        }
        const Extent ey = extent(row_hist_, ya, yb, ya, yb);
        if (ey.hi >= ey.lo) {
          y0 = std::min(y0, ey.lo);
          y1 = std::max(y1, ey.hi);
        }
        if (grow_left) {
          std::fill(col_offset_.begin() + left_end, col_offset_.begin() + x0, d);
          x0 = left_end;
        }
        if (grow_right) {
          std::fill(col_offset_.begin() + x1 + 1, col_offset_.begin() + right_end + 1, d);
          x1 = right_end;
        }
        return true;
      };
      while (dmax + 1 < offsets && tryGrow(dmax + 1)) ++dmax;
      while (dmin - 1 >= 0 && tryGrow(dmin - 1)) --dmin;
    }

    // Obstacles stand on the ground: the bottom is the contact row of the nearest offset.
    // Then the box's matched share and significance.
    struct Verdict {
      cv::Rect box;
      bool floating = false, unmatched = false, significant = false;
    };
    auto judge = [&]() {
      bool floating = false;
      if (ground_known) {
        // The lowest contact over the box's columns (a receding wall meets the ground nearest
        // at its near end; on a transversal slope the contact moves along the box).
        // A contact below the image (a near obstacle) is the image's last row: the obstacle must
        // reach down to it.
        // Rows whose ground offset is within ground_clearance_px of d* are left out of the
        // histograms (ground residue): the gap is measured to the last row the cluster could
        // show in, and only the rows down to there can support it.
        int contact = -1, lowest_shown = -1;
        for (int x = x0; x <= x1; ++x) {
          contact = std::max(contact, std::min(contactRowAt(col_offset_[static_cast<std::size_t>(x)], x), rows - 1));
          lowest_shown = std::max(lowest_shown, col_limit_[static_cast<std::size_t>(x)]);
        }
        lowest_shown = std::min(lowest_shown, contact);
        if (contact >= 0) {
          const double allowed = contactTolerance(y1 - y0 + 1);
          if (y1 < lowest_shown - allowed) {
            // Weakly textured lower parts (legs, a plain lower body) fall below the histogram's
            // fraction of the peak: the cluster still stands on the ground when most rows down
            // to there keep some match at d* inside its columns. Below a cluster wide enough
            // (plain_support_min_width_m), rows without a single feature pixel in its columns are
            // left out: a plain lower body (a vehicle's side, a wall's plaster) shows nothing at
            // any offset there, and neither holds the cluster up nor shows the ground through it.
            // Under a narrow part such rows are common by chance and still count.
            int rows_with_match = 0, rows_seen = 0;
            const bool plain_neutral = params_.plain_support_min_width_m > 0.0 && best > 0 &&
                                       (x1 - x0 + 1) * baseline_m / best >= params_.plain_support_min_width_m;
            for (int y = y1 + 1; y <= lowest_shown; ++y) {
              if (plain_neutral) {
                const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
                if (std::all_of(lab + x0, lab + x1 + 1, [](std::uint8_t v) { return v == kLabelNone; })) continue;
              }
              ++rows_seen;
              const std::uint8_t* l = remaining.ptr<std::uint8_t>(y);
              for (int x = x0; x <= x1; ++x)
                if (l[x] && inStripe(y, x) && maskAt(y, x)) {
                  ++rows_with_match;
                  break;
                }
            }
            floating = rows_with_match < params_.min_support_fraction * rows_seen;
          }
          if (!floating) y1 = contact;
        }
      }
      const cv::Rect box(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
      const int count = sweepBox(box, -1, true);
      const int present = cv::countNonZero(remaining(box));
      const bool unmatched = count < params_.min_match_fraction * present;
      // A weak cluster (its peak or its matches below the obstacle thresholds) stays when it has
      // a person's size at d*: size in metres = pixels x baseline / offset.
      bool significant = strong_peak && count >= params_.min_cluster_features;
      if (!significant && weak_search && count >= params_.weak_cluster_features && best > 0) {
        const double metres_per_px = baseline_m / best;
        const double height_m = box.height * metres_per_px;
        significant = height_m >= params_.weak_min_height_m && height_m <= params_.weak_max_height_m &&
                      box.width * metres_per_px <= params_.weak_max_width_m;
      }
      return Verdict{box, floating, unmatched, significant};
    };
    Verdict verdict = judge();
    if (verdict.unmatched && params_.ungrown_retry && (dmin != best || dmax != best)) {
      // The growth over neighbouring offsets took in columns whose features mostly match
      // elsewhere (what stands beside or behind it): the cluster is judged again on its own
      // columns.
      std::fill(col_offset_.begin(), col_offset_.end(), best);
      x0 = own_x0;
      x1 = own_x1;
      y0 = own_y0;
      y1 = own_y1;
      dmin = dmax = best;
      verdict = judge();
    }
    const cv::Rect box = verdict.box;
    const bool floating = verdict.floating, unmatched = verdict.unmatched, significant = verdict.significant;
    // An earlier obstacle at this offset that the cluster is a part of takes it in.
    auto atOffsetOf = [&](const ObstacleCluster& earlier) { return atOffsetsOf(best, earlier, tol); };
    auto absorbInto = [&](ObstacleCluster& earlier) {
      earlier.feature_count += sweepBox(box, earlier.label, true);
      earlier.box |= box;
      earlier.min_offset_px = std::min(earlier.min_offset_px, dmin);
      earlier.max_offset_px = std::max(earlier.max_offset_px, dmax);
    };
    // A floating cluster resting on an earlier obstacle at its offset (a person's upper body
    // found after the legs) is a part of it.
    ObstacleCluster* below = nullptr;
    if (floating && !unmatched) {
      const double allowed = contactTolerance(box.height);
      for (ObstacleCluster& earlier : obstacles) {
        if (!atOffsetOf(earlier)) continue;
        const int overlap =
            std::min(box.x + box.width, earlier.box.x + earlier.box.width) - std::max(box.x, earlier.box.x);
        if (overlap >= params_.merge_overlap * std::min(box.width, earlier.box.width) &&
            earlier.box.y >= box.y && earlier.box.y <= box.y + box.height - 1 + allowed) {
          below = &earlier;
          break;
        }
      }
    }
    if (below) {
      absorbInto(*below);
      continue;
    }
    if (floating && !unmatched && significant && box.height >= params_.min_height_px &&
        box.width >= params_.min_width_px && static_cast<int>(floating_.size()) < params_.max_iterations)
      floating_.push_back(FloatingPart{box, best, dmin, dmax});
    if (floating || unmatched || !significant || box.height < params_.min_height_px || box.width < params_.min_width_px) {
      rejectCandidate(cv::Rect(cx.lo, cy.lo, cx.hi - cx.lo + 1, cy.hi - cy.lo + 1) | box);
      continue;
    }

    // A cluster at the offset of an earlier obstacle and inside it is a part of it.
    ObstacleCluster* merged = nullptr;
    for (ObstacleCluster& earlier : obstacles) {
      if (atOffsetOf(earlier) && overlapOfSmaller(earlier.box, box) >= params_.merge_overlap) {
        merged = &earlier;
        break;
      }
    }
    if (merged) {
      absorbInto(*merged);
      continue;
    }
    ObstacleCluster cluster;
    cluster.label = kLabelFirstObstacle + static_cast<int>(obstacles.size());
    cluster.offset_px = params_.refine_offset ? ownOffset(remaining, right, box, best) : best;
    cluster.min_offset_px = std::min(dmin, cluster.offset_px);
    cluster.max_offset_px = std::max(dmax, cluster.offset_px);
    cluster.box = box;
    cluster.feature_count = sweepBox(box, cluster.label, true);
    obstacles.push_back(cluster);
  }
  // The score left behind describes what remains (same arithmetic as Correlator).
  const int min_row = correlator.params().min_row_features;
  for (int y = 0; y < rows; ++y) {
    if (!changed_rows[static_cast<std::size_t>(y)]) continue;
    const float norm = static_cast<float>(std::max(cv::countNonZero(remaining.row(y)), min_row));
    const int* m = matches.ptr<int>(y);
    float* sc = score.ptr<float>(y);
    for (int d = 0; d < offsets; ++d) sc[d] = static_cast<float>(m[d]) / norm;
  }
  std::fill(changed_rows.begin(), changed_rows.end(), std::uint8_t{0});
}

int ObstacleExtractor::trimOccludedLeft(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                        cv::Mat& labels, std::vector<ObstacleCluster>& obstacles) const {
  if (!params_.trim_occluded_left || ground.source == GroundSource::kNone) return 0;
  requireMono8Pair(left, right, labels);
  const int cols = left.cols;
  const int tol = params_.offset_tolerance_px;
  auto behind = [&](int y, int x) { return offsetBehind(ground, y, x); };
  int trimmed = 0;
  for (ObstacleCluster& o : obstacles) {
    const int d = o.offset_px;
    // The band is at most as wide as the obstacle's offset minus the smallest offset behind it.
    int min_behind = d;
    for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
      const int b = behind(y, o.box.x);
      if (b >= 0) min_behind = std::min(min_behind, b);
    }
    // The band may be wider than the object (a thin pole before far background): all of the box
    // but the narrowest obstacle's width may go.
    const int most = std::min(static_cast<int>(params_.occluded_max_share * o.box.width),
                              o.box.width - params_.min_width_px);
    const int band = std::min(d - min_behind, most);
    // The band is the longest run of columns from the left whose pixels are, together, at least
    // two thirds ambiguous: it ends where the running sum of 3 * ambiguous - 2 * own peaks, so
    // that one column of chance pixels inside it does not stop the trim.
    int x = o.box.x;
    long balance = 0, best = 0;
    for (int c = o.box.x; c < o.box.x + band; ++c) {
      int own = 0, ambiguous = 0;
      for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
        if (labels.ptr<std::uint8_t>(y)[c] != o.label) continue;
        ++own;
        // The right pixel c - d shows what is behind, visible in the left image at c - d + b.
        const int b = behind(y, c);
        if (b < 0 || b >= d - tol - 1) continue;
        ambiguous += matchAt(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), c - d + b, b - tol, b + tol,
                             params_.grey_tolerance, params_.match_half_window_px, cols);
      }
      balance += 3 * ambiguous - 2 * own;
      if (balance >= best) {
        best = balance;
        x = c + 1;
      }
    }
    if (x == o.box.x) continue;
    trimmed += x - o.box.x;
    narrowTo(o, x, o.box.x + o.box.width - 1, labels);
  }
  return trimmed;
}

void ObstacleExtractor::narrowTo(ObstacleCluster& o, int x0, int x1, cv::Mat& labels) {
  for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
    std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    for (int c = o.box.x; c < o.box.x + o.box.width; ++c) {
      if (lab[c] != o.label || (c >= x0 && c <= x1)) continue;
      lab[c] = kLabelUnassigned;
      --o.feature_count;
    }
  }
  o.box.x = x0;
  o.box.width = x1 - x0 + 1;
}

void ObstacleExtractor::foldInto(std::size_t& i, const cv::Rect& reach, int d_lo, int d_hi, cv::Mat& labels,
                                 std::vector<ObstacleCluster>& obstacles) {
  ObstacleCluster joined = obstacles[i];
  joined.box |= reach;
  folded_.assign(obstacles.size(), 0);
  for (std::size_t j = 0; j < obstacles.size(); ++j) {
    const ObstacleCluster& b = obstacles[j];
    if (j != i && b.min_offset_px <= d_hi && b.max_offset_px >= d_lo &&
        overlapOfSmaller(reach, b.box) >= params_.merge_overlap) {
      joined.box |= b.box;
      joined.min_offset_px = std::min(joined.min_offset_px, b.min_offset_px);
      joined.max_offset_px = std::max(joined.max_offset_px, b.max_offset_px);
      joined.feature_count += b.feature_count;
      folded_[j] = 1;
    }
  }
  replaceFolded(i, joined, labels, obstacles);
}

void ObstacleExtractor::replaceFolded(std::size_t& i, const ObstacleCluster& joined, cv::Mat& labels,
                                      std::vector<ObstacleCluster>& obstacles) {
  const int a_label = obstacles[i].label;
  LabelMap into = unchangedLabels();  // old label -> the old label it ends up under
  std::vector<ObstacleCluster>& kept = kept_;
  kept.clear();
  bool any_folded = false;
  for (std::size_t j = 0; j < obstacles.size(); ++j) {
    if (folded_[j]) into[static_cast<std::size_t>(obstacles[j].label)] = static_cast<std::uint8_t>(a_label);
    else kept.push_back(obstacles[j]);
    any_folded |= folded_[j] != 0;
  }
  // Renumber: the obstacles left keep their order, labels follow.
  LabelMap renumbered = into;
  for (std::size_t n = 0; n < kept.size(); ++n) {
    const int label = kLabelFirstObstacle + static_cast<int>(n);
    if (kept[n].label == a_label) {
      kept[n] = joined;
      kept[n].joined_parts |= any_folded;  // a face of parts found apart
      i = n;
    }
    for (int v = 0; v < 256; ++v)
      if (into[static_cast<std::size_t>(v)] == kept[n].label)
        renumbered[static_cast<std::size_t>(v)] = static_cast<std::uint8_t>(label);
    kept[n].label = label;
  }
  relabel(labels, renumbered);
  obstacles.assign(kept.begin(), kept.end());
}

int ObstacleExtractor::joinRecedingParts(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                         cv::Mat& labels, std::vector<ObstacleCluster>& obstacles, double baseline_m) {
  if (!params_.join_receding_parts || baseline_m <= 0.0 || ground.source != GroundSource::kHough) return 0;
  requireMono8Pair(left, right, labels);
  const int rows = left.rows, cols = left.cols;
  const int tol = params_.offset_tolerance_px;
  // Does the left feature at (y, x) match the right image at offset d (+-tol, the loop's window)?
  auto matches = [&](int y, int x, int d) {
    return matchAt(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x, d - tol, d + tol, params_.grey_tolerance,
                   params_.match_half_window_px, cols);
  };
  // Parts a (left) and b (right): -1 when they are not one face; else the gap's features matching
  // at the face's offsets (labelled a's with label_them, otherwise 0).
  auto gapEvidence = [&](const ObstacleCluster& a, const ObstacleCluster& b, bool label_them) {
    const int x0 = a.box.x + a.box.width, x1 = b.box.x - 1;  // gap columns [x0, x1]
    const int gap = x1 - x0 + 1;
    if (gap < 1 || gap > params_.receding_max_gap_widths * std::max(a.box.width, b.box.width)) return -1;
    const int da = a.offset_px, db = b.offset_px;
    if (std::abs(da - db) < params_.receding_min_offset_step_px || da <= 0 || db <= 0) return -1;
    // One face: the same height in metres at both parts.
    const double ha = a.box.height * baseline_m / da, hb = b.box.height * baseline_m / db;
    if (std::abs(ha - hb) > params_.plain_height_tolerance * std::max(ha, hb)) return -1;
    // Along a vertical plane the offset is linear in the column: the line through the parts'
    // centres. The face's top and bottom rows run straight from one part's side to the other's.
    const double xa = a.box.x + 0.5 * (a.box.width - 1), xb = b.box.x + 0.5 * (b.box.width - 1);
    // A plane X = a Z + c (camera frame) shows offset d = B (x - x_vanishing) / c: the line's
    // slope says where the plane passes the camera. A face passing nearer than
    // receding_min_lateral_m would touch the vehicle; two separate objects side by side make such
    // steep lines.
    if (baseline_m * (xb - xa) / std::abs(db - da) < params_.receding_min_lateral_m) return -1;
    const int ta = a.box.y, tb = b.box.y;
    const int ba = a.box.y + a.box.height - 1, bb = b.box.y + b.box.height - 1;
    auto along = [&](double u, double v, int x) {
      return static_cast<int>(std::lround(u + (v - u) * (x - x0 + 1) / (gap + 1.0)));
    };
    // The evidence is the face's top outline: in most gap columns a feature within 2 rows of the
    // straight top matches at the line's offset there. (The features inside the gap do not tell:
    // the ground seen between two objects matches such offsets about as often as a face does.)
    // When the parts are joined, the gap's features matching at the line's offsets take a's
    // label, those the removal gave the ground or the background by chance too; rows where the
    // ground's offset reaches the line's cannot tell and stay as they are.
    int matched = 0, outlined = 0;
    const float clearance = static_cast<float>(params_.ground_clearance_px);
    for (int x = x0; x <= x1; ++x) {
      const int d = static_cast<int>(std::lround(da + (db - da) * (x - xa) / (xb - xa)));
      const int top = along(ta, tb, x), bottom = along(ba, bb, x);
      for (int y = std::max(0, top); y <= std::min(rows - 1, bottom); ++y) {
        if (y >= ground.horizon_row && y < static_cast<int>(ground.offset_per_row.size())) {
          const float g = ground.groundOffsetAt(y, static_cast<float>(x));
          if (std::isfinite(g) && g >= static_cast<float>(d) - clearance) continue;
        }
        std::uint8_t& label = labels.ptr<std::uint8_t>(y)[x];
        if (!label_them || label == kLabelNone || label >= kLabelFirstObstacle || !matches(y, x, d)) continue;
        ++matched;
        label = static_cast<std::uint8_t>(a.label);
      }
      bool hit = false;
      for (int y = std::max(0, top - 2); y <= std::min(rows - 1, top + 2) && !hit; ++y) {
        const std::uint8_t label = labels.ptr<std::uint8_t>(y)[x];
        const bool ours = label == kLabelUnassigned || label == a.label || label == b.label;
        hit = ours && matches(y, x, d);
      }
      outlined += hit ? 1 : 0;
    }
    return outlined >= params_.plain_min_outline_fraction * gap ? matched : -1;
  };
  int joins = 0;
  for (bool again = true; again;) {
    again = false;
    for (std::size_t i = 0; i < obstacles.size() && !again; ++i) {
      for (std::size_t j = 0; j < obstacles.size() && !again; ++j) {
        if (i == j || gapEvidence(obstacles[i], obstacles[j], false) < 0) continue;
        // b joins a: the gap's matched features take a's label, b's pixels too, and the
        // obstacles after b move up one label.
        const ObstacleCluster& a = obstacles[i];
        const ObstacleCluster& b = obstacles[j];
        const int gap_matches = gapEvidence(a, b, true);
        ObstacleCluster joined = a;
        joined.box |= b.box;
        joined.min_offset_px = std::min({a.min_offset_px, b.min_offset_px, a.offset_px, b.offset_px});
        joined.max_offset_px = std::max({a.max_offset_px, b.max_offset_px, a.offset_px, b.offset_px});
        if (b.feature_count > a.feature_count) joined.offset_px = b.offset_px;  // the larger part's offset
        joined.feature_count += b.feature_count + gap_matches;
        folded_.assign(obstacles.size(), 0);
        folded_[j] = 1;
        replaceFolded(i, joined, labels, obstacles);
        ++joins;
        again = true;
      }
    }
  }
  return joins;
}

int ObstacleExtractor::dropRemnants(cv::Mat& labels, std::vector<ObstacleCluster>& obstacles) {
  const int least = leastClusterFeatures();
  LabelMap renumbered = unchangedLabels();
  std::size_t kept = 0;
  // Every obstacle's pixels lie inside its box: only the boxes of the dropped obstacles and of
  // those renumbered after them hold labels that change.
  cv::Rect changed;
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    ObstacleCluster& o = obstacles[i];
    const auto old_label = static_cast<std::size_t>(o.label);
    if (o.feature_count < least) {
      renumbered[old_label] = kLabelUnassigned;
      changed |= o.box;
      continue;
    }
    o.label = kLabelFirstObstacle + static_cast<int>(kept);
    renumbered[old_label] = static_cast<std::uint8_t>(o.label);
    if (o.label != static_cast<int>(old_label)) changed |= o.box;
    obstacles[kept++] = o;
  }
  const int dropped = static_cast<int>(obstacles.size() - kept);
  if (dropped == 0) return 0;
  obstacles.resize(kept);
  relabel(labels, renumbered, changed);
  return dropped;
}

bool ObstacleExtractor::standsAt(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                 const cv::Mat& labels, int y, int x, int d) const {
  constexpr int kNone = std::numeric_limits<int>::max();
  const std::uint8_t label = labels.ptr<std::uint8_t>(y)[x];
  const bool candidate = label == kLabelGround || label == kLabelBackground ||
                         (label == kLabelUnassigned && params_.stride_unassigned);
  if (!candidate || x < kSadHalfWidth || x + kSadHalfWidth >= left.cols) return false;
  const float line = ground.lineOffsetAt(y, static_cast<float>(x));
  const std::uint8_t* l = left.ptr<std::uint8_t>(y);
  const std::uint8_t* r = right.ptr<std::uint8_t>(y);
  const int at_offset = standingCost(l, r, x, d, line, static_cast<float>(params_.plain_side_contact_px),
                                     params_.stride_max_cost, params_.stride_cost_margin, kNone);
  if (at_offset == kNone) return false;
  // Unique: lower by stride_unique_margin than at every other offset from 8 below the smaller of
  // the two to 8 above the larger.
  const int li = static_cast<int>(std::lround(line));
  for (int e = std::max(0, std::min(li, d) - 8); e <= std::max(li, d) + 8; ++e) {
    if (std::abs(e - d) <= 2 || x - e - kSadHalfWidth < 0) continue;
    if (sadAt(l, r, x, e) < at_offset + params_.stride_unique_margin) return false;
  }
  return true;
}

std::array<int, 256> ObstacleExtractor::offsetsOfLabels(const std::vector<ObstacleCluster>& obstacles) {
  std::array<int, 256> offset_of_label{};
  offset_of_label.fill(-1);
  for (const ObstacleCluster& o : obstacles)
    if (o.label >= 0 && o.label < 256) offset_of_label[static_cast<std::size_t>(o.label)] = o.offset_px;
  return offset_of_label;
}

int ObstacleExtractor::extendStrides(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                     const cv::Mat& labels, std::vector<ObstacleCluster>& obstacles,
                                     double baseline_m) const {
  if (!params_.extend_strides || !(baseline_m > 0.0)) return 0;
  const int cols = left.cols;
  const std::array<int, 256> offset_of_label = offsetsOfLabels(obstacles);
  int added = 0;
  for (ObstacleCluster& o : obstacles) {
    const int d = o.offset_px;
    if (d <= 0) continue;
    const double height_m = static_cast<double>(o.box.height) * baseline_m / d;
    if (height_m < params_.weak_min_height_m || height_m > params_.weak_max_height_m) continue;
    const int y0 = std::max(0, o.box.y), y1 = std::min(left.rows - 1, o.box.y + o.box.height - 1);
    auto stands = [&](int y, int x) { return standsAt(left, right, ground, labels, y, x, d); };
    auto standing = [&](int x) {
      int n = 0;
      for (int y = y0; y <= y1 && n < params_.stride_min_pixels; ++y) n += stands(y, x);
      return n >= params_.stride_min_pixels;
    };
    // Does column x hold, in the box's rows, a pixel of another obstacle at another offset?
    auto holdsAnother = [&](int x) {
      for (int y = y0; y <= y1; ++y)
        if (ofAnotherObstacle(offset_of_label, labels.ptr<std::uint8_t>(y)[x], o.label, d, params_.offset_tolerance_px))
          return true;
      return false;
    };
    const int reach = static_cast<int>(params_.stride_max_growth * o.box.height);
    auto walk = [&](int from, int dir) {
      int end = from;
      for (int x = from + dir, gap = 0; x >= 0 && x < cols && std::abs(x - from) <= reach; x += dir) {
        if (params_.stride_stop_at_others && holdsAnother(x)) break;
        if (standing(x)) {
          end = x;
          gap = 0;
        } else if (++gap > params_.stride_gap_px) {
          break;
        }
      }
      return std::abs(end - from) <= params_.plain_side_reach_px ? from : end;
    };
    added += widenBox(o.box, walk(o.box.x, -1), walk(o.box.x + o.box.width - 1, +1));
  }
  return added;
}

int ObstacleExtractor::growOverHiddenGround(const GroundProfile& ground, const cv::Mat& labels,
                                            std::vector<ObstacleCluster>& obstacles, double baseline_m) {
  if (!params_.grow_over_hidden_ground || ground.source != GroundSource::kHough || !(baseline_m > 0.0)) return 0;
  const int cols = labels.cols, rows = labels.rows;
  seen_in_row_.resize(static_cast<std::size_t>(rows));
  for (int y = 0; y < rows; ++y) seen_in_row_[static_cast<std::size_t>(y)] = groundOrBackgroundInRow(labels, y);
  const std::array<int, 256> offset_of_label = offsetsOfLabels(obstacles);
  const int tol = params_.offset_tolerance_px;
  int added = 0;
  for (ObstacleCluster& o : obstacles) {
    const int d = o.offset_px;
    if (d <= 0 || !atOneOffset(o) || o.box.width < params_.min_width_px) continue;
    const int bottom = o.box.y + o.box.height - 1;
    const int contact = std::min(contactRowAt(d, o.box.x + o.box.width / 2), rows - 1);
    if (std::abs(bottom - contact) > params_.contact_tolerance_px) continue;
    // Its rows, without the foot (where the ground's offset meets its own).
    const int y0 = std::max(0, o.box.y), y1 = std::min(bottom, contact) - 3;
    const int n = y1 - y0 + 1;
    if (n < 8) continue;
    long terrain = 0;
    for (int y = y0; y <= y1; ++y) terrain += seen_in_row_[static_cast<std::size_t>(y)];
    if (static_cast<double>(terrain) < params_.hidden_min_terrain_fraction * n * cols) continue;
    // Column x's ground and background features over the rows; -1 when it holds a pixel of
    // another obstacle outside the offset tolerance.
    auto seen = [&](int x) {
      int k = 0;
      for (int y = y0; y <= y1; ++y) {
        const std::uint8_t label = labels.ptr<std::uint8_t>(y)[x];
        k += groundOrBackground(label);
        if (ofAnotherObstacle(offset_of_label, label, o.label, d, tol)) return -1;
      }
      return k;
    };
    const int max_gap = static_cast<int>(params_.plain_max_width_m * d / baseline_m);
    auto walk = [&](int from, int dir) {
      int end = from, showing = 0;
      for (int x = from + dir; x >= 0 && x < cols && std::abs(x - from) <= max_gap; x += dir) {
        const int k = seen(x);
        if (k < 0) return from;
        if (k <= params_.hidden_max_seen_fraction * n) {
          end = x;
          showing = 0;
        } else if (k >= params_.hidden_surround_fraction * n && ++showing >= params_.hidden_end_columns) {
          return end;
        }
      }
      return from;
    };
    added += widenBox(o.box, walk(o.box.x, -1), walk(o.box.x + o.box.width - 1, +1));
  }
  return added;
}

ObstacleExtractor::OtherOffsetMatches ObstacleExtractor::matchesAtOtherOffsets(const cv::Mat& left,
                                                                              const cv::Mat& right,
                                                                              const cv::Mat& labels,
                                                                              const cv::Rect& box, int d) const {
  constexpr std::array<int, 4> kOthers{-6, -3, 3, 6};
  const int tol = params_.offset_tolerance_px;
  const int cols = left.cols;
  OtherOffsetMatches out;
  for (int k : kOthers) out.windows += d + k - tol >= 0 ? 1 : 0;
  if (out.windows == 0) return out;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    const std::uint8_t* l = left.ptr<std::uint8_t>(y);
    const std::uint8_t* r = right.ptr<std::uint8_t>(y);
    for (int x = box.x; x < box.x + box.width; ++x) {
      if (lab[x] == kLabelNone) continue;
      for (int k : kOthers)
        if (d + k - tol >= 0)
          out.matches += matchAt(l, r, x, d + k - tol, d + k + tol, params_.grey_tolerance,
                                 params_.match_half_window_px, cols);
    }
  }
  return out;
}

int ObstacleExtractor::growThinTops(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels,
                                    std::vector<ObstacleCluster>& obstacles, double baseline_m) const {
  if (!params_.grow_thin_tops || !(baseline_m > 0.0)) return 0;
  requireMono8Pair(left, right, labels);
  const std::array<int, 256> offset_of_label = offsetsOfLabels(obstacles);
  const int cols = left.cols;
  const int tol = params_.offset_tolerance_px;
  int added = 0;
  for (ObstacleCluster& o : obstacles) {
    const int d = o.offset_px;
    if (d <= 0 || !atOneOffset(o) || o.box.width * baseline_m / d > params_.thin_top_max_width_m) continue;
    const int x0 = std::max(0, o.box.x), x1 = std::min(cols, o.box.x + o.box.width);  // [x0, x1)
    // The columns beside: as many as the box is wide each side, past the reach of its outline's dilation.
    const int reach = params_.plain_side_reach_px;
    const int beside0 = std::max(0, x0 - reach - (x1 - x0)), beside1 = std::min(cols, x1 + reach + (x1 - x0));
    // Row y's features and matches at d, in the box's columns and beside; false when the row
    // holds pixels of another obstacle at another offset.
    struct Counts {
      int features = 0, matched = 0, features_beside = 0, matched_beside = 0;
      Counts& operator+=(const Counts& o) {
        features += o.features;
        matched += o.matched;
        features_beside += o.features_beside;
        matched_beside += o.matched_beside;
        return *this;
      }
    };
    auto count = [&](int y, Counts& c) {
      const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
      const std::uint8_t* l = left.ptr<std::uint8_t>(y);
      const std::uint8_t* r = right.ptr<std::uint8_t>(y);
      for (int x = beside0; x < beside1; ++x) {
        const std::uint8_t label = lab[x];
        const bool inside = x >= x0 && x < x1;
        if (label == kLabelNone || (!inside && x >= x0 - reach && x < x1 + reach)) continue;
        if (inside && ofAnotherObstacle(offset_of_label, label, o.label, d, tol)) return false;
        const int m = matchAt(l, r, x, std::max(0, d - tol), d + tol, params_.grey_tolerance,
                              params_.match_half_window_px, cols);
        (inside ? c.features : c.features_beside) += 1;
        (inside ? c.matched : c.matched_beside) += m;
      }
      return true;
    };
    // A row holds when at least two of its features in the box's columns, and a
    // min_match_fraction share of them, match at d: a larger share than beside (where a level
    // streak of the background would match alike).
    // With thin_top_plain_beside, a row with no features beside (a post against plain sky) has
    // nothing to be set against there: its own share decides.
    const bool plain_beside = params_.thin_top_plain_beside;
    auto holds = [&](const Counts& c) {
      return c.matched >= 2 && c.matched >= params_.min_match_fraction * c.features &&
             ((plain_beside && c.features_beside == 0) ||
              static_cast<long>(c.matched_beside) * c.features < static_cast<long>(c.matched) * c.features_beside);
    };
    int top = o.box.y, held = 0, held_at_top = 0;
    Counts grown, at_top;  // sums over the rows walked, and over those up to the top
    Counts compared, compared_at_top;  // the same over the rows with features beside
    for (int y = o.box.y - 1, gap = 0; y >= 0; --y) {
      Counts row;
      if (!count(y, row)) break;
      grown += row;
      if (!plain_beside || row.features_beside > 0) compared += row;
      if (holds(row)) {
        top = y;
        held_at_top = ++held;
        at_top = grown;
        compared_at_top = compared;
        gap = 0;
      } else if (++gap > params_.thin_top_gap_rows) {
        break;
      }
    }
    // Most rows added hold, and together they match at d thin_top_min_contrast times as often as
    // beside (over the rows with features beside, when rows without any hold on their own), or as
    // at the other offsets in their own columns.
    if (top == o.box.y || held_at_top < params_.thin_top_min_share * (o.box.y - top)) continue;
    // (at_top.matched counts the same features' matches at d that the other offsets are set against.)
    auto matchesItsOffsetMost = [&]() {
      const OtherOffsetMatches others =
          matchesAtOtherOffsets(left, right, labels, cv::Rect(x0, top, x1 - x0, o.box.y - top), d);
      return others.windows > 0 && static_cast<double>(at_top.matched) * others.windows >=
                                       params_.thin_top_min_contrast * static_cast<double>(others.matches);
    };
    const bool beside_compared = !plain_beside || compared_at_top.features_beside > 0;
    const bool stands_out_of_beside =
        beside_compared && static_cast<double>(compared_at_top.matched) * compared_at_top.features_beside >=
                               params_.thin_top_min_contrast * compared_at_top.matched_beside * compared_at_top.features;
    if (!stands_out_of_beside && !(params_.thin_top_other_offsets && matchesItsOffsetMost())) continue;
    added += o.box.y - top;
    o.box.height += o.box.y - top;
    o.box.y = top;
  }
  return added;
}

bool ObstacleExtractor::isEdge(const ObstacleCluster& o) const {
  return params_.near_end_min_aspect * o.box.width <= o.box.height;
}

int ObstacleExtractor::foldNearEnds(const GroundProfile& ground, cv::Mat& labels,
                                    std::vector<ObstacleCluster>& obstacles) {
  if (!params_.fold_near_ends || ground.source != GroundSource::kHough || rows_ <= 0) return 0;
  const int tol = params_.offset_tolerance_px;
  int folds = 0;
  for (bool again = true; again;) {
    again = false;
    for (std::size_t i = 0; i < obstacles.size() && !again; ++i) {
      const ObstacleCluster& f = obstacles[i];
      // A top at the image's border is not the face's top outline: nothing to compare.
      if (f.max_offset_px - f.min_offset_px < params_.receding_min_offset_step_px || f.box.y <= 0) continue;
      const int f_end = f.box.x + f.box.width;  // exclusive
      const int slack = std::max(2, f.box.height / 8);
      for (std::size_t j = 0; j < obstacles.size() && !again; ++j) {
        const ObstacleCluster& e = obstacles[j];
        if (j == i || e.offset_px <= 0 || e.min_offset_px <= f.max_offset_px + tol) continue;
        if (!isEdge(e)) continue;  // an object
        const int e_end = e.box.x + e.box.width;
        const int reach = std::max(2, e.box.width);
        const bool at_right = e_end > f_end && std::abs(e.box.x - f_end) <= reach;
        const bool at_left = e.box.x < f.box.x && std::abs(e_end - f.box.x) <= reach;
        if ((!at_right && !at_left) || e.box.y <= 0 || std::abs(e.box.y - f.box.y) > slack) continue;
        const int contact = lowestContact(e.box, e.offset_px);
        const int bottom = e.box.y + e.box.height - 1;
        if (contact < 0 || std::abs(contact - bottom) > contactTolerance(e.box.height)) continue;
        foldInto(i, e.box, e.min_offset_px - tol - 1, e.max_offset_px + tol + 1, labels, obstacles);
        ++folds;
        again = true;
      }
    }
  }
  return folds;
}

int ObstacleExtractor::stretchToContact(const GroundProfile& ground, std::vector<ObstacleCluster>& obstacles) const {
  if (!params_.stretch_to_contact || ground.source == GroundSource::kNone || rows_ <= 0) return 0;
  int added = 0;
  for (ObstacleCluster& o : obstacles) {
    const int d = o.offset_px;
    if (d <= 0) continue;
    // The lowest contact over the box's columns, as the loop judged it (a receding face meets the
    // ground nearest at its near end; on a transversal slope the contact moves along the box).
    const int contact = lowestContact(o.box, d);
    const int bottom = o.box.y + o.box.height - 1;
    if (contact <= bottom || contact - bottom > contactTolerance(o.box.height)) continue;
    added += contact - bottom;
    o.box.height = contact - o.box.y + 1;
  }
  return added;
}

int ObstacleExtractor::settleOffsets(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels,
                                     std::vector<ObstacleCluster>& obstacles) const {
  const int span = params_.settle_offset_span_px;
  if (span <= 0) return 0;
  requireMono8Pair(left, right, labels);
  const int tol = params_.grey_tolerance;
  int changed = 0;
  for (ObstacleCluster& o : obstacles) {
    if (o.max_offset_px - o.min_offset_px > span) continue;
    const cv::Rect box = o.box & cv::Rect(0, 0, left.cols, left.rows);
    const std::uint8_t own = static_cast<std::uint8_t>(o.label);
    const int best = offsetWithMostMatches(o.offset_px, span, left.cols, [&](int d) {
      long count = 0;
      for (int y = box.y; y < box.y + box.height; ++y) {
        const std::uint8_t* l = left.ptr<std::uint8_t>(y);
        const std::uint8_t* r = right.ptr<std::uint8_t>(y);
        const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
        int row = 0;  // branch-free on bytes, so that the loop vectorises
        for (int x = std::max(box.x, d); x < box.x + box.width; ++x) {
          const std::uint8_t a = l[x], b = r[x - d], c = lab[x];
          const std::uint8_t lo = a < b ? a : b, hi = a < b ? b : a;
          const bool counted = (c == own) | (c == kLabelGround) | (c == kLabelBackground);
          row += counted & (lo != 0) & (hi - lo <= tol);
        }
        count += row;
      }
      return count;
    });
    if (best == o.offset_px) continue;
    o.offset_px = best;
    o.min_offset_px = std::min(o.min_offset_px, best);
    o.max_offset_px = std::max(o.max_offset_px, best);
    ++changed;
  }
  return changed;
}

int ObstacleExtractor::trimStreakSides(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                       cv::Mat& labels, std::vector<ObstacleCluster>& obstacles) const {
  if (!params_.trim_streak_sides) return 0;
  requireMono8Pair(left, right, labels);
  constexpr int kNone = std::numeric_limits<int>::max();
  const int cols = left.cols;
  const float clearance = static_cast<float>(params_.plain_side_contact_px);
  int trimmed = 0;
  for (ObstacleCluster& o : obstacles) {
    const int d = o.offset_px;
    if (d <= 0 || !atOneOffset(o)) continue;
    const int top_rows = static_cast<int>(params_.streak_top_share * o.box.height);
    const int y_end = o.box.y + o.box.height;
    // Does column x stay: a pixel of o in the box's top rows (a head and shoulders, a roof
    // line), or streak_min_standing of them standing at d rather than at their row's line offset
    // (a level streak of the ground matches at both alike)? Columns too near the border to test stay.
    auto stays = [&](int x) {
      if (x - d - kSadHalfWidth - 1 < 0 || x + kSadHalfWidth >= cols) return true;
      int standing = 0;
      for (int y = o.box.y; y < y_end; ++y) {
        if (labels.ptr<std::uint8_t>(y)[x] != o.label) continue;
        if (y < o.box.y + top_rows) return true;
        const float line = ground.lineOffsetAt(y, static_cast<float>(x));
        if (standingCost(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x, d, line, clearance,
                         params_.streak_max_cost, params_.stride_cost_margin, kNone) != kNone &&
            ++standing >= params_.streak_min_standing)
          return true;
      }
      return false;
    };
    const int x_last = o.box.x + o.box.width - 1;
    int a = o.box.x, b = x_last;
    while (a < b && !stays(a)) ++a;
    while (b > a && !stays(b)) --b;
    // Up to plain_side_reach_px columns are the outline's own dilation: left to the plain-side trim.
    if (a - o.box.x <= params_.plain_side_reach_px) a = o.box.x;
    if (x_last - b <= params_.plain_side_reach_px) b = x_last;
    if ((a == o.box.x && b == x_last) || b - a + 1 < params_.min_width_px) continue;
    // The columns going must hold o's pixels in most of them (a streak, not a plain face's span
    // between its outlines), and most of o's pixels must stay.
    const int kept = pixelsOf(labels, o, a, b);
    int held = 0;
    for (int x = o.box.x; x <= x_last; ++x)
      if (x < a || x > b) held += pixelsOf(labels, o, x, x) > 0 ? 1 : 0;
    const int going = o.box.width - (b - a + 1);
    if (kept == o.feature_count || held < params_.streak_min_held_share * going ||
        kept < params_.streak_keep_share * o.feature_count || kept < leastClusterFeatures())
      continue;
    trimmed += going;
    narrowTo(o, a, b, labels);
  }
  return trimmed;
}

int ObstacleExtractor::trimForeignSides(const cv::Mat& left, const cv::Mat& right, cv::Mat& labels,
                                        std::vector<ObstacleCluster>& obstacles, double focal_baseline) const {
  if (!params_.trim_foreign_sides || !(focal_baseline > 0.0)) return 0;
  const int cols = left.cols;
  const int tol = params_.grey_tolerance;
  const int reach = params_.foreign_search_px;
  int trimmed = 0;
  for (ObstacleCluster& o : obstacles) {
    if (!atOneOffset(o)) continue;
    const int d = o.offset_px;
    if (d <= 0) continue;
    // Offset steps of at least foreign_min_step_px and foreign_min_depth_m in depth (Z = fB / d,
    // so a step of dZ is about d^2 dZ / fB pixels): a near object's own parts (arms, a
    // vehicle's nose) lie a few pixels apart.
    const int near = std::max(params_.foreign_min_step_px,
                              static_cast<int>(std::ceil(static_cast<double>(d) * d * params_.foreign_min_depth_m /
                                                         focal_baseline)));
    if (near > reach) continue;
    // Votes of column x's pixels of o that pin an offset: for the offset among d - reach .. d + reach
    // whose 5-pixel window matches best, near d (within near - 1) or away from it.
    auto votes = [&](int x, int& own, int& other) {
      own = other = 0;
      if (x - d - reach - kSadHalfWidth < 0 || x + kSadHalfWidth >= cols) return;
      for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
        if (labels.ptr<std::uint8_t>(y)[x] != o.label) continue;
        const std::uint8_t* l = left.ptr<std::uint8_t>(y);
        if (!pinsOffset(l, x, cols, tol)) continue;
        const std::uint8_t* r = right.ptr<std::uint8_t>(y);
        int best = std::numeric_limits<int>::max(), at = d;
        for (int e = std::max(0, d - reach); e <= d + reach; ++e) {
          const int sad = sadAt(l, r, x, e);
          if (sad < best) {
            best = sad;
            at = e;
          }
        }
        (std::abs(at - d) >= near ? other : own) += 1;
      }
    };
    // From a side inwards up to the first column whose pinning pixels vote for d, when a column
    // before it voted for another offset (the columns between, with no vote, go with them:
    // a plain stretch or a horizontal edge between the two objects).
    auto walk = [&](int from, int to, int dir) {
      bool seen_other = false;
      for (int x = from; x != to + dir; x += dir) {
        int own = 0, other = 0;
        votes(x, own, other);
        if (own >= other && own > 0) return seen_other ? x : from;
        seen_other = seen_other || other > own;
      }
      return from;
    };
    const int x0 = o.box.x, x1 = o.box.x + o.box.width - 1;
    const int a = walk(x0, x1, +1);
    const int b = walk(x1, a, -1);
    // Most of the box voting for other offsets: the obstacle is not a neighbour's remnant (a
    // vehicle's side receding from its nose), keep it whole.
    if (b - a + 1 < params_.min_width_px || (a == x0 && b == x1) ||
        static_cast<double>(b - a + 1) < (1.0 - params_.foreign_max_share) * o.box.width)
      continue;
    trimmed += o.box.width - (b - a + 1);
    narrowTo(o, a, b, labels);
  }
  return trimmed;
}

bool ObstacleExtractor::outlineAt(const cv::Mat& left, const cv::Mat& right, int top, int x, int d0, int d1) const {
  for (int y = std::max(0, top - 2); y <= std::min(left.rows - 1, top + 2); ++y)
    if (matchAt(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x, d0, d1, params_.grey_tolerance,
                params_.match_half_window_px, left.cols))
      return true;
  return false;
}

ObstacleExtractor::FaceTop ObstacleExtractor::faceTop(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels,
                                const ObstacleCluster& o, int first, int end, int dir, int d0, int d1,
                                double baseline_m) {
  const int gap = std::abs(end - first);
  // The gap's columns holding an outline within 2 rows of `top`, one byte each into `hits`.
  auto outlined = [&](int top, std::vector<std::uint8_t>& hits) {
    hits.clear();
    int n = 0;
    for (int k = first; k != end; k += dir) {
      hits.push_back(outlineAt(left, right, top, k, d0, d1) ? 1 : 0);
      n += hits.back();
    }
    return n;
  };
  const FaceTop at_top{o.box.y, outlined(o.box.y, face_hits_)};
  if (!params_.plain_raise_top || gap == 0 || at_top.outlined >= params_.plain_min_outline_fraction * gap)
    return at_top;
  // A gap narrower than a person may be a person's own plain clothes, or the space between a
  // person and what stands behind: a raised outline there could join them.
  if (o.offset_px <= 0 || gap * baseline_m / o.offset_px < params_.plain_raise_min_gap_m) return at_top;
  // Up from the top while the gap's row stays plain (at most a quarter of its columns features),
  // no higher than half the obstacle's height.
  const int highest = std::max(0, o.box.y - o.box.height / 2);
  int y = o.box.y - 1;
  for (; y >= highest; --y) {
    const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    int features = 0;
    for (int k = first; k != end; k += dir) features += lab[k] != kLabelNone;
    if (4 * features > gap) break;
  }
  if (y < highest) return at_top;
  const FaceTop raised{y, outlined(y, raised_hits_)};
  if (raised.outlined < params_.plain_min_outline_fraction * gap) return at_top;
  // The side reaches up there too: on at least a quarter of the rows between (any, when they are
  // within the outline's own +-2 rows), one of its plain_side_reach_px columns next to the gap
  // holds a feature matching at the offsets. A person standing before a plain wall does not.
  const int between = o.box.y - y - 1;
  if (between <= 2) {
    face_hits_.swap(raised_hits_);
    return raised;
  }
  int rows = 0;
  for (int r = y + 1; r < o.box.y; ++r) {
    const std::uint8_t* l = left.ptr<std::uint8_t>(r);
    const std::uint8_t* rr = right.ptr<std::uint8_t>(r);
    for (int k = 1; k <= params_.plain_side_reach_px; ++k) {
      const int c = first - dir * k;
      if (c >= 0 && c < left.cols && l[c] != 0 &&
          matchAt(l, rr, c, d0, d1, params_.grey_tolerance, params_.match_half_window_px, left.cols)) {
        ++rows;
        break;
      }
    }
  }
  if (4 * rows < between) return at_top;
  face_hits_.swap(raised_hits_);
  return raised;
}

bool ObstacleExtractor::atFoot(const GroundProfile& ground, const ObstacleCluster& o, int y, int x) const {
  const float contact = static_cast<float>(params_.plain_side_contact_px);
  if (contact < 0.0f || y < ground.horizon_row || y >= static_cast<int>(ground.offset_per_row.size())) return false;
  const float g = ground.groundOffsetAt(y, static_cast<float>(x));
  return std::isfinite(g) && std::fabs(g - static_cast<float>(o.offset_px)) <= contact;
}

int ObstacleExtractor::splitGroundLinks(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                        cv::Mat& labels, std::vector<ObstacleCluster>& obstacles,
                                        double baseline_m) {
  if (!params_.split_ground_links || !(baseline_m > 0.0)) return 0;
  const int cols = left.cols;
  const int min_link = params_.plain_side_reach_px + 1;
  int removed = 0;
  std::vector<int>& above = pixels_above_foot_;
  above.reserve(static_cast<std::size_t>(cols));  // no box is wider than the image
  link_parts_.reserve(static_cast<std::size_t>(cols));  // a part per column at most
  split_off_.clear();
  split_off_.reserve(static_cast<std::size_t>(std::max(0, params_.max_obstacles)));
  for (ObstacleCluster& o : obstacles) {
    if (o.offset_px <= 0 || !atOneOffset(o)) continue;
    // The obstacle's pixels above its foot, per column.
    above.assign(static_cast<std::size_t>(o.box.width), 0);
    for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
      const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
      for (int x = o.box.x; x < o.box.x + o.box.width; ++x)
        if (lab[x] == o.label && !atFoot(ground, o, y, x)) ++above[static_cast<std::size_t>(x - o.box.x)];
    }
    // Parts between links (runs of at least min_link columns without such pixels); the one with
    // the most pixels is the candidate.
    int best_a = -1, best_b = -1, best_n = 0, links = 0;
    link_parts_.clear();
    for (int k = 0; k < o.box.width;) {
      if (above[static_cast<std::size_t>(k)] == 0) {
        int e = k;
        while (e < o.box.width && above[static_cast<std::size_t>(e)] == 0) ++e;
        if (e - k >= min_link) ++links;
        k = e;
        continue;
      }
      // A part: columns with pixels, crossing runs shorter than min_link.
      int a = k, b = k, n = 0;
      for (int e = k, gap = 0; e < o.box.width && gap < min_link; ++e) {
        const int c = above[static_cast<std::size_t>(e)];
        if (c == 0) {
          ++gap;
          continue;
        }
        gap = 0;
        b = e;
        n += c;
      }
      if (n > best_n) {
        best_a = a;
        best_b = b;
        best_n = n;
      }
      link_parts_.push_back(LinkPart{a, b});
      k = b + 1;
    }
    if (links == 0 || best_a < 0) continue;
    const double metres_per_px = baseline_m / o.offset_px;
    const double width_m = (best_b - best_a + 1) * metres_per_px, height_m = o.box.height * metres_per_px;
    if (width_m < params_.link_min_part_width_m || width_m > params_.weak_max_width_m ||
        height_m < params_.weak_min_height_m || height_m > params_.weak_max_height_m ||
        best_b - best_a + 1 < params_.min_width_px)
      continue;
    // A plain face between two outlines: its upper outline runs across the links at the offset.
    const int d0 = std::max(0, o.offset_px - params_.offset_tolerance_px), d1 = o.offset_px + params_.offset_tolerance_px;
    int link_columns = 0, outlined = 0;
    const int margin = std::max(2, o.box.height / 8);
    const int inner_top = o.box.y + margin, inner_bottom = o.box.y + o.box.height - 1 - margin;
    for (int k = 0; k < o.box.width; ++k) {
      if (above[static_cast<std::size_t>(k)] != 0) continue;
      ++link_columns;
      // With `link_plain_outline`, only a plain column (at most a quarter of its inner rows
      // features) can be a face's: textured hills behind a link match along the top by chance.
      // In a face joined from parts found apart, with `link_face_pinning`, the column is plain when
      // few of its features pin an offset, as the joins judged it.
      if (params_.link_plain_outline) {
        const int x = o.box.x + k;
        const bool plain = params_.link_face_pinning && o.joined_parts
                               ? plainOfPinning(left, labels, x, inner_top, inner_bottom, params_.grey_tolerance)
                               : plainColumn(labels, x, inner_top, inner_bottom);
        if (!plain) continue;
      }
      outlined += outlineAt(left, right, o.box.y, o.box.x + k, d0, d1) ? 1 : 0;
    }
    if (outlined >= params_.plain_min_outline_fraction * link_columns) continue;
    // The other parts of a person's size are obstacles of their own (two people at one offset).
    if (params_.link_keep_parts) {
      for (const LinkPart& part : link_parts_) {
        if (part.a == best_a) continue;
        const int label = kLabelFirstObstacle + static_cast<int>(obstacles.size() + split_off_.size());
        if (label > 255 || static_cast<int>(obstacles.size() + split_off_.size()) >= params_.max_obstacles) break;
        const int x0 = o.box.x + part.a, x1 = o.box.x + part.b;
        int top = -1;
        for (int y = o.box.y; y < o.box.y + o.box.height && top < 0; ++y) {
          const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
          for (int x = x0; x <= x1; ++x)
            if (lab[x] == o.label) {
              top = y;
              break;
            }
        }
        if (top < 0) continue;
        const int bottom = o.box.y + o.box.height - 1;
        const double part_w = (x1 - x0 + 1) * metres_per_px, part_h = (bottom - top + 1) * metres_per_px;
        if (part_w < params_.link_min_part_width_m || part_w > params_.weak_max_width_m ||
            part_h < params_.weak_min_height_m || part_h > params_.weak_max_height_m || x1 - x0 + 1 < params_.min_width_px)
          continue;
        ObstacleCluster c = o;
        c.label = label;
        c.joined_parts = false;
        c.box = cv::Rect(x0, top, x1 - x0 + 1, bottom - top + 1);
        c.feature_count = 0;
        for (int y = top; y <= bottom; ++y) {
          std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
          for (int x = x0; x <= x1; ++x)
            if (lab[x] == o.label) {
              lab[x] = static_cast<std::uint8_t>(label);
              ++c.feature_count;
              --o.feature_count;
            }
        }
        split_off_.push_back(c);
      }
    }
    removed += o.box.width - (best_b - best_a + 1);
    narrowTo(o, o.box.x + best_a, o.box.x + best_b, labels);
  }
  obstacles.insert(obstacles.end(), split_off_.begin(), split_off_.end());
  return removed;
}

int ObstacleExtractor::trimPlainSides(const cv::Mat& left, cv::Mat& labels,
                                      std::vector<ObstacleCluster>& obstacles, const GroundProfile* ground) const {
  if (!params_.trim_plain_sides && !params_.trim_foot_skirt && !params_.drop_unpinned) return 0;
  if (left.type() != CV_8UC1 || labels.size() != left.size() || labels.type() != CV_8UC1)
    throw InputError("obstacles: feature and label images must be mono8 of the same size");
  const int cols = left.cols;
  const int tol = params_.grey_tolerance;
  // At the obstacle's foot the ground's offset is the obstacle's own: ground texture there matches
  // at that offset as well as the obstacle does, and pins nothing.
  auto atFoot = [&](const ObstacleCluster& o, int y, int x) { return ground && this->atFoot(*ground, o, y, x); };
  // Does column x hold a pixel of obstacle o whose horizontal neighbours differ by more than tol
  // (away from its foot)?
  auto pins = [&](const ObstacleCluster& o, int x) {
    if (x <= 0 || x >= cols - 1) return true;  // the image border: nothing to compare, keep
    for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
      if (labels.ptr<std::uint8_t>(y)[x] != o.label || !pinsOffset(left.ptr<std::uint8_t>(y), x, cols, tol)) continue;
      if (atFoot(o, y, x)) continue;
      return true;
    }
    return false;
  };
  // Does column x hold pixels of obstacle o at its foot, and above it none that pins the offset?
  // Ground texture at the foot matches at the obstacle's offset, and the ground's residue there
  // joins the obstacle as a skirt reaching sideways; a horizontal streak of it higher up matches
  // at any offset and pins nothing.
  auto skirtOnly = [&](const ObstacleCluster& o, int x) {
    int foot = 0;
    for (int y = o.box.y; y < o.box.y + o.box.height; ++y) {
      if (labels.ptr<std::uint8_t>(y)[x] != o.label) continue;
      if (atFoot(o, y, x)) ++foot;
      else if (pinsOffset(left.ptr<std::uint8_t>(y), x, cols, tol)) return false;
    }
    return foot > 0;
  };
  int trimmed = 0;
  for (ObstacleCluster& o : obstacles) {
    // Only obstacles at one offset: a face receding in depth has another foot in every column.
    if (params_.trim_foot_skirt && ground && atOneOffset(o)) {
      int a = o.box.x, b = o.box.x + o.box.width - 1;
      while (a < b && skirtOnly(o, a)) ++a;
      while (b > a && skirtOnly(o, b)) --b;
      if (b - a + 1 >= params_.min_width_px && (a != o.box.x || b != o.box.x + o.box.width - 1)) {
        trimmed += o.box.width - (b - a + 1);
        narrowTo(o, a, b, labels);
      }
    }
    if (params_.thin_min_aspect > 0.0 && o.box.height >= params_.thin_min_aspect * o.box.width) {
      // A thin obstacle (a pole, a post) fills its own columns top to bottom: side columns holding
      // less than thin_side_share of its fullest column's pixels are residue beside it (ground
      // texture near the horizon, chance matches of the hills), which the plain-side trim below,
      // limited to the outline's reach, leaves when they pin an offset.
      auto count = [&](int x) { return pixelsOf(labels, o, x, x); };
      int fullest = 0;
      for (int x = o.box.x; x < o.box.x + o.box.width; ++x) fullest = std::max(fullest, count(x));
      const double least = params_.thin_side_share * fullest;
      int a = o.box.x, b = o.box.x + o.box.width - 1;
      while (a < b && count(a) < least) ++a;
      while (b > a && count(b) < least) --b;
      if (a != o.box.x || b != o.box.x + o.box.width - 1) {
        trimmed += o.box.width - (b - a + 1);
        narrowTo(o, a, b, labels);
      }
    }
    if (params_.drop_unpinned && atOneOffset(o)) {
      // No column pins the offset: every match is a plain surround's or a level edge's, which
      // match at any offset alike; the obstacle is emptied (dropRemnants removes it).
      bool pinned = false;
      for (int x = o.box.x; x < o.box.x + o.box.width && !pinned; ++x) pinned = pins(o, x);
      if (!pinned) {
        trimmed += o.box.width;
        narrowTo(o, o.box.x, o.box.x - 1, labels);
        continue;
      }
    }
    if (!params_.trim_plain_sides) continue;
    // The columns [x0, x1] left when at most `reach` columns go from each side.
    auto trimmedTo = [&](int reach, int& x0, int& x1) {
      x0 = o.box.x;
      x1 = o.box.x + o.box.width - 1;
      while (x0 < std::min(x1, o.box.x + reach) && !pins(o, x0)) ++x0;
      const int right_stop = std::max(x0, o.box.x + o.box.width - 1 - reach);
      while (x1 > right_stop && !pins(o, x1)) --x1;
    };
    int x0 = 0, x1 = 0;
    trimmedTo(params_.plain_side_reach_px, x0, x1);
    // A tall obstacle at one offset (a person, a post) is no plain face whose level outlines the
    // reach protects: beside it, a horizontal streak of the ground or a plain surround pins
    // nothing however far it reaches. Its sides go as far as no column pins, while most of its
    // pixels stay (a far person's cluster is small, and its pins may be few).
    if (params_.tall_side_min_aspect > 0.0 && atOneOffset(o) &&
        o.box.height >= params_.tall_side_min_aspect * o.box.width) {
      int a = 0, b = 0;
      trimmedTo(o.box.width, a, b);
      const int kept = pixelsOf(labels, o, a, b);
      if (kept >= params_.tall_side_keep_share * o.feature_count && kept >= leastClusterFeatures()) {
        x0 = a;
        x1 = b;
      }
    }
    if (x0 == o.box.x && x1 == o.box.x + o.box.width - 1) continue;
    trimmed += o.box.width - (x1 - x0 + 1);
    narrowTo(o, x0, x1, labels);
  }
  return trimmed;
}

int ObstacleExtractor::claimUnassigned(const cv::Mat& left, const cv::Mat& right, cv::Mat& labels,
                                       const FloatingPart& f, int label) const {
  const int tol = params_.offset_tolerance_px;
  int claimed = 0;
  for (int y = f.box.y; y < f.box.y + f.box.height; ++y) {
    std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    const std::uint8_t* l = left.ptr<std::uint8_t>(y);
    const std::uint8_t* r = right.ptr<std::uint8_t>(y);
    for (int x = f.box.x; x < f.box.x + f.box.width; ++x) {
      if (lab[x] != kLabelUnassigned || !matchAt(l, r, x, std::max(0, f.min_offset - tol), f.max_offset + tol,
                                                 params_.grey_tolerance, params_.match_half_window_px, left.cols))
        continue;
      lab[x] = static_cast<std::uint8_t>(label);
      ++claimed;
    }
  }
  return claimed;
}

int ObstacleExtractor::joinStackedParts(const cv::Mat& left, const cv::Mat& right, cv::Mat& labels,
                                        std::vector<ObstacleCluster>& obstacles, double focal_baseline) const {
  if (!params_.join_stacked_parts || !(focal_baseline > 0.0)) return 0;
  const int tol = params_.offset_tolerance_px;
  int joins = 0;
  for (const FloatingPart& f : floating_) {
    const int bottom = f.box.y + f.box.height - 1;
    const int reach = std::max(params_.contact_tolerance_px, static_cast<int>(0.1 * f.box.height));
    for (ObstacleCluster& o : obstacles) {
      if (o.min_offset_px <= f.max_offset + tol) continue;  // the part below must be nearer
      if (focal_baseline / f.offset - focal_baseline / o.offset_px > params_.stacked_max_depth_m) continue;
      if (std::abs(o.box.y - bottom) > reach) continue;    // resting on its top
      if (std::min(o.box.x + o.box.width, f.box.x + f.box.width) <= std::max(o.box.x, f.box.x)) continue;
      // The part's pixels (the rejection left them unassigned) that match at its offsets join.
      o.feature_count += claimUnassigned(left, right, labels, f, o.label);
      o.box |= f.box;
      o.min_offset_px = std::min(o.min_offset_px, f.min_offset);
      ++joins;
      break;
    }
  }
  return joins;
}

int ObstacleExtractor::keepHiddenFeet(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                      cv::Mat& labels, std::vector<ObstacleCluster>& obstacles,
                                      double baseline_m) const {
  // Only a measured ground line says where the ground would show: on weak texture it shows little anywhere.
  if (!params_.keep_hidden_feet || ground.source != GroundSource::kHough || !(baseline_m > 0.0)) return 0;
  requireMono8Pair(left, right, labels);
  const int tol = params_.offset_tolerance_px;
  int kept = 0;
  for (const FloatingPart& f : floating_) {
    if (static_cast<int>(obstacles.size()) >= params_.max_obstacles) break;
    // Taken in since by an obstacle at its offsets (a cabin joined to its body).
    bool taken = false;
    for (const ObstacleCluster& o : obstacles)
      taken |= atOffsetsOf(f.offset, o, tol) && overlapOfSmaller(o.box, f.box) >= params_.merge_overlap;
    if (taken) continue;
    // Short parts are left alone: chance matches far above their contact, a person's arm.
    if (f.box.height * baseline_m / std::max(1, f.offset) < params_.weak_min_height_m) continue;
    // Below the part, down to its contact row, the ground (or the background) shows unless
    // something nearer hides it: its matched pixels there are few.
    const int bottom = f.box.y + f.box.height - 1;
    int last = bottom;
    long below = 0, area = 0;
    for (int x = f.box.x; x < f.box.x + f.box.width; ++x) {
      const int contact = std::min(contactRowAt(f.offset, x), labels.rows - 1);
      last = std::max(last, contact);
      for (int y = bottom + 1; y <= contact; ++y) {
        below += groundOrBackground(labels.ptr<std::uint8_t>(y)[x]);
        ++area;
      }
    }
    if (area == 0 || static_cast<double>(below) > params_.hidden_foot_max_behind * static_cast<double>(area)) continue;
    // ... while across the image, on the same rows, they are many (the ground there is textured).
    long across = 0;
    for (int y = bottom + 1; y <= last; ++y) across += groundOrBackgroundInRow(labels, y);
    if (static_cast<double>(across) <
        params_.hidden_foot_min_behind_across * static_cast<double>(last - bottom) * labels.cols)
      continue;
    // An obstacle of its own: its pixels (the rejection left them unassigned) that match at its offsets.
    const int label = kLabelFirstObstacle + static_cast<int>(obstacles.size());
    if (label > 255) break;
    ObstacleCluster c;
    c.label = label;
    c.offset_px = f.offset;
    c.min_offset_px = f.min_offset;
    c.max_offset_px = f.max_offset;
    c.box = f.box;
    c.feature_count = claimUnassigned(left, right, labels, f, label);
    // Later obstacles took most of its pixels: it is theirs.
    if (c.feature_count < std::min(params_.min_cluster_features, params_.weak_cluster_features)) {
      LabelMap back = unchangedLabels();
      back[static_cast<std::size_t>(label)] = kLabelUnassigned;
      relabel(labels, back, f.box);
      continue;
    }
    obstacles.push_back(c);
    ++kept;
  }
  return kept;
}

int ObstacleExtractor::joinPlainFaces(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                      cv::Mat& labels, std::vector<ObstacleCluster>& obstacles, double baseline_m,
                                      bool late) {
  // Where the ground line was not measured (its texture too weak), a plain gap beside an obstacle
  // may be that ground: only two sides at one offset, with the top outline across the gap and a
  // textured surround, are joined there; one-sided faces, receding faces and parts across a nearer
  // obstacle need the measured line.
  const bool measured_ground = ground.source == GroundSource::kHough;
  if (!params_.join_plain_faces || baseline_m <= 0.0) return 0;
  requireMono8Pair(left, right, labels);
  const int cols = left.cols;
  const int tol = params_.offset_tolerance_px;
  hidden_columns_.reserve(static_cast<std::size_t>(cols));  // any gap is narrower than the image
  face_hits_.reserve(static_cast<std::size_t>(cols));
  raised_hits_.reserve(static_cast<std::size_t>(cols));
  // A nearer part `a` with a farther face on one side (`face_left`) stands in front of that face,
  // and is not its end, when another part `g` of the face lies beyond `a` on the other side: at an
  // offset in [g_lo, g_hi], its top within `slack` rows of the face's `top`, of the face's height
  // in metres (`height_m`; not tested when 0), the face from column `outer` to g's far edge no
  // wider than plain_max_width_m, and at least three quarters of the columns between `a` and `g`
  // plain over rows ya..yb (the side's dilated edge may take a column or two).
  auto faceBeyond = [&](const ObstacleCluster& a, const ObstacleCluster* f, bool face_left, int g_lo, int g_hi,
                        int top, int slack, int outer, int ya, int yb, double height_m) {
    const int a_end = a.box.x + a.box.width;  // exclusive
    for (const ObstacleCluster& g : obstacles) {
      if (&g == &a || &g == f || g.offset_px < std::max(1, g_lo) || g.offset_px > g_hi) continue;
      const int g_end = g.box.x + g.box.width;
      if (face_left ? g.box.x < a_end : g_end > a.box.x) continue;  // beyond a, away from the face
      if (std::abs(g.box.y - top) > slack) continue;                  // the face's top outline
      const double hg = g.box.height * baseline_m / g.offset_px;
      if (height_m > 0.0 && std::max(height_m, hg) > (1.0 + params_.plain_height_tolerance) * std::min(height_m, hg))
        continue;
      const int far_edge = face_left ? g_end - 1 : g.box.x;
      if ((std::abs(far_edge - outer) + 1) * baseline_m / g.offset_px > params_.plain_max_width_m) continue;
      int between = 0, plain_columns = 0;
      for (int x = face_left ? a_end : g_end; x < (face_left ? g.box.x : a.box.x); ++x) {
        ++between;
        plain_columns += plainColumn(labels, x, ya, yb);
      }
      if (4 * plain_columns >= 3 * between) return true;
    }
    return false;
  };
  int joins = 0;
  // The joins beside each obstacle. `second` (the late call): only one-sided faces.
  auto besideJoins = [&](bool second) {
    for (std::size_t i = 0; i < obstacles.size(); ++i) {
      for (const int dir : {+1, -1}) {
        const ObstacleCluster& a = obstacles[i];
        // An edge (near_end_min_aspect) found alone is a receding face's near end rather than a
        // face at one offset: the face's offset changes along it.
        if (second && isEdge(a)) continue;
        const int d_lo = std::max(1, a.min_offset_px - tol);
        const int d_hi = a.max_offset_px + tol;
        // The face's inner rows: the obstacle's rows without their top and bottom outline.
        const int margin = std::max(2, a.box.height / 8);
        const int y0 = a.box.y + margin, y1 = a.box.y + a.box.height - 1 - margin;
        const int inner = y1 - y0 + 1;
        if (inner <= 0) continue;
        // Features of column x's inner rows; with `pinning`, also those of them that pin an offset
        // (a horizontal edge, a window's or a panel's outline on a plain face, matches at every
        // offset and tells no depth).
        auto featuresIn = [&](int x, int* pinning = nullptr) {
          int n = 0;
          for (int y = y0; y <= y1; ++y) {
            if (labels.ptr<std::uint8_t>(y)[x] == kLabelNone) continue;
            ++n;
            if (pinning && pinsOffset(left.ptr<std::uint8_t>(y), x, cols, params_.grey_tolerance)) ++*pinning;
          }
          return n;
        };
        auto matches = [&](int y, int x) {
          return matchAt(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x, d_lo, d_hi, params_.grey_tolerance,
                         params_.match_half_window_px, cols);
        };
        // A column is plain when at most a quarter of its inner rows are features.
        auto plain = [&](int f) { return 4 * f <= inner; };
        // The gap: plain columns beside the obstacle, up to plain_max_width_m at its offset.
        const int max_gap = static_cast<int>(params_.plain_max_width_m * a.offset_px / baseline_m);
        const int first = dir > 0 ? a.box.x + a.box.width : a.box.x - 1;
        int x = first, features = 0, pinning = 0;
        for (; x >= 0 && x < cols && std::abs(x - first) <= max_gap; x += dir) {
          int p = 0;
          const int f = featuresIn(x, &p);
          if (!plain(f)) break;
          features += f;
          pinning += p;
        }
        const int gap = std::abs(x - first);
        if (gap == 0) continue;
        if (pinning > params_.plain_max_feature_fraction * inner * gap) continue;
        // The face's top outline: the obstacle's top row, or, when the gap's columns hold no matching
        // outline there, the first row above it at which the gap stops being plain (a side whose upper
        // part the removal took against the background: the face is plain up to its top).
        auto topOf = [&]() { return faceTop(left, right, labels, a, first, x, dir, d_lo, d_hi, baseline_m); };
        // Features (count, columns) in the `beyond` columns past the obstacle's near side, and past
        // column `far` on the other side when there is one (far >= 0).
        const int near_end = dir > 0 ? a.box.x - 1 : a.box.x + a.box.width;
        auto featuresBeside = [&](int beyond, int far) {
          int outside = 0, outside_columns = 0;
          for (int k = 0; k < beyond; ++k) {
            for (const int c : {near_end - dir * k, far >= 0 ? far + dir * (k + 1) : -1}) {
              if (c < 0 || c >= cols) continue;
              outside += featuresIn(c);
              ++outside_columns;
            }
          }
          return std::pair<int, int>{outside, outside_columns};
        };
        // One side only (the far side hidden, at the image border or not a face's): the face
        // reaches as far as its top outline keeps matching in most columns.
        auto oneSided = [&]() {
          // Without a far side, horizontal edges in the gap may be a receding face's texture (its
          // offset changes along it): only a gap plain of every feature is taken at one offset.
          // The late call, after the receding joins, takes any gap of plain columns (its features
          // the horizontal edges of a vehicle's side seen at an angle), where it hides the terrain
          // that shows elsewhere: across the image, the face's inner rows hold
          // hidden_min_terrain_fraction of ground and background features or more (on weakly
          // textured ground a featureless stretch beside an obstacle is that ground).
          if (!measured_ground || !params_.plain_one_sided) return false;
          if (!second) {
            if (features > params_.plain_max_feature_fraction * inner * gap) return false;
          } else {
            long terrain = 0;
            for (int y = y0; y <= y1; ++y) {
              int& seen = seen_in_row_[static_cast<std::size_t>(y)];  // counted when first needed
              if (seen < 0) seen = groundOrBackgroundInRow(labels, y);
              terrain += seen;
            }
            if (static_cast<double>(terrain) < params_.hidden_min_terrain_fraction * inner * cols) return false;
          }
          const int top = topOf().row;
          int hits = 0, end = -1;
          for (int k = first, j = 0; k != x; k += dir, ++j) {
            if (!face_hits_[static_cast<std::size_t>(j)]) continue;
            ++hits;
            if (hits >= params_.plain_min_outline_fraction * (std::abs(k - first) + 1)) end = k;
          }
          if (end < 0 || std::abs(end - first) + 1 < std::max(8, a.box.width)) return false;
          // In the late call the gap holds a pixel pinning an offset (a corner, a wheel, a window's
          // side): level streaks alone tell no depth, and may be the top of a plain box farther
          // behind.
          if (second) {
            bool pinned = false;
            for (int k = first; k != end + dir && !pinned; k += dir)
              for (int y = y0; y <= y1 && !pinned; ++y)
                pinned = labels.ptr<std::uint8_t>(y)[k] != kLabelNone &&
                         pinsOffset(left.ptr<std::uint8_t>(y), k, cols, params_.grey_tolerance);
            if (!pinned) return false;
          }
          const auto [outside, outside_columns] =
              featuresBeside(std::min(std::abs(end - first) + 1, 2 * a.box.width), -1);
          if (outside_columns == 0 || outside < kPlainSurroundFraction * outside_columns * inner) return false;
          const cv::Rect reach = a.box | cv::Rect(std::min(first, end), top, std::abs(end - first) + 1, 1);
          foldInto(i, reach, a.min_offset_px - tol - 1, a.max_offset_px + tol + 1, labels, obstacles);
          return true;
        };
        if (x < 0 || x >= cols || gap > max_gap) {
          joins += oneSided() ? 1 : 0;
          continue;
        }
        // The far side: the columns after the gap whose features mostly match at the offsets.
        int far = x - dir;
        for (int k = x; k >= 0 && k < cols && std::abs(k - x) < std::max(a.box.width, 8); k += dir) {
          const int f = featuresIn(k);
          if (plain(f)) break;
          int matched = 0;
          for (int y = y0; y <= y1; ++y) matched += matches(y, k);
          if (matched < params_.min_match_fraction * f) break;
          far = k;
        }
        if (far == x - dir) {
          joins += oneSided() ? 1 : 0;
          continue;
        }
        if (second) continue;
        // The top outline continues the obstacle's top: most gap columns hold, within 2 rows of
        // it, a feature matching at the offsets.
        const FaceTop top = topOf();
        // The gap is plain where the same rows beyond both sides are not: something hides what
        // is behind it (on ground without texture a plain gap may be the ground itself).
        const auto [outside, outside_columns] = featuresBeside(std::min(gap, 2 * a.box.width), far);
        if (top.outlined < params_.plain_min_outline_fraction * gap) continue;
        if (outside < kPlainSurroundFraction * outside_columns * inner) continue;
        // A side farther than `a` (within the offsets the far side matched at) continuing the face
        // beyond it: `a` stands in front of the face (a person before a wall whose far end is found).
        if (params_.front_of_face && faceBeyond(a, nullptr, dir < 0, d_lo - 1, a.offset_px - tol - 1, top.row,
                                                std::max(2, a.box.height / 8), far, y0, y1, 0.0))
          continue;
        // Joined: the box spans the far side, and obstacles there at the same offsets fold into it.
        cv::Rect reach = a.box | cv::Rect(std::min(x, far), top.row, std::abs(far - x) + 1, 1);
        foldInto(i, reach, a.min_offset_px - tol - 1, a.max_offset_px + tol + 1, labels, obstacles);
        ++joins;
      }
    }
  };
  if (late) {
    if (!params_.plain_late_one_sided) return 0;
    // The joins relabel obstacles only: each row's ground and background count holds throughout.
    seen_in_row_.assign(static_cast<std::size_t>(left.rows), -1);
    besideJoins(true);
    return joins;
  }
  besideJoins(false);
  // Faces receding in depth (a long wall seen at an angle): a near part `a` and a far part `f`
  // at a smaller offset with a gap between them (a wall plain where near and textured far away,
  // or a textured wall whose matches held over a few offsets at a time, so the growth over
  // offsets stopped). The face is a vertical plane standing on the ground: its offset changes
  // linearly along it, its top and bottom outlines are straight lines, and its height in metres
  // is the same at both parts. They are one face when most features over both, between the
  // outlines through their centres, match the offset line through their centres, and the gap
  // is the face's: textured with features matching the line rather than what is behind, or
  // plain with its top outline matching and textured surroundings.
  auto receding = [&](const ObstacleCluster& a, const ObstacleCluster& f) {
    const double da = a.offset_px, df = f.offset_px;
    if (df < 1.0 || da <= df) return false;
    const int a_end = a.box.x + a.box.width, f_end = f.box.x + f.box.width;  // exclusive
    const int gap = std::max(a.box.x, f.box.x) - std::min(a_end, f_end);   // negative: overlap
    if (gap < 1 || gap * baseline_m / df > params_.plain_max_width_m) return false;
    const double ha = a.box.height * baseline_m / da, hf = f.box.height * baseline_m / df;
    if (std::max(ha, hf) > (1.0 + params_.plain_height_tolerance) * std::min(ha, hf)) return false;
    const double ca = a.box.x + 0.5 * (a.box.width - 1), cf = f.box.x + 0.5 * (f.box.width - 1);
    if (std::abs(cf - ca) < 1.0) return false;
    if (params_.front_of_face) {
      const bool f_left = f.box.x < a.box.x;
      const int m = std::max(2, f.box.height / 8);
      if (faceBeyond(a, &f, f_left, f.offset_px - tol - 1, f.offset_px + tol + 1, f.box.y, m,
                     f_left ? f.box.x : f.box.x + f.box.width - 1, f.box.y + m, f.box.y + f.box.height - 1 - m, hf))
        return false;
    }
    // The columns: the offset line, the outlines through the parts' tops and bottoms, and the
    // features between them (the counts the verdict needs are known before any matching).
    std::vector<FaceColumn>& columns = face_columns_;
    columns.clear();
    int features_total = 0, gap_features_total = 0, gap_area = 0;
    for (int x = std::min(a.box.x, f.box.x); x < std::max(a_end, f_end); ++x) {
      const double t = (x - ca) / (cf - ca);
      const double d = da + t * (df - da);
      if (d < 1.0) continue;
      FaceColumn c;
      c.x = x;
      c.top = static_cast<int>(std::lround(a.box.y + t * (f.box.y - a.box.y)));
      c.bottom = static_cast<int>(
          std::lround(a.box.y + a.box.height - 1 + t * (f.box.y + f.box.height - a.box.y - a.box.height)));
      c.d0 = static_cast<int>(std::floor(d)) - tol;
      c.d1 = static_cast<int>(std::ceil(d)) + tol;
      c.margin = std::max(2, (c.bottom - c.top + 1) / 8);
      c.in_gap = (x >= a_end || x < a.box.x) && (x >= f_end || x < f.box.x);
      c.features = featuresInColumn(labels, x, c.top, c.bottom);
      features_total += c.features;
      if (c.in_gap) {
        gap_features_total += c.features;
        gap_area += std::max(0, c.bottom - c.top + 1 - 2 * c.margin);
      }
      columns.push_back(c);
    }
    if (features_total == 0) return false;
    const double frac = params_.min_match_fraction;
    // A textured gap (the face's own texture): most of its features match the offset line and
    // not the ground or background behind them.
    const bool gap_textured = gap_features_total >= kPlainSurroundFraction * gap_area;
    int features = 0, matched = 0, gap_other = 0, outlined = 0, gap_features = 0, gap_matched = 0;
    bool blocked = false;
    // Gap columns first: once the gap is blocked and cannot be a textured face, or the matches
    // cannot reach their share whatever the columns left hold, the verdict is known.
    auto decided = [&]() {
      if (matched + (features_total - features) < frac * features_total) return true;
      return blocked && (!gap_textured || gap_matched + (gap_features_total - gap_features) < frac * gap_features_total);
    };
    for (const bool gap_pass : {true, false})
      for (const FaceColumn& c : columns) {
        if (c.in_gap != gap_pass) continue;
        const int x = c.x;
        auto onFace = [&](int y) {
          return matchAt(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x, c.d0, c.d1, params_.grey_tolerance,
                         params_.match_half_window_px, cols);
        };
        int other = 0, column_matched = 0;
        for (int y = std::max(0, c.top); y <= std::min(left.rows - 1, c.bottom); ++y) {
          if (labels.ptr<std::uint8_t>(y)[x] == kLabelNone) continue;
          const bool m = onFace(y);
          matched += m;
          other += !m && y >= c.top + c.margin && y <= c.bottom - c.margin;
          // In a textured gap, a match that the ground or background behind explains as well is no evidence.
          if (m && c.in_gap) {
            const int b = offsetBehind(ground, y, x);
            column_matched += b < 0 || b >= c.d0 - 1 ||
                              !matchAt(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x, b - tol, b + tol,
                                       params_.grey_tolerance, params_.match_half_window_px, cols);
          }
        }
        features += c.features;
        if (c.in_gap) {
          const int rows_in = std::max(0, c.bottom - c.top + 1 - 2 * c.margin);
          blocked |= 4 * other > rows_in;  // something in front of a plain face, or no face
          gap_features += c.features;
          gap_matched += column_matched;
          gap_other += other;
          bool hit = false;
          for (int y = std::max(0, c.top - 2); y <= std::min(left.rows - 1, c.top + 2) && !hit; ++y) hit = onFace(y);
          outlined += hit;
        }
        if (decided()) return false;
      }
    if (matched < frac * features) return false;
    // A gap full of features that hardly pin an offset is level streaks of the ground (seen beside
    // a person, in the band left of him that the right camera cannot see): they match the line's
    // offsets as well as any other, and show neither the face's texture nor a plain face.
    if (gap_textured) {
      int gap_pinning = 0;
      for (const FaceColumn& c : columns)
        if (c.in_gap) gap_pinning += pinningInColumn(left, labels, c.x, c.top, c.bottom, params_.grey_tolerance);
      if (gap_pinning < params_.textured_gap_min_pinning * gap_features) return false;
    }
    // A textured gap is the face's only when its features match the line rather than what lies
    // behind: ground streaks between a person and a farther object match the line's offsets by
    // chance, and would pass for a plain gap's outline below.
    if (gap_textured && gap_matched >= frac * gap_features) return true;
    if (gap_textured && params_.textured_gap_not_plain) return false;
    // A plain gap: nothing in it that does not match the line, ...
    if (blocked) return false;
    // ... its top outline matching, and the rows both parts share textured beyond them: the
    // plain gap hides something (far ground near the horizon is plain too).
    const bool f_left = cf < ca;
    const int dir = f_left ? -1 : +1;
    const int ya = std::max(a.box.y, f.box.y), yb = std::min(a.box.y + a.box.height, f.box.y + f.box.height) - 1;
    const int m = std::max(2, (yb - ya + 1) / 8);
    const int beyond = std::min(gap, 2 * std::max(a.box.width, f.box.width));
    const int a_out = f_left ? a_end : a.box.x - 1;  // first column beyond each part
    const int f_out = f_left ? f.box.x - 1 : f_end;
    int beside = 0, beside_area = 0;
    for (int y = ya + m; y <= yb - m; ++y) {
      const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
      for (int k = 0; k < beyond; ++k) {
        for (const int c : {a_out - dir * k, f_out + dir * k}) {
          if (c < 0 || c >= cols) continue;
          beside += lab[c] != kLabelNone;
          ++beside_area;
        }
      }
    }
    return gap_area > 0 && gap_other <= params_.plain_max_feature_fraction * gap_area &&
           outlined >= params_.plain_min_outline_fraction * gap && beside >= kPlainSurroundFraction * beside_area;
  };
  // One object seen on both sides of a nearer one (a vehicle behind a pedestrian): two parts at
  // the same offsets, of the same height in metres, sharing most rows, with every column between
  // them either hidden (behind a nearer obstacle, or in the band left of it that the right camera
  // cannot see past it) or plain, and most of them hidden.
  auto acrossNearer = [&](const ObstacleCluster& a, const ObstacleCluster& b) {
    const int a_end = a.box.x + a.box.width;  // exclusive
    if (b.box.x <= a_end) return false;       // b lies right of a, with a gap
    if (b.min_offset_px > a.max_offset_px + tol + 1 || a.min_offset_px > b.max_offset_px + tol + 1) return false;
    const double d = 0.5 * (a.offset_px + b.offset_px);
    if (d < 1.0 || a.offset_px < 1 || b.offset_px < 1) return false;
    if ((b.box.x + b.box.width - a.box.x) * baseline_m / d > params_.plain_max_width_m) return false;
    const double ha = a.box.height * baseline_m / a.offset_px, hb = b.box.height * baseline_m / b.offset_px;
    if (std::max(ha, hb) > (1.0 + params_.plain_height_tolerance) * std::min(ha, hb)) return false;
    const int ya = std::max(a.box.y, b.box.y), yb = std::min(a.box.y + a.box.height, b.box.y + b.box.height) - 1;
    if (2 * (yb - ya + 1) < std::min(a.box.height, b.box.height)) return false;
    const int m = std::max(2, (yb - ya + 1) / 8);
    const int inner = yb - ya + 1 - 2 * m;
    if (inner <= 0) return false;
    const int nearer_than = std::max(a.max_offset_px, b.max_offset_px) + tol + 1;
    const int gap = b.box.x - a_end;
    std::vector<std::uint8_t>& hidden = hidden_columns_;
    hidden.assign(static_cast<std::size_t>(gap), 0);
    for (const ObstacleCluster& o : obstacles) {
      if (o.min_offset_px <= nearer_than || o.box.y > yb || o.box.y + o.box.height - 1 < ya) continue;
      const int band = std::max(0, static_cast<int>(std::lround(o.offset_px - d)));
      for (int x = std::max(o.box.x - band, a_end); x < std::min(o.box.x + o.box.width, b.box.x); ++x)
        hidden[static_cast<std::size_t>(x - a_end)] = 1;
    }
    int n_hidden = 0;
    for (int x = a_end; x < b.box.x; ++x) {
      if (hidden[static_cast<std::size_t>(x - a_end)]) {
        ++n_hidden;
        continue;
      }
      // Neither hidden nor plain: something else stands there.
      if (!plainColumn(labels, x, ya + m, yb - m)) return false;
    }
    return 2 * n_hidden >= gap;
  };
  for (bool joined = measured_ground; joined;) {
    joined = false;
    for (std::size_t i = 0; i < obstacles.size() && !joined; ++i)
      for (std::size_t j = 0; j < obstacles.size() && !joined; ++j) {
        if (i == j || !receding(obstacles[i], obstacles[j])) continue;
        // The earlier (stronger) part keeps its label; the other, and what lies inside it at its
        // offsets, folds into it (an obstacle in front of the face stays apart).
        std::size_t keep = std::min(i, j);
        const ObstacleCluster& other = obstacles[i + j - keep];
        const cv::Rect reach = other.box;
        foldInto(keep, reach, other.min_offset_px - tol - 1, other.max_offset_px + tol + 1, labels, obstacles);
        joined = true;
        ++joins;
      }
  }
  for (bool joined = params_.join_across_nearer && measured_ground; joined;) {
    joined = false;
    for (std::size_t i = 0; i < obstacles.size() && !joined; ++i)
      for (std::size_t j = 0; j < obstacles.size() && !joined; ++j) {
        if (i == j || !acrossNearer(obstacles[i], obstacles[j])) continue;
        // The earlier (stronger) part keeps its label; the nearer obstacle stays apart.
        std::size_t keep = std::min(i, j);
        const cv::Rect reach = obstacles[i].box | obstacles[j].box;
        const ObstacleCluster& other = obstacles[i + j - keep];
        foldInto(keep, reach, other.min_offset_px - tol - 1, other.max_offset_px + tol + 1, labels, obstacles);
        joined = true;
        ++joins;
      }
  }
  return joins;
}

int ObstacleExtractor::growAlongTopOutline(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                           cv::Mat& labels, std::vector<ObstacleCluster>& obstacles,
                                           double baseline_m) {
  // Plain faces receding to the image border (a long wall seen at an angle, its near end out of
  // view): only a part near its far end is found, and nothing past it shows texture. A vertical
  // face standing on the ground with a level top has, along the row, an offset that changes
  // linearly and a top outline at contact(d) - H d / B (H its height in metres), so one offset
  // slope k and one height H (from the top row at the part) predict the outline in every column.
  // The part grows to the border when, for some (k, H), the predicted outline holds a feature
  // matching the predicted offset in most columns, the face below it is plain, the outline
  // slants and the offset changes (a level line such as the horizon matches at any offset), and
  // the outline runs out of the image (no far side was found).
  if (!params_.join_plain_faces || !params_.plain_outline_faces || baseline_m <= 0.0 ||
      ground.source != GroundSource::kHough || ground.offset_per_row.empty())
    return 0;
  requireMono8Pair(left, right, labels);
  const int cols = left.cols;
  const int tol = params_.offset_tolerance_px;
  outline_hits_.reserve(static_cast<std::size_t>(cols));  // one entry per tested column
  int joins = 0;
  const int rows = left.rows;
  const int max_offset = static_cast<int>(row_limit_.size()) - 1;
  // Contact rows below the image: the ground line continued with its slope over the last rows.
  constexpr int kSlopeRows = 20;
  const float g_last = ground.offset_per_row.back();
  const float g_prev = rows > kSlopeRows ? ground.offset_per_row[static_cast<std::size_t>(rows - 1 - kSlopeRows)] : g_last;
  const double slope_last =
      std::isfinite(g_last) && std::isfinite(g_prev) ? static_cast<double>(g_last - g_prev) / kSlopeRows : 0.0;
  auto contactOf = [&](double d, int x) {
    const int di = static_cast<int>(std::lround(d));
    const int c = contactRowAt(di, x);
    if (c < rows || slope_last <= 1e-3) return static_cast<double>(c);
    return rows - 1 + static_cast<double>(groundRelative(di, x) - g_last) / slope_last;
  };
  // Pixel (y, x) matches the face's offset d there (+- the tolerance and one more).
  auto onFaceAt = [&](int y, int x, double d) {
    return matchAt(left.ptr<std::uint8_t>(y), right.ptr<std::uint8_t>(y), x, static_cast<int>(std::floor(d)) - tol - 1,
                   static_cast<int>(std::ceil(d)) + tol + 1, params_.grey_tolerance, params_.match_half_window_px, cols);
  };
  auto outlineHit = [&](int x, double yt, double d) {
    const int yc = static_cast<int>(std::lround(yt));
    for (int y = std::max(0, yc - 2); y <= std::min(rows - 1, yc + 2); ++y)
      if (onFaceAt(y, x, d)) return true;
    return false;
  };
  struct Outline {
    double k = 0.0, h = 0.0, frac = 0.0;
    int end = -1, tested = 0;
  };
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    for (const int dir : {+1, -1}) {
      const ObstacleCluster& a = obstacles[i];
      const int da = a.offset_px;
      if (da < 2) continue;
      // A part of a person's size is taken for a person, not for the end of a face.
      if (a.box.height * baseline_m / da <= params_.weak_max_height_m &&
          a.box.width * baseline_m / da <= params_.weak_max_width_m)
        continue;
      const int xs = dir > 0 ? a.box.x + a.box.width - 1 : a.box.x;
      const int n_cols = dir > 0 ? cols - 1 - xs : xs;
      // A wide part (much of the face's far half textured) may leave fewer columns to the border
      // than its own width; the outline's hypotheses are tested over those columns all the same.
      const double walk_widths = params_.plain_outline_min_walk_widths * a.box.width;
      if (n_cols < std::max(16.0, walk_widths)) continue;
      // Plain beside the part over its rows (plain_outline_min_plain_columns of the next 8): the
      // face shows little texture there. (The part's own side may reach a few columns past its
      // box: the plain area below the outline, tested with each hypothesis, is what tells.)
      int plain_columns = 0;
      for (int j = 1; j <= 8; ++j)
        plain_columns += plainColumn(labels, xs + dir * j, a.box.y, a.box.y + a.box.height - 1);
      if (plain_columns < params_.plain_outline_min_plain_columns) continue;
      // The face's offset at the part's side: the part's own (its dominant offset) for a face out
      // of view; for one ending in view the part's nearest offset (a receding part is nearest
      // at the side the walk leaves from, and its dominant offset may lie several pixels below).
      int d_side = da;
      double ca = contactOf(d_side, xs);
      Outline best;
      // One hypothesis: the face's top at the part in row ys, its offset slope k.
      int best_ys = -1;
      // Below the outline at column x (offset d there): the face's rows without a margin at its
      // top and foot (none when y1 < y0).
      struct FaceRows {
        int y0, y1;
        long count() const { return std::max(0, y1 - y0 + 1); }
      };
      auto faceRows = [&](int x, double d, double h) {
        const double c = contactOf(d, x);
        const double yt = c - h * d / baseline_m;
        const int m = std::max(2, static_cast<int>((c - yt) / 8));
        return FaceRows{std::max(0, static_cast<int>(std::lround(yt)) + m),
                        std::min(rows - 1, static_cast<int>(std::lround(c)) - m)};
      };
      // How many of the features in those rows do not match d, counted on top of `other` until it
      // exceeds `cap` (the verdicts only ask whether it does).
      auto foreignBelow = [&](int x, double d, const FaceRows& face, long& other, long cap) {
        for (int y = face.y0; y <= face.y1 && other <= cap; ++y) {
          if (labels.ptr<std::uint8_t>(y)[x] == kLabelNone) continue;
          other += !onFaceAt(y, x, d);
        }
      };
      // With `in_view`, a face that ends inside the image (its near end in view): the walk's
      // outline goes on past the end over the ground and the hills, where features match the
      // predicted offset by chance in about half the columns, so the end is where the face
      // below the outline gives way to texture (two sampled columns in a row where more than
      // half of the rows are features not matching the face's offset), at the
      // last outline hit before it, and a vertical outline there (the face's near end) must
      // match the end's offset over at least plain_near_end_edge_share of the face's rows.
      auto evaluate = [&](int ys, double k, bool in_view) {
        if (ys < 0 || ys > a.box.y + 2) return;
        const double h = (ca - ys) * baseline_m / d_side;
        if (h < 0.5) return;
        Outline o{k, h, 0.0, -1, 0};
        int hits = 0;
        bool out_of_view = false;  // the outline reached the image's side or top
        outline_hits_.clear();
        for (int j = 2; j <= n_cols; j += 2) {  // every second column
          const double d = d_side + k * j;
          if (d > max_offset) break;
          const int x = xs + dir * j;
          const double yt = contactOf(d, x) - h * d / baseline_m;
          if (yt < 2.0) {
            out_of_view = true;
            break;
          }
          out_of_view = j + 2 > n_cols;
          ++o.tested;
          const bool hit = outlineHit(x, yt, d);
          outline_hits_.push_back(hit ? 1 : 0);
          if (hit) {
            ++hits;
            o.end = x;
          }
          if (o.tested % 20 == 0 && 5 * hits < 2 * o.tested) break;  // below 40 %: hopeless
          // A face out of view is judged on its whole walk: once its share would stay below the
          // share needed, or below the best one's, even with a hit in every remaining column, it
          // cannot be taken.
          if (!in_view && o.tested % 8 == 0) {
            const int remaining = (n_cols - j) / 2;
            const double bound = static_cast<double>(hits + remaining) / (o.tested + remaining);
            if (bound < params_.plain_min_outline_fraction || bound < best.frac) return;
          }
        }
        if (o.end < 0) return;
        // The outline's share and shape (checked before the costlier tests of the face):
        // enough of it matched and more than the best so far, an offset that changes and an
        // outline that slants from `tested` columns ending at column `end`.
        auto shapeHolds = [&](int tested, int hit_count, int end) {
          const double frac = static_cast<double>(hit_count) / tested;
          if (frac < params_.plain_min_outline_fraction || frac < best.frac ||
              (frac == best.frac && tested <= best.tested))
            return false;
          const int j_end = std::abs(end - xs);
          const double d_end = d_side + k * j_end;
          const double top_s = ca - h * d_side / baseline_m;
          const double top_e = contactOf(d_end, end) - h * d_end / baseline_m;
          return d_end - d_side >= 3.0 && std::abs(top_e - top_s) >= std::max(6.0, 0.05 * j_end);
        };
        if (!in_view) {
          if (!out_of_view || o.tested < std::max(8.0, walk_widths / 2) || !shapeHolds(o.tested, hits, o.end)) return;
        } else {
          // The last tested column before `limit` that is a hit with enough of the outline
          // matched up to it (-1 when none), and the hits up to it.
          const int n_tested = static_cast<int>(outline_hits_.size());
          auto lastQualifying = [&](int limit, int& hits_up_to) {
            int last = -1;
            for (int t = 0, run = 0; t < limit; ++t) {
              run += outline_hits_[static_cast<std::size_t>(t)];
              if (outline_hits_[static_cast<std::size_t>(t)] && run >= params_.plain_min_outline_fraction * (t + 1)) {
                last = t;
                hits_up_to = run;
              }
            }
            return last;
          };
          // The farthest such hit: no end lies beyond, and the face below the outline is
          // sampled only that far (and 8 columns more).
          int hits_at_last = 0;
          const int reach = lastQualifying(n_tested, hits_at_last);
          if (reach + 1 < std::max(8.0, walk_widths / 2)) return;
          // The end lies at or before `reach`: the offset must change by 3 up to there.
          if (d_side + k * (2 * (reach + 1)) - d_side < 3.0) return;
          // The end taken below is one of the qualifying hits up to `reach`: when none of them
          // gives the share and the shape, no face below can.
          bool possible = false;
          for (int t = 0, run = 0; t <= reach && !possible; ++t) {
            const std::uint8_t hit = outline_hits_[static_cast<std::size_t>(t)];
            run += hit;
            if (!hit || run < params_.plain_min_outline_fraction * (t + 1) || t + 1 < std::max(8.0, walk_widths / 2))
              continue;
            possible = shapeHolds(t + 1, run, xs + dir * 2 * (t + 1));
          }
          if (!possible) return;
          const int scan_end = std::min(n_tested, reach + 5);
          int stop = scan_end, first_bad = -1;
          for (int t = 1; t < scan_end; t += 2) {  // every fourth column
            const int j = 2 * (t + 1);
            const int x = xs + dir * j;
            const double d = d_side + k * j;
            const FaceRows face = faceRows(x, d, h);
            const long area = face.count();
            const long half_area = area / 2;  // plain while at most half of the rows are such features
            long other = 0;
            foreignBelow(x, d, face, other, half_area);
            if (area > 0 && other <= half_area) {
              first_bad = -1;
            } else if (first_bad < 0) {
              first_bad = t;
            } else {
              stop = first_bad;
              break;
            }
          }
          if (stop == n_tested && out_of_view) return;  // plain to the border: the case above
          const int last = stop > reach ? reach : lastQualifying(stop, hits_at_last);
          if (last + 1 < std::max(8.0, walk_widths / 2)) return;
          const int j_end = 2 * (last + 1);
          const double d_end = d_side + k * j_end;
          const int x_end = xs + dir * j_end;
          const double c_end = contactOf(d_end, x_end);
          const int y_top = std::max(0, static_cast<int>(std::lround(c_end - h * d_end / baseline_m)));
          const int y_bottom = std::min(rows - 1, static_cast<int>(std::lround(c_end)));
          if (y_bottom < y_top || !shapeHolds(last + 1, hits_at_last, x_end)) return;
          // The vertical outline lies between the last hit and the first textured column (+2).
          const int x_stop = xs + dir * 2 * (std::min(stop, n_tested - 1) + 1);
          const int xa = std::max(0, std::min(x_end, x_stop) - 2), xb = std::min(cols - 1, std::max(x_end, x_stop) + 2);
          // Rows are counted until the share is reached, or until it no longer can be.
          const double needed = params_.plain_near_end_edge_share * (y_bottom - y_top + 1);
          int edge_rows = 0;
          for (int y = y_top; y <= y_bottom && edge_rows < needed && edge_rows + (y_bottom - y + 1) >= needed; ++y) {
            bool on = false;
            for (int x = xa; x <= xb && !on; ++x) on = onFaceAt(y, x, d_end);
            edge_rows += on ? 1 : 0;
          }
          if (edge_rows < needed) return;
          o.tested = last + 1;
          o.end = x_end;
          hits = hits_at_last;
        }
        o.frac = static_cast<double>(hits) / o.tested;
        const int j_end = std::abs(o.end - xs);
        // Plain below the outline: few features there that do not match the face's offset.
        long area = 0, other = 0;
        for (int j = 2; j <= j_end; j += 4) area += faceRows(xs + dir * j, d_side + k * j, h).count();
        if (area == 0) return;
        // The most features off the face's offset that a plain face holds.
        const long cap = static_cast<long>(std::floor(params_.plain_max_feature_fraction * static_cast<double>(area)));
        for (int j = 2; j <= j_end && other <= cap; j += 4)
          foreignBelow(xs + dir * j, d_side + k * j, faceRows(xs + dir * j, d_side + k * j, h), other, cap);
        if (other > cap) return;
        best = o;
        best_ys = ys;
      };
      // Coarse to fine. The face's top at the part: from half the part's height above its top
      // (the part may be a piece of the face's end) down to its top; offset slopes from 0.01 to
      // 0.5 px per column (a wall along the line of sight 1.1 m to the side of the camera
      // changes by B / 1.1 m per column).
      // Faces out of view first; a face ending in view only when none is found.
      for (const bool in_view : {false, true}) {
        if (best.end >= 0 || (in_view && !params_.plain_outline_near_end)) break;
        if (in_view) {
          d_side = std::max(d_side, a.max_offset_px);
          ca = contactOf(d_side, xs);
        }
        for (int ys = a.box.y + 2; ys >= std::max(0, a.box.y - a.box.height / 2); ys -= 3)
          for (double k = 0.01; k <= 0.5; k *= 1.2) evaluate(ys, k, in_view);
        if (best.end >= 0) {
          const int ys_c = best_ys;
          const double k_c = best.k;
          for (int ys = ys_c - 2; ys <= ys_c + 2; ++ys)
            for (double k = k_c / 1.2; k <= std::min(0.5, k_c * 1.2); k *= 1.05) evaluate(ys, k, in_view);
        }
      }
      if (best.end < 0) continue;
      // The part grows over the face; other obstacles on the face (at its offset where they
      // stand) fold into it, those in front of it stay apart.
      const int j_end = std::abs(best.end - xs);
      const double d_end = d_side + best.k * j_end;
      const double c_end = contactOf(d_end, best.end);
      const int top = static_cast<int>(std::lround(c_end - best.h * d_end / baseline_m));
      const int x0 = std::min(a.box.x, best.end), x1 = std::max(a.box.x + a.box.width - 1, best.end);
      const int y0 = std::max(0, std::min(a.box.y, top));
      const int y1 = std::max(a.box.y + a.box.height - 1, std::min(rows - 1, static_cast<int>(std::lround(c_end))));
      obstacles[i].box = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
      obstacles[i].max_offset_px =
          std::max(obstacles[i].max_offset_px, std::min(max_offset, static_cast<int>(std::ceil(d_end))));
      // (Each fold renumbers the obstacles: the grown one is obstacles[i] again after it.)
      auto onFace = [&](const ObstacleCluster& o) {
        const double xc = o.box.x + 0.5 * (o.box.width - 1);
        const double d = d_side + best.k * dir * (xc - xs);
        return overlapOfSmaller(obstacles[i].box, o.box) >= params_.merge_overlap && std::abs(o.offset_px - d) <= tol + 1;
      };
      for (bool folded = true; folded;) {
        folded = false;
        for (std::size_t j = 0; j < obstacles.size() && !folded; ++j) {
          if (j == i || !onFace(obstacles[j])) continue;
          const ObstacleCluster& o = obstacles[j];
          foldInto(i, o.box, o.min_offset_px, o.max_offset_px, labels, obstacles);
          folded = true;
        }
      }
      ++joins;
      break;
    }
  }
  return joins;
}

}  // namespace sg
