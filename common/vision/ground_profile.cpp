#include "vision/ground_profile.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include "config/errors.hpp"
#include "vision/correlation.hpp"
#include "vision/simd_match.hpp"

namespace sg {

namespace {
constexpr int kRollGreyTolerance = 12;  // grey levels, as the correlation default
constexpr int kTiltMinRowFeatures = 3;  // a band's row with fewer features says nothing

// The row below the first run of rows, from the top, for which `background(y)` holds, gaps
// of at most `gap_rows` rows inside it; 0 when no row does. Rows after the run are not asked.
template <class IsBackground>
int rowBelowTopRun(int rows, int gap_rows, IsBackground background) {
  int last = -1;
  for (int y = 0; y < rows; ++y) {
    if (background(y)) {
      last = y;
    } else if (last >= 0 && y - last > gap_rows) {
      break;
    }
  }
  return last + 1;
}

// A row's correlation peak: a local maximum (the first of a plateau) at or above the floor.
inline bool isRowPeak(const float* s, int d, int offsets, float floor) {
  const bool left_ok = d == 0 || s[d] >= s[d - 1];
  const bool right_ok = d == offsets - 1 || s[d] > s[d + 1];
  return left_ok && right_ok && s[d] >= floor;
}

// Where the parabola through three equally spaced values (left, centre, right) peaks,
// relative to the centre; 0 when they do not bend downwards.
inline double parabolaPeakShift(double left, double centre, double right) {
  const double den = left - 2 * centre + right;
  return den < 0 ? 0.5 * (left - right) / den : 0.0;
}
}  // namespace

GroundEstimator::GroundEstimator(const GroundParams& params) : params_(params) { params_.validate(); }

void GroundEstimator::keepStrongest(std::vector<Peak>& row_peaks) {
  // Strongest first; ties keep the smaller offset (stable sort on a deterministic order).
  // The first `keep` of a stable sort, by repeated selection: the strongest remaining
  // peak, the earliest of equals (no temporary buffer, linear in the row's peaks).
  const std::size_t keep = std::min(row_peaks.size(), static_cast<std::size_t>(params_.max_peaks_per_row));
  for (std::size_t t = 0; t < keep; ++t) {
    std::size_t best = t;
    for (std::size_t i = t + 1; i < row_peaks.size(); ++i)
      if (row_peaks[i].weight > row_peaks[best].weight) best = i;
    // Move it to position t keeping the order of the others (stability of the rest).
    const Peak p = row_peaks[best];
    for (std::size_t i = best; i > t; --i) row_peaks[i] = row_peaks[i - 1];
    row_peaks[t] = p;
  }
  peaks_.insert(peaks_.end(), row_peaks.begin(), row_peaks.begin() + static_cast<std::ptrdiff_t>(keep));
}

void GroundEstimator::findPeaksReference(const cv::Mat& score) {
  peaks_.clear();
  row_peak_begin_.assign(static_cast<std::size_t>(score.rows) + 1, 0);
  const int offsets = score.cols;
  std::vector<Peak>& row_peaks = row_peaks_;
  for (int y = 0; y < score.rows; ++y) {
    row_peak_begin_[static_cast<std::size_t>(y)] = static_cast<int>(peaks_.size());
    const float* s = score.ptr<float>(y);
    const float row_max = *std::max_element(s, s + offsets);
    const float floor = std::max(params_.min_peak_score, params_.peak_ratio * row_max);
    if (row_max <= 0.0f || row_max < floor) continue;
    row_peaks.clear();
    for (int d = 0; d < offsets; ++d) {
      if (isRowPeak(s, d, offsets, floor)) row_peaks.push_back(Peak{y, d, s[d]});
    }
    keepStrongest(row_peaks);
  }
  row_peak_begin_[static_cast<std::size_t>(score.rows)] = static_cast<int>(peaks_.size());
}

void GroundEstimator::findPeaks(const cv::Mat& score) {
  peaks_.clear();
  row_peak_begin_.assign(static_cast<std::size_t>(score.rows) + 1, 0);
  const int offsets = score.cols;
  std::vector<Peak>& row_peaks = row_peaks_;
  // Four lanes: the baseline (SSE2) build of this file turns wider comparisons and
  // selections into scalar code through the stack.
  typedef float F32x4 __attribute__((vector_size(16)));
  typedef std::int32_t I32x4 __attribute__((vector_size(16)));
  constexpr int kWidth = 4;
  for (int y = 0; y < score.rows; ++y) {
    row_peak_begin_[static_cast<std::size_t>(y)] = static_cast<int>(peaks_.size());
    const float* s = score.ptr<float>(y);
    // Row maximum, four lanes at a time (exact: a maximum does not round).
    float row_max = s[0];
    int d = 0;
    {
      F32x4 m = F32x4{} + s[0];
      for (; d + kWidth <= offsets; d += kWidth) {
        F32x4 v;
        std::memcpy(&v, s + d, sizeof(v));
        m = v > m ? v : m;
      }
      float lanes[kWidth];
      std::memcpy(lanes, &m, sizeof(lanes));
      for (const float v : lanes) row_max = std::max(row_max, v);
      for (; d < offsets; ++d) row_max = std::max(row_max, s[d]);
    }
    const float floor = std::max(params_.min_peak_score, params_.peak_ratio * row_max);
    if (row_max <= 0.0f || row_max < floor) continue;
    row_peaks.clear();
    // Local maxima at or above the floor, in offset order: a vector test of four
    // interior offsets at a time, the offsets of a block with a candidate tested one by one.
    auto test = [&](int k) {
      if (isRowPeak(s, k, offsets, floor)) row_peaks.push_back(Peak{y, k, s[k]});
    };
    test(0);
    d = 1;
    const F32x4 vfloor = F32x4{} + floor;
    for (; d + kWidth < offsets; d += kWidth) {
      F32x4 prev, cur, next;
      std::memcpy(&prev, s + d - 1, sizeof(prev));
      std::memcpy(&cur, s + d, sizeof(cur));
      std::memcpy(&next, s + d + 1, sizeof(next));
      const I32x4 hit = (cur >= vfloor) & (cur >= prev) & (cur > next);
      std::int32_t lanes[kWidth];
      std::memcpy(lanes, &hit, sizeof(lanes));
      std::int32_t any = 0;
      for (const std::int32_t v : lanes) any |= v;
      if (any == 0) continue;
      for (int j = 0; j < kWidth; ++j)
        if (lanes[j] != 0) row_peaks.push_back(Peak{y, d + j, s[d + j]});
    }
    for (; d < offsets; ++d) test(d);
    keepStrongest(row_peaks);
  }
  row_peak_begin_[static_cast<std::size_t>(score.rows)] = static_cast<int>(peaks_.size());
}

std::optional<GroundLine> GroundEstimator::hough(const std::vector<std::uint8_t>& use, int rows, int offsets) const {
  (void)offsets;
  const int n_slopes = static_cast<int>(std::floor((params_.max_slope - params_.min_slope) / params_.slope_step)) + 1;
  const int n_bins = 2 * rows;  // horizon rows -rows .. rows-1 (a horizon below the image shows no ground)
  accumulator_.assign(static_cast<std::size_t>(n_slopes) * static_cast<std::size_t>(n_bins), 0.0f);
  bool any = false;
  for (std::size_t i = 0; i < peaks_.size(); ++i) {
    const Peak& p = peaks_[i];
    if (!use[i] || p.offset < 1) continue;  // offset 0 is infinity: no slope information
    any = true;
    for (int k = 0; k < n_slopes; ++k) {
      const double s = params_.min_slope + k * params_.slope_step;
      const long bin = std::lround(p.row - p.offset / s) + rows;
      if (bin < 0 || bin >= n_bins) continue;
      accumulator_[static_cast<std::size_t>(k) * static_cast<std::size_t>(n_bins) + static_cast<std::size_t>(bin)] +=
          p.weight;
    }
  }
  if (!any) return std::nullopt;
  // Best 3x3 neighbourhood sum: a line between two bins still collects its votes.
  float best = 0.0f;
  int best_k = -1, best_b = -1;
  for (int k = 0; k < n_slopes; ++k) {
    for (int b = 0; b < n_bins; ++b) {
      float sum = 0.0f;
      for (int dk = -1; dk <= 1; ++dk) {
        const int kk = k + dk;
        if (kk < 0 || kk >= n_slopes) continue;
        const float* row = &accumulator_[static_cast<std::size_t>(kk) * static_cast<std::size_t>(n_bins)];
        for (int db = -1; db <= 1; ++db) {
          const int bb = b + db;
          if (bb >= 0 && bb < n_bins) sum += row[bb];
        }
      }
      if (sum > best) {
        best = sum;
        best_k = k;
        best_b = b;
      }
    }
  }
  if (best_k < 0) return std::nullopt;
  GroundLine line;
  line.slope = params_.min_slope + best_k * params_.slope_step;
  line.horizon_row = best_b - rows;
  return line;
}

namespace {
// farSegment tries every this many slopes of the Hough space (the refit then sets the slope).
constexpr int kFarSlopeStride = 4;
// Bin shift of a (offset, slope) pair whose rounding depends on the row (below).
constexpr int kRowDependentShift = std::numeric_limits<int>::min() / 2;
// Slopes per group of houghFast's branch and bound, level by level (each size divides the
// one before it): a group of the first level is split into its groups of the next one, a
// group of the last level is scanned, a group in between is split when its bound is below
// kSplitBelow times the best sum found (a loose bound, its groups likely dropped: far from
// the ground line's slope, at small slopes where a vote's bin moves fast), else scanned.
// Measured on the KITTI pairs (houghFast's instructions under callgrind, docs/performance.md):
// 32 / 8 / 4 and 1.5 take 113 M, 32 / 8 alone 125-130 M, 16 / 4 or 32 / 4 130 M, and a full
// scan 247 M.
constexpr int kGroupLevels[] = {32, 8, 4};
constexpr int kLevels = 3;
constexpr double kSplitBelow = 1.5;
static_assert(kGroupLevels[0] % kGroupLevels[1] == 0 && kGroupLevels[1] % kGroupLevels[2] == 0);
}  // namespace

std::optional<GroundLine> GroundEstimator::houghFast(const std::vector<std::uint8_t>& use, int rows, int offsets) {
  // Same votes and sums as hough(), in the same order per bin: bit-identical.
  // The reference adds the votes peak by peak; a bin's sum depends only on the
  // order of the votes it receives, which stays the peaks' order when the loops
  // are swapped: here slope by slope, each slope's votes landing in one row of
  // n_bins floats (in L1), and only three slope rows kept for the 3x3 sums.
  // Most slopes cannot hold the maximum: a group of consecutive slopes whose bound
  // (below) is under the best sum found so far is not voted at all.
  const int n_slopes = static_cast<int>(std::floor((params_.max_slope - params_.min_slope) / params_.slope_step)) + 1;
  const int n_bins = 2 * rows;
  // Groups numbered level by level: level l's groups from level_first[l].
  int level_first[kLevels + 1] = {};
  for (int l = 0; l < kLevels; ++l)
    level_first[l + 1] = level_first[l] + (n_slopes + kGroupLevels[l] - 1) / kGroupLevels[l];
  const int n_groups = level_first[kLevels];
  const int n_coarse = level_first[1];
  auto levelOf = [&](int g) {
    int l = 0;
    while (g >= level_first[l + 1]) ++l;
    return l;
  };
  auto groupSlopes = [&](int g, int& k0, int& k1) {
    const int l = levelOf(g);
    k0 = (g - level_first[l]) * kGroupLevels[l];
    k1 = std::min(k0 + kGroupLevels[l], n_slopes) - 1;
  };
  if (slope_table_offsets_ != offsets || bin_shift_.size() != static_cast<std::size_t>(offsets) * n_slopes) {
    // The reference's bin is lround(row - offset / s) + rows. Where offset / s = q is
    // farther than 1e-6 from a half-integer, row - q (|row - q| < 2^31, so rounded by at
    // most 2^-22) rounds to row - n for the integer n nearest to q, whatever the row:
    // the bin is row + rows + shift with shift = -n, one table entry per offset and
    // slope. The other pairs (a tie, or q too large) are computed as the reference does.
    bin_shift_.resize(static_cast<std::size_t>(offsets) * static_cast<std::size_t>(n_slopes));
    for (int k = 0; k < n_slopes; ++k) {
      const double s = params_.min_slope + k * params_.slope_step;
      for (int d = 0; d < offsets; ++d) {
        const double q = d / s;
        int shift = kRowDependentShift;
        if (q < 0x1p30) {
          const double frac = q - std::floor(q);
          if (std::abs(frac - 0.5) > 1e-6) shift = -static_cast<int>(std::lround(q));
        }
        bin_shift_[static_cast<std::size_t>(k) * static_cast<std::size_t>(offsets) + static_cast<std::size_t>(d)] =
            shift;
      }
    }
    // Per group and offset, what the group's bound needs of a vote (see groupBound): the
    // windows of slopes k0 .. k1 use slopes k0 - 1 .. k1 + 1, over which a vote's bin goes
    // from row + rows + shift at the first to row + rows + shift at the last (a bin is
    // non-decreasing in the slope for offsets >= 1); the windows b it can reach run from
    // one bin before the first to one after the last. Where the table has no shift, the
    // reference's bin lround(row - q) + rows lies within row + rows - ceil(q) - 1 ..
    // row + rows - floor(q) + 1. And a vote's bin moves by the same integer step whatever
    // its row: moving by 2 bins or more per slope (3 or more), it falls into the three
    // bins of a window at two (one) of the window's three slopes at most.
    group_spans_.resize(static_cast<std::size_t>(n_groups) * static_cast<std::size_t>(offsets));
    auto shiftAt = [&](int k, int d) {
      return bin_shift_[static_cast<std::size_t>(k) * static_cast<std::size_t>(offsets) + static_cast<std::size_t>(d)];
    };
    auto shiftBelow = [&](int k, int d, bool upper) {
      const int shift = shiftAt(k, d);
      if (shift != kRowDependentShift) return shift;
      const double q = d / (params_.min_slope + k * params_.slope_step);
      if (!(q < 0x1p30)) return -(1 << 30);  // below every bin
      return upper ? -static_cast<int>(std::floor(q)) + 1 : -static_cast<int>(std::ceil(q)) - 1;
    };
    for (int g = 0; g < n_groups; ++g) {
      int k0 = 0, k1 = 0;
      groupSlopes(g, k0, k1);
      const int k_first = std::max(k0 - 1, 0), k_last = std::min(k1 + 1, n_slopes - 1);
      for (int d = 0; d < offsets; ++d) {
        GroupSpan& span = group_spans_[static_cast<std::size_t>(g) * static_cast<std::size_t>(offsets) +
                                       static_cast<std::size_t>(d)];
        span.first = shiftBelow(k_first, d, false) - 1;
        span.end = shiftBelow(k_last, d, true) + 2;
        int step = std::numeric_limits<int>::max();
        bool exact = shiftAt(k_first, d) != kRowDependentShift;
        for (int k = k_first + 1; k <= k_last; ++k) {
          exact = exact && shiftAt(k, d) != kRowDependentShift;
          step = std::min(step, shiftAt(k, d) - shiftAt(k - 1, d));
        }
        span.repeats = !exact ? 3.0 : step >= 3 ? 1.0 : step == 2 ? 2.0 : 3.0;
      }
    }
    slope_table_offsets_ = offsets;
  }
  // The voting peaks, in order: row + rows, offset, weight (capacity for every peak
  // a frame of this size can have: no allocation after the first frame).
  const std::size_t most = static_cast<std::size_t>(rows) * static_cast<std::size_t>(params_.max_peaks_per_row);
  vote_base_.reserve(most);
  vote_offset_.reserve(most);
  vote_weight_.reserve(most);
  vote_base_.clear();
  vote_offset_.clear();
  vote_weight_.clear();
  double total_weight = 0.0;
  bool weights_bounded = true;  // every weight finite and >= 0 (as row peaks' scores are)
  for (std::size_t i = 0; i < peaks_.size(); ++i) {
    const Peak& p = peaks_[i];
    if (!use[i] || p.offset < 1 || p.offset >= offsets) continue;  // offset 0 is infinity: no slope information
    vote_base_.push_back(p.row + rows);
    vote_offset_.push_back(p.offset);
    vote_weight_.push_back(p.weight);
    total_weight += static_cast<double>(p.weight);
    weights_bounded = weights_bounded && p.weight >= 0.0f && std::isfinite(p.weight);
  }
  if (vote_base_.empty()) return std::nullopt;
  const int n_votes = static_cast<int>(vote_base_.size());

  // Three accumulator rows (slopes k - 1, k, k + 1) and a zero row, each with a zero
  // bin on either side: the 3x3 sums need no bounds tests (adding +0.0f where the
  // reference skips a term leaves a sum unchanged: every sum is >= +0).
  const int stride = n_bins + 2;
  slope_rows_.assign(static_cast<std::size_t>(4) * static_cast<std::size_t>(stride), 0.0f);
  window_sums_.resize(static_cast<std::size_t>(n_bins));
  float* zero_row = slope_rows_.data() + 1;
  float* ring[3] = {zero_row + stride, zero_row + 2 * stride, zero_row + 3 * stride};
  const int* base = vote_base_.data();
  const int* offset = vote_offset_.data();
  const float* weight = vote_weight_.data();
  auto vote = [&](int k, float* acc) {
    std::fill(acc - 1, acc + n_bins + 1, 0.0f);
    const int* shift = &bin_shift_[static_cast<std::size_t>(k) * static_cast<std::size_t>(offsets)];
    for (int i = 0; i < n_votes; ++i) {
      const int sh = shift[offset[i]];
      const int bin = base[i] + sh;
      if (static_cast<unsigned>(bin) < static_cast<unsigned>(n_bins)) {
        acc[bin] += weight[i];
      } else if (sh == kRowDependentShift) {
        const double s = params_.min_slope + k * params_.slope_step;
        const long b = std::lround((base[i] - rows) - offset[i] / s) + rows;
        if (b >= 0 && b < n_bins) acc[b] += weight[i];
      }
    }
  };

  // Bound of every 3x3 sum of group g: each vote adds its weight, at most `repeats` times,
  // only to the windows b its span reaches, so the largest sum of these weights over b (a
  // difference array over the bins, in double; spans clipped to the bins, which only
  // widens them) bounds the real sums of the group's windows. A float sum exceeds its real
  // sum by at most the factor (1 + 2^-24)^h, h the additions a vote goes through (at most
  // n_votes + 8: its bin, then the window), below 1 + 2 h 2^-24 while h 2^-24 < 1/2; 1e-3
  // more on top. The double sums' own rounding stays far below 1e-9 of the total weight.
  // Without a bound (a weight not finite or negative, too many votes, or sums that could
  // overflow a float), +infinity.
  const double rounding = 2.0 * (n_votes + 8.0) * 0x1p-24;
  const bool bounded = weights_bounded && rounding < 1e-2 && total_weight < 1e37;
  const double relative_margin = 1.0 + 1e-3 + rounding;
  const double absolute_margin = 1e-9 * total_weight;
  bound_diff_.resize(static_cast<std::size_t>(n_bins) + 1);
  auto groupBound = [&](int g) -> double {
    if (!bounded) return std::numeric_limits<double>::infinity();
    double* diff = bound_diff_.data();
    std::fill(diff, diff + n_bins + 1, 0.0);
    const GroupSpan* spans = &group_spans_[static_cast<std::size_t>(g) * static_cast<std::size_t>(offsets)];
    for (int i = 0; i < n_votes; ++i) {
      const GroupSpan& span = spans[offset[i]];
      const int first = std::clamp(base[i] + span.first, 0, n_bins);
      const int end = std::clamp(base[i] + span.end, 0, n_bins);
      const double w = static_cast<double>(weight[i]) * span.repeats;
      diff[first] += w;
      diff[end] -= w;
    }
    double run = 0.0, largest = 0.0;
    for (int b = 0; b < n_bins; ++b) {
      run += diff[b];
      largest = std::max(largest, run);
    }
    return largest * relative_margin + absolute_margin;
  };

  // 3x3 sums in the reference's order (slopes k-1, k, k+1; bins b-1, b, b+1); the
  // reference keeps the first maximum in slope-major order. Within a group the scan is
  // the reference's; a group's first maximum replaces the best when larger, or equal and
  // at a smaller slope (groups are visited by bound, not in slope order).
  float best = 0.0f;
  int best_k = -1, best_b = -1;
  auto scanGroup = [&](int k0, int k1) {
    float* prev = zero_row;
    if (k0 > 0) {
      prev = ring[(k0 - 1) % 3];
      vote(k0 - 1, prev);
    }
    float* cur = ring[k0 % 3];
    vote(k0, cur);
    float group_best = 0.0f;
    int group_k = -1, group_b = -1;
    for (int k = k0; k <= k1; ++k) {
      float* next = zero_row;
      if (k + 1 < n_slopes) {
        next = ring[(k + 1) % 3];
        vote(k + 1, next);
      }
      float* out = window_sums_.data();
      // Largest sum of this slope with the sums (exact: a maximum does not round); most
      // slopes cannot change the group's best and are not scanned.
      const float row_max = simd::houghWindowSums(prev, cur, next, n_bins, out);
      if (row_max > group_best) {
        group_best = row_max;
        group_k = k;
        group_b = static_cast<int>(std::find(out, out + n_bins, row_max) - out);
      }
      prev = cur;
      cur = next;
    }
    if (group_k >= 0 && (group_best > best || (group_best == best && group_k < best_k))) {
      best = group_best;
      best_k = group_k;
      best_b = group_b;
    }
  };

  // Branch and bound, best first: of the open groups (at first those of the first level),
  // the one with the largest bound is taken and split into its groups of the next level
  // or scanned (kGroupLevels); a group whose bound is below the best sum found (so are all
  // its sums: neither a larger maximum nor an equal earlier one) is dropped, and the
  // search ends when the largest open bound is. Which groups are split changes only the
  // work: every slope is scanned or in a dropped group.
  open_groups_.reserve(static_cast<std::size_t>(n_groups));
  open_groups_.clear();
  for (int g = 0; g < n_coarse; ++g) open_groups_.push_back(OpenGroup{groupBound(g), g});
  while (!open_groups_.empty()) {
    std::size_t top = 0;
    for (std::size_t j = 1; j < open_groups_.size(); ++j)
      if (open_groups_[j].bound > open_groups_[top].bound) top = j;
    const OpenGroup group = open_groups_[top];
    if (group.bound < static_cast<double>(best)) break;
    open_groups_[top] = open_groups_.back();
    open_groups_.pop_back();
    int k0 = 0, k1 = 0;
    groupSlopes(group.group, k0, k1);
    const int level = levelOf(group.group);
    const bool loose = best > 0.0f && group.bound < kSplitBelow * static_cast<double>(best);
    if (level == kLevels - 1 || (level > 0 && !loose)) {
      scanGroup(k0, k1);
      continue;
    }
    const int size = kGroupLevels[level + 1];
    for (int f = level_first[level + 1] + k0 / size; f <= level_first[level + 1] + k1 / size; ++f) {
      const double bound = groupBound(f);
      if (bound >= static_cast<double>(best)) open_groups_.push_back(OpenGroup{bound, f});
    }
  }
  if (best_k < 0) return std::nullopt;
  GroundLine line;
  line.slope = params_.min_slope + best_k * params_.slope_step;
  line.horizon_row = best_b - rows;
  return line;
}

bool GroundEstimator::peakNear(int y, double d) const {
  for (int i = row_peak_begin_[static_cast<std::size_t>(y)]; i < row_peak_begin_[static_cast<std::size_t>(y) + 1]; ++i)
    if (std::abs(peaks_[static_cast<std::size_t>(i)].offset - d) <= params_.support_tolerance_px) return true;
  return false;
}

int GroundEstimator::support(const GroundLine& line, int row_begin, int row_end, int offsets, int* crossed,
                             double above) const {
  int count = 0, seen = 0;
  for (int y = std::max(row_begin, 0); y < row_end; ++y) {
    const double d = line.offsetAt(y);
    if (d < 0.5 || d <= above || d > offsets - 1) continue;
    ++seen;
    count += peakNear(y, d) ? 1 : 0;
  }
  if (crossed) *crossed = seen;
  return count;
}

GroundLine GroundEstimator::refit(const GroundLine& line, int row_begin, int row_end) const {
  // Weighted least squares d = a * y + b over the peaks near the line.
  double sw = 0, sy = 0, sd = 0, syy = 0, syd = 0;
  for (int y = std::max(row_begin, 0); y < row_end; ++y) {
    const double d_line = line.offsetAt(y);
    for (int i = row_peak_begin_[static_cast<std::size_t>(y)]; i < row_peak_begin_[static_cast<std::size_t>(y) + 1];
         ++i) {
      const Peak& p = peaks_[static_cast<std::size_t>(i)];
      if (p.offset < 1 || std::abs(p.offset - d_line) > params_.support_tolerance_px) continue;
      const double w = static_cast<double>(p.weight);
      sw += w;
      sy += w * y;
      sd += w * p.offset;
      syy += w * y * y;
      syd += w * y * p.offset;
    }
  }
  const double det = sw * syy - sy * sy;
  if (sw <= 0.0 || std::abs(det) < 1e-9) return line;
  const double a = (sw * syd - sy * sd) / det;
  const double b = (sd - a * sy) / sw;
  if (!(a >= params_.min_slope * 0.5 && a <= params_.max_slope * 2.0)) return line;
  GroundLine out = line;
  out.slope = a;
  out.horizon_row = -b / a;
  return out;
}

double GroundEstimator::groundFloor(const cv::Mat& score, const cv::Mat& matches, const GroundLine& line,
                                    std::optional<double>& floor) {
  if (floor) return *floor;
  const int rows = score.rows;
  const int h1 = std::clamp(static_cast<int>(std::ceil(line.horizon_row)), 0, rows);
  // The background the far ground would meet, as the line alone leaves it.
  line_rows_.resize(static_cast<std::size_t>(rows));
  for (int y = 0; y < rows; ++y) line_rows_[static_cast<std::size_t>(y)] = static_cast<float>(line.offsetAt(y));
  floor = static_cast<double>(backgroundOffset(score, matches, h1, line_rows_)) + params_.support_tolerance_px;
  return *floor;
}

std::optional<GroundLine> GroundEstimator::farSegment(const cv::Mat& score, const cv::Mat& matches,
                                                      const GroundLine& line, std::optional<double>& floor) {
  const int rows = score.rows;
  const int h1 = std::clamp(static_cast<int>(std::ceil(line.horizon_row)), 0, rows);
  const int need = params_.min_segment_rows;
  if (rows - h1 < 2 * need) return std::nullopt;
  const double tol = params_.support_tolerance_px;
  const double ground_above = groundFloor(score, matches, line, floor);
  // Rows supporting the line where the segment would be ground (the line is the background
  // where it is farther), as prefix sums. The rows that can support the segment and not the
  // line (a peak farther than the background, none on the line) vote; a bound on what a
  // segment ending above row j can gain: the best run of rows ending there, each row +1 when
  // it votes and -1 when it supports the line.
  const double background = ground_above - tol;
  line_support_.assign(static_cast<std::size_t>(rows) + 1, 0);
  far_bound_.assign(static_cast<std::size_t>(rows) + 1, 0);
  far_rows_.clear();
  far_peaks_.clear();
  for (int y = 0; y < rows; ++y) {
    const auto i = static_cast<std::size_t>(y);
    const bool on_line = peakNear(y, std::max(background, line.offsetAt(y)));
    bool votes = false;
    if (!on_line) {
      for (int k = row_peak_begin_[i]; k < row_peak_begin_[i + 1]; ++k) {
        const double d = peaks_[static_cast<std::size_t>(k)].offset;
        if (d <= background) continue;
        if (!votes) far_rows_.push_back(FarRow{y, static_cast<int>(far_peaks_.size()), 0});
        votes = true;
        far_peaks_.push_back(d);
        ++far_rows_.back().peaks;
      }
    }
    line_support_[i + 1] = line_support_[i] + (on_line ? 1 : 0);
    far_bound_[i + 1] = std::max(far_bound_[i], 0) + (votes ? 1 : 0) - (on_line ? 1 : 0);
  }
  int best_gain = need - 1;
  if (*std::max_element(far_bound_.begin(), far_bound_.end()) <= best_gain) return std::nullopt;
  // Per slope, each voting row votes for the junction rows whose segment passes within the
  // tolerance of one of its peaks and is ground there: the segment's offset at row y is
  // f(j) = a * j + c, linear in the junction row j.
  const int j_first = h1 + need;
  const int n_slopes = static_cast<int>(std::floor((params_.max_slope - params_.min_slope) / params_.slope_step)) + 1;
  const double s1 = line.slope;
  int best_j = -1, best_k = -1;
  // The line stays the ground below the junction: supported there as a segment is.
  int j_last = rows - 1;
  while (j_last >= j_first && line_support_[static_cast<std::size_t>(rows)] -
                                      line_support_[static_cast<std::size_t>(j_last)] < need)
    --j_last;
  if (j_last < j_first) return std::nullopt;
  far_votes_.resize(static_cast<std::size_t>(rows) + 1);
  auto scan = [&](int k) {
    const double s2 = params_.min_slope + k * params_.slope_step;
    const double a = s1 - s2;
    if (std::abs(a) < 0.05 * s1) return;
    const double inv_a = 1.0 / a;
    // Rows within this many of the junction are within the tolerance of both lines: they
    // support both or neither, and count for neither.
    const int shared = static_cast<int>(std::floor(tol / std::abs(a)));
    std::fill(far_votes_.begin(), far_votes_.end(), 0);
    // The integer j with lo <= a * j + c <= hi, j > y, j_first <= j < rows.
    auto junctions = [&](double c, double lo, double hi, int y, int& first, int& last) {
      const double u = (lo - c) * inv_a, v = (hi - c) * inv_a;
      const double j_lo = std::clamp(std::min(u, v), -1.0, static_cast<double>(rows));
      const double j_hi = std::clamp(std::max(u, v), -1.0, static_cast<double>(rows));
      first = std::max({static_cast<int>(std::ceil(j_lo)), y + 1, j_first});
      last = std::min(static_cast<int>(std::floor(j_hi)), rows - 1);
    };
    for (const FarRow& r : far_rows_) {
      const double c = s2 * r.row - s1 * line.horizon_row;
      int run_first = -1, run_last = -2;  // the peaks' intervals merged: a row votes once
      for (int p = r.first; p < r.first + r.peaks; ++p) {
        const double d = far_peaks_[static_cast<std::size_t>(p)];
        int first = 0, last = 0;
        junctions(c, std::max(d - tol, ground_above), d + tol, r.row, first, last);
        if (first > last) continue;
        if (first > run_last + 1) {
          if (run_last >= run_first) {
            ++far_votes_[static_cast<std::size_t>(run_first)];
            --far_votes_[static_cast<std::size_t>(run_last) + 1];
          }
          run_first = first;
          run_last = last;
        } else {
          run_last = std::max(run_last, last);
        }
      }
      if (run_last >= run_first) {
        ++far_votes_[static_cast<std::size_t>(run_first)];
        --far_votes_[static_cast<std::size_t>(run_last) + 1];
      }
    }
    int votes = 0;
    for (int j = 0; j < rows; ++j) {
      votes += far_votes_[static_cast<std::size_t>(j)];
      if (j < j_first || votes <= best_gain || j > j_last) continue;
      const double dj = line.offsetAt(j);
      if (dj <= ground_above) continue;
      const int y0 = std::max(0, static_cast<int>(std::floor(j - (dj - ground_above) / s2)) + 1);
      const int y1 = std::max(y0, j - shared);
      const int gained =
          votes - (line_support_[static_cast<std::size_t>(y1)] - line_support_[static_cast<std::size_t>(y0)]);
      if (gained > best_gain) {
        best_gain = gained;
        best_j = j;
        best_k = k;
      }
    }
  };
  // Every kFarSlopeStride-th slope, then the slopes around the best of them.
  for (int k = 0; k < n_slopes; k += kFarSlopeStride) scan(k);
  if (best_k >= 0) {
    const int coarse = best_k;
    for (int k = std::max(0, coarse - kFarSlopeStride + 1); k < std::min(n_slopes, coarse + kFarSlopeStride); ++k)
      if (k != coarse) scan(k);
  }
  if (best_j < 0) return std::nullopt;
  const double best_slope = params_.min_slope + best_k * params_.slope_step;
  GroundLine far{best_slope, best_j - line.offsetAt(best_j) / best_slope, 0};
  const int top = static_cast<int>(std::ceil(std::min(line.horizon_row, far.horizon_row)));
  far = refit(far, top, best_j);
  if (std::abs(far.slope - line.slope) <= 1e-6) return std::nullopt;
  // The refitted segment, met by the line at its own junction, must still gain as much.
  const double yj = line.junctionRow(far);
  if (!(yj > top && yj < rows - 1)) return std::nullopt;
  const int j = static_cast<int>(std::ceil(yj));
  const int shared = static_cast<int>(std::floor(tol / std::abs(s1 - far.slope)));
  int gained = 0;
  for (int y = std::max(top, 0); y < j; ++y) {
    const double d = far.offsetAt(y);
    if (d <= ground_above) continue;
    gained += peakNear(y, d) ? 1 : 0;
    if (y < j - shared) gained -= line_support_[static_cast<std::size_t>(y) + 1] - line_support_[static_cast<std::size_t>(y)];
  }
  if (gained < need) return std::nullopt;
  // A rise ahead flattens the far segment: slope ratio h / (h + g Z0) for a camera h above the
  // ground and a grade g from Z0 on (0.27 for a 15 % grade 30 m ahead of a 1.65 m camera).
  // Far flatter, it is something standing (the offset of poles over their rows), not ground.
  if (far.slope < params_.far_min_slope_ratio * line.slope) return std::nullopt;
  far.support_rows = support(far, top, j, score.cols, nullptr);
  return far;
}

bool GroundEstimator::farSegmentWinsOnItsRows(const cv::Mat& score, const cv::Mat& matches, const GroundLine& line,
                                               const GroundLine& far, int row_begin, int junction,
                                               std::optional<double>& floor) {
  if (!(params_.far_share_ratio > 0.0)) return false;
  const double ground_above = groundFloor(score, matches, line, floor);
  // Rows next to the junction lie within the tolerance of both: they count for neither.
  const int shared = static_cast<int>(std::floor(params_.support_tolerance_px / std::abs(line.slope - far.slope)));
  const int row_end = std::min(junction - shared, score.rows);
  int line_rows = 0, far_rows = 0;
  const int line_supported = support(line, row_begin, row_end, score.cols, &line_rows, ground_above);
  const int far_supported = support(far, row_begin, row_end, score.cols, &far_rows, ground_above);
  // far_supported / far_rows >= ratio * line_supported / line_rows, without the divisions.
  return far_supported >= params_.far_share_min_rows &&
         static_cast<double>(far_supported) * line_rows >= params_.far_share_ratio * line_supported * far_rows;
}

float GroundEstimator::backgroundOffset(const cv::Mat& score, const cv::Mat& matches, int rows_above,
                                        const std::vector<float>& ground_per_row) {
  const int rows = std::clamp(rows_above, 0, score.rows);
  if (rows == 0) return 0.0f;
  std::vector<float>& sums = background_sums_;
  sums.assign(static_cast<std::size_t>(score.cols), 0.0f);
  // A row's score is its matches over its features (floored at min_row_features). For the
  // background the floor is background_row_share of the width: a row whose few features are a
  // pole against a plain sky scores as high as a row of textured hills, but says less.
  for (int y = 0; y < rows; ++y) {
    const float* s = score.ptr<float>(y);
    if (!matches.empty()) {
      const int* m = matches.ptr<int>(y);
      for (int d = 0; d < score.cols; ++d)
        sums[static_cast<std::size_t>(d)] += std::min(s[d], static_cast<float>(m[d]) * per_match_);
    } else {
      for (int d = 0; d < score.cols; ++d) sums[static_cast<std::size_t>(d)] += s[d];
    }
  }
  // The strongest column first; one that would hide measured ground is something standing in
  // front (a pole or a trunk taller than the view, alone against a plain sky), not the background.
  for (;;) {
    const auto best = std::max_element(sums.begin(), sums.end());
    if (*best < params_.min_background_score) return 0.0f;  // nothing measurable: infinity
    const auto offset = static_cast<float>(best - sums.begin());
    if (!hidesMeasuredGround(offset, ground_per_row)) return offset;
    *best = -1.0f;
  }
}

double GroundEstimator::refinedBackground(float background) const {
  // The vertex of the parabola through the column sums at the offset and its two neighbours
  // (neighbours left out as hiding measured ground, marked -1, leave the offset as it is).
  const auto& sums = background_sums_;
  const double whole = static_cast<double>(background);
  const auto k = static_cast<std::size_t>(std::lround(background));
  if (k == 0 || k + 1 >= sums.size()) return whole;
  const auto l = static_cast<double>(sums[k - 1]), r = static_cast<double>(sums[k + 1]);
  if (l < 0.0 || r < 0.0) return whole;
  return whole + parabolaPeakShift(l, static_cast<double>(sums[k]), r);
}

bool GroundEstimator::hidesMeasuredGround(float offset, const std::vector<float>& ground_per_row) const {
  const double tol = params_.support_tolerance_px;
  const double hidden_below = static_cast<double>(offset) - 1.0 - tol;
  int hidden = 0, shown = 0, supported = 0;
  for (std::size_t y = 0; y < ground_per_row.size() && y + 1 < row_peak_begin_.size(); ++y) {
    const auto d = static_cast<double>(ground_per_row[y]);
    if (!(d >= 1.0)) continue;  // not ground (or farther than the background can be)
    const bool on_line = peakNear(static_cast<int>(y), d);
    supported += on_line ? 1 : 0;
    if (d > hidden_below) continue;
    ++hidden;
    shown += on_line ? 1 : 0;
  }
  // Measured there as a segment is, and a measured share of the whole line.
  return shown >= params_.min_segment_rows && shown >= params_.min_support_fraction * hidden &&
         shown >= params_.min_support_fraction * supported;
}

int GroundEstimator::rowsBeyond(const GroundLine& line, int row_begin, int row_end, float background) const {
  const double tol = params_.support_tolerance_px;
  int count = 0;
  for (int y = std::max(row_begin, 0); y < row_end; ++y) {
    // keepStrongest stores a row's peaks strongest first.
    const int first = row_peak_begin_[static_cast<std::size_t>(y)];
    if (first == row_peak_begin_[static_cast<std::size_t>(y) + 1]) continue;
    const double d = static_cast<double>(peaks_[static_cast<std::size_t>(first)].offset);
    count += d < line.offsetAt(y) - tol && d > static_cast<double>(background) + tol ? 1 : 0;
  }
  return count;
}

int GroundEstimator::backgroundEdgeRow(const cv::Mat& score, float background) const {
  const int d0 = std::max(0, static_cast<int>(std::floor(background)) - 1);
  const int d1 = std::min(score.cols - 1, static_cast<int>(std::ceil(background)) + 1);
  if (d0 > d1) return 0;
  return rowBelowTopRun(score.rows, params_.background_edge_gap_rows, [&](int y) {
    const float* s = score.ptr<float>(y);
    return *std::max_element(s + d0, s + d1 + 1) >= params_.background_edge_share;
  });
}

bool GroundEstimator::rollSetUp(const cv::Mat& left, const StereoRig& rig, GroundProfile& ground) {
  ground.offset_per_column = 0.0f;
  ground.offset_per_column_by_row.clear();
  ground.reference_column = static_cast<float>(rig.focal_px > 0 ? rig.cx_px : left.cols / 2.0);
  if (params_.roll_strips < 3 || ground.source == GroundSource::kNone || left.empty() ||
      static_cast<int>(ground.offset_per_row.size()) != left.rows)
    return false;
  // Ground rows in bands of profile_band_rows (a short last band joins the one above it).
  roll_first_row_ = std::max(ground.horizon_row + 2, 0);
  const int ground_rows = std::max(left.rows - roll_first_row_, 0);
  const int band = params_.profile_band_rows;
  roll_bands_ = band > 0 ? std::max(1, (ground_rows + band / 2) / band) : 1;
  const int bins = 2 * params_.roll_search_px + 1;
  // Sized for the most bands an image of this height can have: no allocation as the horizon moves.
  const int most_bands = band > 0 ? std::max(1, (left.rows + band / 2) / band) : 1;
  const std::size_t per_band = static_cast<std::size_t>(params_.roll_strips * bins);
  if (roll_hist_.size() < static_cast<std::size_t>(most_bands) * per_band)
    roll_hist_.resize(static_cast<std::size_t>(most_bands) * per_band);
  std::fill(roll_hist_.begin(), roll_hist_.begin() + static_cast<std::ptrdiff_t>(roll_bands_ * per_band), 0.0);
  return true;
}

int GroundEstimator::rollBand(int y) const {
  const int band = params_.profile_band_rows;
  return band > 0 ? std::min(roll_bands_ - 1, (y - roll_first_row_) / band) : 0;
}

bool GroundEstimator::tiltPrior(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                                GroundProfile& ground) {
  if (!params_.prior_tilt || ground.source != GroundSource::kPrior || !rig.mounting) return false;
  if (ground.offset_per_column != 0.0f || !ground.offset_per_column_by_row.empty()) return false;
  const float background = ground.background_offset;
  if (!std::isfinite(background) || background <= 0.0f || left.empty() || left.size() != right.size()) return false;
  const double slope = rig.groundOffsetPrior(1.0) - rig.groundOffsetPrior(0.0);  // offset per row
  if (!(slope > 0.0)) return false;
  const int rows = left.rows, width = left.cols;
  const int bands = params_.prior_tilt_bands;
  const int e0 = std::max(0, static_cast<int>(std::floor(background)) - 1);
  const int e1 = static_cast<int>(std::ceil(background)) + 1;
  const int first_column = e1;  // the right image shows every offset searched from here on
  // Each band's lower edge of the background, by backgroundEdgeRow's rule for whole rows: the
  // row below the first run of rows (from the top, gaps of background_edge_gap_rows allowed)
  // where at least background_edge_share of the band's features match at the background's
  // offset (+-1).
  tilt_columns_.clear();
  tilt_edges_.clear();
  for (int k = 0; k < bands; ++k) {
    const int x0 = std::max(first_column, k * width / bands), x1 = (k + 1) * width / bands;
    if (x1 - x0 < 4) continue;
    const int edge = rowBelowTopRun(rows, params_.background_edge_gap_rows, [&](int y) {
      const std::uint8_t* l = left.ptr<std::uint8_t>(y);
      const std::uint8_t* r = right.ptr<std::uint8_t>(y);
      int features = 0, matched = 0;
      for (int x = x0; x < x1; ++x) {
        if (l[x] == 0) continue;
        ++features;
        for (int e = e0; e <= e1; ++e) {
          if (std::abs(static_cast<int>(l[x]) - static_cast<int>(r[x - e])) <= kRollGreyTolerance) {
            ++matched;
            break;
          }
        }
      }
      return features >= kTiltMinRowFeatures && matched >= params_.background_edge_share * features;
    });
    if (edge <= 0 || edge >= rows) continue;
    tilt_columns_.push_back(0.5 * (x0 + x1 - 1) - static_cast<double>(ground.reference_column));
    tilt_edges_.push_back(static_cast<double>(edge));
  }
  const std::size_t n = tilt_columns_.size();
  if (n < static_cast<std::size_t>(params_.prior_tilt_min_bands)) return false;
  // Theil-Sen: the median of the pairwise slopes and the median intercept, then a least-squares
  // refit over the bands within prior_tilt_inlier_rows of that line.
  tilt_slopes_.clear();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      tilt_slopes_.push_back((tilt_edges_[j] - tilt_edges_[i]) / (tilt_columns_[j] - tilt_columns_[i]));
  auto median = [](std::vector<double>& v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  double tilt = median(tilt_slopes_);
  tilt_slopes_.clear();
  for (std::size_t i = 0; i < n; ++i) tilt_slopes_.push_back(tilt_edges_[i] - tilt * tilt_columns_[i]);
  double centre = median(tilt_slopes_);
  double su = 0.0, sv = 0.0, suu = 0.0, suv = 0.0;
  int inliers = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::abs(tilt_edges_[i] - (centre + tilt * tilt_columns_[i])) > params_.prior_tilt_inlier_rows) continue;
    ++inliers;
    su += tilt_columns_[i];
    sv += tilt_edges_[i];
    suu += tilt_columns_[i] * tilt_columns_[i];
    suv += tilt_columns_[i] * tilt_edges_[i];
  }
  if (inliers < params_.prior_tilt_min_bands) return false;
  const double det = inliers * suu - su * su;
  if (!(det > 0.0)) return false;
  tilt = (inliers * suv - su * sv) / det;
  centre = (sv - tilt * su) / inliers;
  // The ground meets the background along edge(x) = centre + tilt * (x - reference), so its
  // offset changes by -slope * tilt per column.
  const double per_column = -slope * tilt;
  if (std::abs(per_column) * width < params_.min_roll_px) return false;
  if (!(centre > 0.0) || centre >= rows) return false;
  if (!prior_moved_) {
    // The level prior stands where the mounting puts it: the ground under the camera. A
    // transversal slope through that ground leaves its offsets at the reference column as
    // they are and tilts them across it. (The background's edge may lie elsewhere: a crest
    // hides the ground beyond it.)
    ground.offset_per_column = static_cast<float>(per_column);
    return true;
  }
  // The prior moved to the background's edge of whole rows stands at the lowest point of a
  // slanted edge: it is placed on the fitted edge at the reference column instead.
  const int horizon = static_cast<int>(std::ceil(centre));
  // A band's row counts as the background while its features match within one offset of
  // the background's: the ground's rows do too until their offset passes it by one, so the
  // edge lies where the ground's offset is the background's plus one.
  const double at_edge = refinedBackground(background) + 1.0;
  for (int y = 0; y < rows; ++y)
    ground.offset_per_row[static_cast<std::size_t>(y)] =
        y < horizon ? background : static_cast<float>(at_edge + slope * (y - centre));
  ground.offset_per_column = static_cast<float>(per_column);
  ground.horizon_row = horizon;
  ground.vertices.clear();
  ground.vertices.emplace_back(background, 0.0f);
  ground.vertices.emplace_back(background, static_cast<float>(horizon));
  if (horizon < rows)
    ground.vertices.emplace_back(ground.offset_per_row[static_cast<std::size_t>(rows - 1)], static_cast<float>(rows - 1));
  return true;
}

void GroundEstimator::estimateRollReference(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                                            GroundProfile& ground) {
  if (!rollSetUp(left, rig, ground)) return;
  const int strips = params_.roll_strips;
  const int w = left.cols;
  const int search = params_.roll_search_px;
  const int bins = 2 * search + 1;
  const int tol = kRollGreyTolerance;
  for (int y = roll_first_row_; y < left.rows; ++y) {
    const float g = ground.offset_per_row[static_cast<std::size_t>(y)];
    if (!std::isfinite(g)) continue;
    const int base = static_cast<int>(std::lround(g));
    const std::uint8_t* l = left.ptr<std::uint8_t>(y);
    const std::uint8_t* r = right.ptr<std::uint8_t>(y);
    double* band_hist = &roll_hist_[static_cast<std::size_t>(rollBand(y) * strips * bins)];
    for (int k = 0; k < strips; ++k) {
      const int x0 = k * w / strips;
      const int x1 = (k + 1) * w / strips;
      for (int b = 0; b < bins; ++b) {
        const int d = base + b - search;
        if (d < 0) continue;
        const int from = std::max(x0, d);
        if (from >= x1) continue;
        band_hist[k * bins + b] += countRowMatches(l, r, from, x1, d, tol);
      }
    }
  }
  rollFit(w, ground);
}

void GroundEstimator::estimateRoll(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                                   GroundProfile& ground, const StripMatches* strip_matches) {
  if (!rollSetUp(left, rig, ground)) return;
  const int strips = params_.roll_strips;
  const int w = left.cols;
  const int search = params_.roll_search_px;
  const int bins = 2 * search + 1;
  const bool counted = strip_matches != nullptr && strip_matches->valid && strip_matches->strips == strips &&
                       strip_matches->rows == left.rows && strip_matches->cols == w &&
                       kRollGreyTolerance == strip_matches->grey_tolerance;
  roll_counts_.resize(static_cast<std::size_t>(simd::kLanes));
  // Right row with kLanes zeros in front: the window kernel reads up to kLanes - 1 before x - d_first.
  const int pad = simd::kLanes;
  roll_right_.resize(static_cast<std::size_t>(pad + w));
  std::fill(roll_right_.begin(), roll_right_.begin() + pad, std::uint8_t{0});
  std::uint8_t* rp = roll_right_.data() + pad;
  for (int y = roll_first_row_; y < left.rows; ++y) {
    const float g = ground.offset_per_row[static_cast<std::size_t>(y)];
    if (!std::isfinite(g)) continue;
    const int base = static_cast<int>(std::lround(g));
    const std::uint8_t* l = left.ptr<std::uint8_t>(y);
    double* band_hist = &roll_hist_[static_cast<std::size_t>(rollBand(y) * strips * bins)];
    if (counted && y >= strip_matches->first_row && base + search < strip_matches->offsets) {
      // The correlation's strip counts at the row's offsets (an offset beyond a strip's
      // columns counts nothing there, as in the reference).
      const int b_first = std::max(0, search - base);
      for (int k = 0; k < strips; ++k) {
        const int* c = strip_matches->at(y, k);
        double* h = band_hist + k * bins;
        for (int b = b_first; b < bins; ++b) h[b] += c[base - search + b];
      }
      continue;
    }
    std::memcpy(rp, right.ptr<std::uint8_t>(y), static_cast<std::size_t>(w));
    // Offsets base - search .. base + search, negative ones left out, in windows of kLanes.
    for (int b_first = std::max(0, search - base); b_first < bins; b_first += simd::kLanes) {
      const int count = std::min(simd::kLanes, bins - b_first);
      const int d_first = base + b_first - search;
      for (int k = 0; k < strips; ++k) {
        const int x0 = k * w / strips;
        const int x1 = (k + 1) * w / strips;
        if (std::max(x0, d_first) >= x1) continue;
        std::fill(roll_counts_.begin(), roll_counts_.end(), 0);
        simd::accumulateMatchesWindow(l, rp, x0, x1, d_first, count, kRollGreyTolerance, roll_counts_.data());
        double* h = band_hist + k * bins + b_first;
        for (int i = 0; i < count; ++i) h[i] += roll_counts_[static_cast<std::size_t>(i)];
      }
    }
  }
  rollFit(w, ground);
}

namespace {
constexpr double kBandAgreementPx = 0.5;  // strips of a band within this of its line agree
constexpr int kMinAgreeingStrips = 4;

// The peak of one strip's match histogram around the line: its sub-pixel position relative to
// the line (parabola through the peak and its neighbours) and its height above the histogram's
// median. False when the strip shows no peak inside the searched offsets.
bool stripPeak(const double* h, int bins, std::vector<double>& sorted, double& delta, double& excess) {
  const int best = static_cast<int>(std::max_element(h, h + bins) - h);
  sorted.assign(h, h + bins);
  std::nth_element(sorted.begin(), sorted.begin() + bins / 2, sorted.end());
  excess = h[best] - sorted[static_cast<std::size_t>(bins / 2)];
  if (excess <= 0.0 || best == 0 || best == bins - 1) return false;
  delta = best - bins / 2 + parabolaPeakShift(h[best - 1], h[best], h[best + 1]);
  return true;
}
}  // namespace

void GroundEstimator::collectStrips(const double* hist, int width, float reference_column, double roll) {
  const int strips = params_.roll_strips;
  const int bins = 2 * params_.roll_search_px + 1;
  band_column_.clear();
  band_residual_.clear();
  band_weight_.clear();
  for (int k = 0; k < strips; ++k) {
    double delta = 0.0, excess = 0.0;
    if (!stripPeak(hist + k * bins, bins, roll_sorted_, delta, excess)) continue;
    const double xc = (k + 0.5) * width / strips - static_cast<double>(reference_column);
    band_column_.push_back(xc);
    band_residual_.push_back(delta - roll * xc);
    band_weight_.push_back(excess);
  }
}

bool GroundEstimator::fitBandLine(double max_deviation, double& shift, double& tilt, int min_strips) const {
  double sw = 0, sx = 0, sr = 0, sxx = 0, sxr = 0;
  int used = 0;
  for (std::size_t i = 0; i < band_residual_.size(); ++i) {
    const double x = band_column_[i];
    const double r = band_residual_[i];
    if (std::abs(r - shift - tilt * x) > max_deviation) continue;
    const double w = band_weight_[i];
    sw += w;
    sx += w * x;
    sr += w * r;
    sxx += w * x * x;
    sxr += w * x * r;
    ++used;
  }
  const double det = sw * sxx - sx * sx;
  if (used < min_strips || std::abs(det) < 1e-9) return false;
  tilt = (sw * sxr - sx * sr) / det;
  shift = (sr - tilt * sx) / sw;
  return true;
}

bool GroundEstimator::fitStrips(double& shift, double& tilt) const {
  // Fitted twice: the second time without the strips farther than 2 px from the first fit
  // (an obstacle or a raised kerb filling a strip). The strips must then agree: most of the
  // weight within kBandAgreementPx of the line (on weak texture the peaks are noise).
  shift = 0.0;
  tilt = 0.0;
  if (!fitBandLine(std::numeric_limits<double>::infinity(), shift, tilt, kMinAgreeingStrips) ||
      !fitBandLine(2.0 * kBandAgreementPx, shift, tilt, kMinAgreeingStrips))
    return false;
  double total = 0.0, agreeing = 0.0;
  int agreeing_strips = 0;
  for (std::size_t i = 0; i < band_residual_.size(); ++i) {
    total += band_weight_[i];
    if (std::abs(band_residual_[i] - shift - tilt * band_column_[i]) <= kBandAgreementPx) {
      agreeing += band_weight_[i];
      ++agreeing_strips;
    }
  }
  return agreeing_strips >= kMinAgreeingStrips && agreeing >= 0.5 * total;
}

void GroundEstimator::rollFitWhole(int w, GroundProfile& ground) {
  // One line through the strips' peaks over all ground rows, weighted by the peaks' heights.
  collectStrips(roll_total_.data(), w, ground.reference_column, 0.0);
  double shift = 0.0, slope = 0.0;
  if (!fitBandLine(std::numeric_limits<double>::infinity(), shift, slope, 3)) return;
  if (std::abs(slope) * w < params_.min_roll_px) return;
  ground.offset_per_column = static_cast<float>(slope);
  // On a transversal slope the row's correlation peak is smeared over the offsets the row
  // spans, and the line follows wherever the ground shows most: the strips' fit says where the
  // line lies at the reference column, and the whole line moves there (rows keep their spacing).
  // A prior comes from the mounting, not from this smeared peak: it stays where it is.
  if (ground.source != GroundSource::kHough || !std::isfinite(shift) || std::abs(shift) < 0.5 ||
      std::abs(shift) > params_.roll_search_px)
    return;
  const float s = static_cast<float>(shift);
  for (std::size_t y = static_cast<std::size_t>(std::max(ground.horizon_row, 0)); y < ground.offset_per_row.size(); ++y)
    if (std::isfinite(ground.offset_per_row[y])) ground.offset_per_row[y] += s;
  for (cv::Point2f& v : ground.vertices)
    if (v.y >= static_cast<float>(ground.horizon_row)) v.x += s;
}

void GroundEstimator::rollFit(int w, GroundProfile& ground) {
  const int strips = params_.roll_strips;
  const int search = params_.roll_search_px;
  const int bins = 2 * search + 1;
  const std::size_t per_band = static_cast<std::size_t>(strips * bins);
  roll_total_.assign(per_band, 0.0);
  for (int b = 0; b < roll_bands_; ++b)
    for (std::size_t i = 0; i < per_band; ++i) roll_total_[i] += roll_hist_[static_cast<std::size_t>(b) * per_band + i];
  if (params_.profile_band_rows <= 0) {
    rollFitWhole(w, ground);
    return;
  }
  // The transversal slope: a line through the strips' peaks over all ground rows. Not where
  // the ground line itself could not be measured (the prior, a previous frame's line): on
  // weak ground texture the strips' peaks are mostly the objects'.
  if (ground.source != GroundSource::kHough) return;
  collectStrips(roll_total_.data(), w, ground.reference_column, 0.0);
  double offset = 0.0, slope = 0.0;
  if (!fitStrips(offset, slope)) return;
  if (std::abs(slope) * w >= params_.min_roll_px)
    ground.offset_per_column = static_cast<float>(slope);
  else
    slope = 0.0;
  // Band by band: where the ground lies beside the line at the reference column. The line is
  // a compromise wherever the ground bends (a slope change the second segment did not catch,
  // the smeared row peaks of a transversal slope); each band's strips, the roll taken out,
  // measure the shift there, with the band's own tilt (where the ground bends, its
  // transversal slope changes too).
  const int rows = static_cast<int>(ground.offset_per_row.size());
  band_fits_.clear();
  // Band 0, next to the horizon, is not used: its rows are a few offsets apart, its texture is
  // fine, and the far objects standing there pull its strips nearer (on the generated scenes
  // band 1's shift carried up was nearer the truth there than band 0's own).
  for (int b = 1; b < roll_bands_; ++b) {
    collectStrips(&roll_hist_[static_cast<std::size_t>(b) * per_band], w, ground.reference_column, slope);
    double shift = 0.0, tilt = 0.0;
    if (!fitStrips(shift, tilt)) continue;
    const int first = roll_first_row_ + b * params_.profile_band_rows;
    const int last = b == roll_bands_ - 1 ? rows - 1 : first + params_.profile_band_rows - 1;
    // Moved that far, the band's ground would meet the background inside the band: its strips
    // matched the hills beyond a crest (the far ground hidden), not the ground.
    if (params_.band_above_background && std::isfinite(ground.background_offset) && first >= 0 && first < rows &&
        static_cast<double>(ground.offset_per_row[static_cast<std::size_t>(first)]) + shift <=
            static_cast<double>(ground.background_offset) + params_.support_tolerance_px)
      continue;
    band_fits_.push_back(BandFit{0.5f * static_cast<float>(first + last), static_cast<float>(shift),
                                 static_cast<float>(slope + tilt)});
  }
  if (band_fits_.empty()) return;
  // Between band centres the shifts and slopes are interpolated, beyond the outer ones kept.
  auto interpolate = [&](float y, float BandFit::*value) {
    if (y <= band_fits_.front().row) return band_fits_.front().*value;
    for (std::size_t i = 1; i < band_fits_.size(); ++i) {
      const BandFit& a = band_fits_[i - 1];
      const BandFit& b = band_fits_[i];
      if (y <= b.row) return a.*value + (b.*value - a.*value) * (y - a.row) / (b.row - a.row);
    }
    return band_fits_.back().*value;
  };
  const int horizon = std::max(ground.horizon_row, 0);
  for (int y = horizon; y < rows; ++y) {
    float& d = ground.offset_per_row[static_cast<std::size_t>(y)];
    if (std::isfinite(d)) d += interpolate(static_cast<float>(y), &BandFit::shift);
  }
  // The transversal slope per row, where any band's differs measurably from none.
  const bool tilted = std::any_of(band_fits_.begin(), band_fits_.end(), [&](const BandFit& f) {
    return std::abs(static_cast<double>(f.tilt)) * w >= params_.min_roll_px;
  });
  if (tilted) {
    ground.offset_per_column_by_row.assign(static_cast<std::size_t>(rows), ground.offset_per_column);
    for (int y = horizon; y < rows; ++y)
      ground.offset_per_column_by_row[static_cast<std::size_t>(y)] = interpolate(static_cast<float>(y), &BandFit::tilt);
  }
  // The horizon follows the corrected line: rows now nearer than the background belong to it.
  int new_horizon = horizon;
  if (std::isfinite(ground.background_offset))
    while (new_horizon < rows && ground.offset_per_row[static_cast<std::size_t>(new_horizon)] < ground.background_offset)
      ground.offset_per_row[static_cast<std::size_t>(new_horizon++)] = ground.background_offset;
  ground.horizon_row = new_horizon;
  // The polyline: the background, then the ground at its old vertices and at the band centres.
  vertex_rows_.clear();
  for (const cv::Point2f& v : ground.vertices) vertex_rows_.push_back(static_cast<int>(std::lround(v.y)));
  for (const BandFit& f : band_fits_) vertex_rows_.push_back(static_cast<int>(std::lround(f.row)));
  vertex_rows_.push_back(rows - 1);
  std::sort(vertex_rows_.begin(), vertex_rows_.end());
  vertex_rows_.erase(std::unique(vertex_rows_.begin(), vertex_rows_.end()), vertex_rows_.end());
  ground.vertices.clear();
  if (std::isfinite(ground.background_offset)) {
    ground.vertices.emplace_back(ground.background_offset, 0.0f);
    ground.vertices.emplace_back(ground.background_offset, static_cast<float>(new_horizon));
  }
  for (const int y : vertex_rows_)
    if (y > new_horizon && y < rows)
      ground.vertices.emplace_back(ground.offset_per_row[static_cast<std::size_t>(y)], static_cast<float>(y));
}

void GroundEstimator::compute(const cv::Mat& score, const cv::Mat& matches, const StereoRig& rig,
                              const GroundProfile* previous, int previous_age_frames, GroundProfile& out,
                              bool refuse_measured) {
  computeImpl(score, matches, rig, previous, previous_age_frames, out, false, refuse_measured);
}

void GroundEstimator::computeReference(const cv::Mat& score, const cv::Mat& matches, const StereoRig& rig,
                                       const GroundProfile* previous, int previous_age_frames, GroundProfile& out,
                                       bool refuse_measured) {
  computeImpl(score, matches, rig, previous, previous_age_frames, out, true, refuse_measured);
}

void GroundEstimator::computeImpl(const cv::Mat& score, const cv::Mat& matches, const StereoRig& rig,
                                  const GroundProfile* previous, int previous_age_frames, GroundProfile& out,
                                  bool reference, bool refuse_measured) {
  auto houghOf = [&](const std::vector<std::uint8_t>& use, int rows, int offsets) {
    return reference ? hough(use, rows, offsets) : houghFast(use, rows, offsets);
  };
  if (score.empty() || score.type() != CV_32F) throw InputError("ground: the correlation image must be CV_32F");
  if (!matches.empty() && (matches.type() != CV_32S || matches.size() != score.size()))
    throw InputError("ground: the correlation's counts must be CV_32S of the score's size");
  // The background's rows: matches over at least background_row_share of the width's pixels.
  const double width = rig.width > 0 ? rig.width : score.cols;
  per_match_ = static_cast<float>(1.0 / std::max(1.0, params_.background_row_share * width));
  const int rows = score.rows;
  const int offsets = score.cols;
  main_line_.reset();
  second_line_.reset();
  main_hough_.reset();
  second_hough_.reset();
  needs_corroboration_ = false;
  if (reference)
    findPeaksReference(score);
  else
    findPeaks(score);

  use_.assign(peaks_.size(), 1);
  std::optional<GroundLine> l1 = houghOf(use_, rows, offsets);
  main_hough_ = l1;
  bool measured = false;
  if (l1) {
    int row_begin = static_cast<int>(std::ceil(l1->horizon_row));
    *l1 = refit(*l1, row_begin, rows);
    row_begin = static_cast<int>(std::ceil(l1->horizon_row));
    int crossed = 0;
    l1->support_rows = support(*l1, row_begin, rows, offsets, &crossed);
    measured = l1->support_rows >= params_.min_support_rows &&
               l1->support_rows >= params_.min_support_fraction * crossed;
    needs_corroboration_ = measured && l1->support_rows < params_.corroborated_support_fraction * crossed;
    if (refuse_measured) measured = false;
  }

  out.offset_per_row.assign(static_cast<std::size_t>(rows), GroundProfile::kUnknown);
  out.vertices.clear();
  out.offset_per_column = 0.0f;

  double junction = -1.0;
  if (measured) {
    main_line_ = l1;
    bool second_far = false;  // second segment above (farther than) the junction
    std::optional<double> ground_floor;  // groundFloor of the line, once either test needs it
    if (params_.piecewise) {
      const double tol = 2.0 * params_.support_tolerance_px;
      for (std::size_t i = 0; i < peaks_.size(); ++i) {
        const Peak& p = peaks_[i];
        use_[i] = p.row > l1->horizon_row && std::abs(p.offset - l1->offsetAt(p.row)) > tol;
      }
      std::optional<GroundLine> l2 = houghOf(use_, rows, offsets);
      second_hough_ = l2;
      if (l2 && std::abs(l2->slope - l1->slope) > 0.05 * l1->slope) {
        const double yj = l1->junctionRow(*l2);
        const int top = static_cast<int>(std::ceil(std::min(l1->horizon_row, l2->horizon_row)));
        if (yj > top && yj < rows - 1) {
          const int j = static_cast<int>(std::ceil(yj));
          const int a1 = support(*l1, top, j, offsets, nullptr);
          const int a2 = support(*l2, top, j, offsets, nullptr);
          const int b1 = support(*l1, j, rows, offsets, nullptr);
          const int b2 = support(*l2, j, rows, offsets, nullptr);
          if ((a2 > a1 && a2 >= params_.min_segment_rows) ||
              farSegmentWinsOnItsRows(score, matches, *l1, *l2, top, j, ground_floor)) {
            second_far = true;
            *l2 = refit(*l2, top, j);
            l2->support_rows = support(*l2, top, j, offsets, nullptr);
          } else if (b2 > b1 && b2 >= params_.min_segment_rows) {
            *l2 = refit(*l2, j, rows);
            l2->support_rows = support(*l2, j, rows, offsets, nullptr);
          } else {
            l2.reset();
          }
          if (l2 && std::abs(l2->slope - l1->slope) > 1e-6) {
            junction = l1->junctionRow(*l2);
            if (junction > top && junction < rows - 1) second_line_ = l2;
          }
        }
      }
      // Unless the line is the far part and the second segment the near one, a far segment
      // meeting the line where it explains more rows than the line's extension replaces it.
      if ((!second_line_ || second_far) && params_.far_segment_search && !needs_corroboration_) {
        // farSegment returns only a segment whose junction lies inside the ground rows.
        if (std::optional<GroundLine> far = farSegment(score, matches, *l1, ground_floor)) {
          second_line_ = far;
          second_far = true;
          junction = l1->junctionRow(*far);
        }
      }
    }
    auto ground = [&](double y) {
      if (second_line_ && (second_far ? y < junction : y >= junction)) return second_line_->offsetAt(y);
      return main_line_->offsetAt(y);
    };
    for (int y = 0; y < rows; ++y) out.offset_per_row[static_cast<std::size_t>(y)] = static_cast<float>(ground(y));
    out.source = GroundSource::kHough;
  } else if (params_.prefer_previous && previous && previous->source == GroundSource::kHough &&
             previous_age_frames <= params_.max_previous_age_frames &&
             static_cast<int>(previous->offset_per_row.size()) == rows) {
    // The previous line keeps its ground part; the background is measured again below.
    for (int y = 0; y < rows; ++y) {
      const float d = previous->offset_per_row[static_cast<std::size_t>(y)];
      out.offset_per_row[static_cast<std::size_t>(y)] = y >= previous->horizon_row ? d : -1.0f;
    }
    // Extend the ground part above the old horizon with its own slope (two lowest rows).
    const int yh = std::max(previous->horizon_row, 0);
    if (yh + 1 < rows) {
      const float slope = out.offset_per_row[static_cast<std::size_t>(rows - 1)] -
                          out.offset_per_row[static_cast<std::size_t>(rows - 2)];
      for (int y = yh - 1; y >= 0; --y)
        out.offset_per_row[static_cast<std::size_t>(y)] = out.offset_per_row[static_cast<std::size_t>(y) + 1] - slope;
    }
    out.source = GroundSource::kPrevious;
  } else if (rig.mounting) {
    for (int y = 0; y < rows; ++y)
      out.offset_per_row[static_cast<std::size_t>(y)] = static_cast<float>(rig.groundOffsetPrior(y));
    out.source = GroundSource::kPrior;
  } else {
    out.source = GroundSource::kNone;
    out.horizon_row = -1;
    out.background_offset = GroundProfile::kUnknown;
    return;
  }

  // Background: the offset dominating the rows where the ground would be farther than 1 px.
  int rows_above = 0;
  while (rows_above < rows && out.offset_per_row[static_cast<std::size_t>(rows_above)] < 1.0f) ++rows_above;
  const float background = backgroundOffset(score, matches, rows_above, out.offset_per_row);
  int horizon = 0;
  while (horizon < rows && out.offset_per_row[static_cast<std::size_t>(horizon)] < background) ++horizon;
  for (int y = 0; y < horizon; ++y) out.offset_per_row[static_cast<std::size_t>(y)] = background;
  // The prior is level ground at the rig's height and pitch. On a slope the ground meets the
  // background at another row: where the background's features end. The prior moved along
  // the rows to meet it there replaces the prior when the level one is refuted (many rows show
  // something farther than its ground), or when neither is and more rows support it (a crest
  // hiding the far ground also moves the edge, while the near ground stays level).
  prior_moved_ = false;
  if (out.source == GroundSource::kPrior && params_.prior_background_edge && background > 0.0f) {
    const int edge = backgroundEdgeRow(score, background);
    const double slope = rig.groundOffsetPrior(1.0) - rig.groundOffsetPrior(0.0);
    if (edge > 0 && edge < rows && edge != horizon && slope > 0.0) {
      const GroundLine level{slope, -rig.groundOffsetPrior(0.0) / slope, 0};
      // The ground meets the background at the edge row, at the background's offset to a
      // fraction of a pixel (the background line itself keeps its whole offset).
      const GroundLine moved{slope, static_cast<double>(edge) - refinedBackground(background) / slope, 0};
      const int beyond_level = rowsBeyond(level, horizon, rows, background);
      const int beyond_moved = rowsBeyond(moved, edge, rows, background);
      auto refuted = [&](int beyond, int other) {
        return beyond >= params_.min_support_rows && beyond >= params_.refuting_ratio * other;
      };
      const bool use_moved =
          refuted(beyond_level, beyond_moved) ||
          (!refuted(beyond_moved, beyond_level) &&
           support(moved, edge, rows, offsets, nullptr) > support(level, horizon, rows, offsets, nullptr));
      prior_moved_ = use_moved;
      if (use_moved) {
        for (int y = 0; y < rows; ++y)
          out.offset_per_row[static_cast<std::size_t>(y)] = y < edge ? background : static_cast<float>(moved.offsetAt(y));
        horizon = edge;
      }
    }
  }
  out.background_offset = background;
  out.horizon_row = horizon;
  out.vertices.emplace_back(background, 0.0f);
  out.vertices.emplace_back(background, static_cast<float>(horizon));
  if (second_line_) {
    const int j = static_cast<int>(std::ceil(junction));
    if (j > horizon && j < rows) out.vertices.emplace_back(out.offset_per_row[static_cast<std::size_t>(j)], static_cast<float>(j));
  }
  if (horizon < rows)
    out.vertices.emplace_back(out.offset_per_row[static_cast<std::size_t>(rows - 1)], static_cast<float>(rows - 1));
}

}  // namespace sg
