#include "vision/correlation.hpp"

#include <algorithm>
#include <cstring>

#include "config/errors.hpp"
#include "vision/parallel_bands.hpp"
#include "vision/simd_match.hpp"

namespace sg {

int countRowMatches(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d, int grey_tolerance) {
  // Branch-free on bytes so the compiler vectorises it: min(a, b) != 0 means both are
  // feature pixels, max - min is the grey difference without a sign.
  const std::uint8_t tol = static_cast<std::uint8_t>(grey_tolerance);
  const std::uint8_t* r = right - d;
  int count = 0;
  int x = x0;
  // Blocks of at most 255 with a byte accumulator keep the vector loop narrow.
  while (x < x1) {
    const int end = std::min(x1, x + 255);
    std::uint8_t block = 0;
    for (int i = x; i < end; ++i) {
      const std::uint8_t a = left[i];
      const std::uint8_t b = r[i];
      const std::uint8_t lo = a < b ? a : b;
      const std::uint8_t hi = a < b ? b : a;
      block = static_cast<std::uint8_t>(block + ((lo != 0) & (static_cast<std::uint8_t>(hi - lo) <= tol)));
    }
    count += block;
    x = end;
  }
  return count;
}

Correlator::Correlator(const CorrelationParams& params) : params_(params) { params_.validate(); }

void Correlator::prepare(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches) const {
  if (left.empty() || left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size())
    throw InputError("correlation: feature images must be non-empty mono8 of the same size");
  score.create(left.rows, params_.offsets, CV_32F);
  matches.create(left.rows, params_.offsets, CV_32S);
}

void Correlator::correlateRow(const cv::Mat& left, const cv::Mat& right, int y, cv::Mat& score,
                              cv::Mat& matches) const {
  const int w = left.cols;
  const int offsets = params_.offsets;
  const std::uint8_t* l = left.ptr<std::uint8_t>(y);
  const std::uint8_t* r = right.ptr<std::uint8_t>(y);
  float* s = score.ptr<float>(y);
  int* m = matches.ptr<int>(y);
  // Only the span between the first and last feature pixel of each row can match.
  int l0 = 0, l1 = w, r0 = 0, r1 = w;
  while (l0 < w && l[l0] == 0) ++l0;
  while (l1 > l0 && l[l1 - 1] == 0) --l1;
  while (r0 < w && r[r0] == 0) ++r0;
  while (r1 > r0 && r[r1 - 1] == 0) --r1;
  int n_left = 0;
  for (int x = l0; x < l1; ++x) n_left += l[x] != 0;
  const float norm = static_cast<float>(std::max(n_left, params_.min_row_features));
  for (int d = 0; d < offsets; ++d) {
    int count = 0;
    if (n_left > 0 && r0 < r1) {
      const int x0 = std::max({d, l0, r0 + d});
      const int x1 = std::min(l1, r1 + d);
      if (x0 < x1) count = countRowMatches(l, r, x0, x1, d, params_.grey_tolerance);
    }
    m[d] = count;
    s[d] = static_cast<float>(count) / norm;
  }
}

void Correlator::correlateRowFast(const cv::Mat& left, const cv::Mat* before, const cv::Mat& right, int y,
                                  cv::Mat& score, cv::Mat& matches, std::vector<std::uint8_t>& padded_right,
                                  bool with_strips) {
  const int w = left.cols;
  const int offsets = params_.offsets;
  const int tol = params_.grey_tolerance;
  const std::uint8_t* l = left.ptr<std::uint8_t>(y);
  float* s = score.ptr<float>(y);
  int* m = matches.ptr<int>(y);
  // The span between the first and last feature pixel, and their number (vector passes).
  const simd::ByteSpan features = simd::nonZeroSpan(l, w);
  const int l0 = features.first, l1 = features.end, n_left = features.count;

  // Update from `before`: valid when every pixel of `left` is the `before` pixel or 0.
  const std::uint8_t* b = before != nullptr ? before->ptr<std::uint8_t>(y) : nullptr;
  int n_removed = 0, b0 = w, b1 = 0;
  if (b != nullptr) {
    bool subset = false;
    const simd::ByteSpan removed = simd::removedSpan(l, b, w, subset);
    if (!subset) {
      b = nullptr;  // not a removal: recompute the row
    } else if (removed.count > 0) {
      n_removed = removed.count;
      b0 = removed.first;
      b1 = removed.end;
    }
  }
  if (b == nullptr || n_removed > 0) {
    const int pad = simd::rightPadding(offsets);
    if (padded_right.size() < static_cast<std::size_t>(pad + w)) padded_right.resize(static_cast<std::size_t>(pad + w));
    std::uint8_t* rp = padded_right.data() + pad;
    std::memset(padded_right.data(), 0, static_cast<std::size_t>(pad));
    std::memcpy(rp, right.ptr<std::uint8_t>(y), static_cast<std::size_t>(w));
    if (b != nullptr && n_removed < n_left) {
      // Count the removed pixels (in `before`, 0 in `left`) out: m = -(-m + removed).
      for (int d = 0; d < offsets; ++d) m[d] = -m[d];
      simd::accumulateMatches(b, l, rp, b0, b1, offsets, tol, m);
      for (int d = 0; d < offsets; ++d) m[d] = -m[d];
    } else {
      std::fill(m, m + offsets, 0);
      if (with_strips) {
        // Strip by strip (the same pixels, split at the strips' borders), each flushed into its
        // own counts and the row's.
        const int strips = strips_.strips;
        int* c = strips_.counts.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(strips) *
                                             static_cast<std::size_t>(offsets);
        simd::accumulateMatchesStrips(l, rp, l0, l1, offsets, tol, strip_bounds_.data(), strips, c, m);
      } else {
        simd::accumulateMatches(l, nullptr, rp, l0, l1, offsets, tol, m);
      }
    }
  }
  const float norm = static_cast<float>(std::max(n_left, params_.min_row_features));
  for (int d = 0; d < offsets; ++d) s[d] = static_cast<float>(m[d]) / norm;
}

std::vector<std::uint8_t>& Correlator::bandScratch(int band) { return band_scratch_[static_cast<std::size_t>(band)]; }

template <class Fn>
void Correlator::forEachRow(int rows, Fn&& fn) {
  const int band = params_.band_rows;
  const int bands = (rows + band - 1) / band;
  if (static_cast<int>(band_scratch_.size()) < bands) band_scratch_.resize(static_cast<std::size_t>(bands));
  forEachBand(bands, [&](int k) {
    std::vector<std::uint8_t>& scratch = bandScratch(k);
    const int y1 = std::min((k + 1) * band, rows);
    for (int y = k * band; y < y1; ++y) fn(y, scratch);
  });
}

void Correlator::computeReference(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches) {
  prepare(left, right, score, matches);
  strips_.valid = false;
  for (int y = 0; y < left.rows; ++y) correlateRow(left, right, y, score, matches);
}

void Correlator::compute(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches) {
  prepare(left, right, score, matches);
  const bool with_strips = strip_count_ > 0;
  strips_.valid = false;
  if (with_strips) {  // kept between frames of one size
    strips_.strips = strip_count_;
    strips_.rows = left.rows;
    strips_.cols = left.cols;
    strips_.offsets = params_.offsets;
    strips_.grey_tolerance = params_.grey_tolerance;
    strips_.first_row = std::clamp(strip_first_row_, 0, left.rows);
    strips_.counts.resize(static_cast<std::size_t>(left.rows) * static_cast<std::size_t>(strip_count_) *
                          static_cast<std::size_t>(params_.offsets));
    strip_bounds_.resize(static_cast<std::size_t>(strip_count_) + 1);
    for (int k = 0; k <= strip_count_; ++k) strip_bounds_[static_cast<std::size_t>(k)] = k * left.cols / strip_count_;
  }
  forEachRow(left.rows, [&](int y, std::vector<std::uint8_t>& scratch) {
    correlateRowFast(left, nullptr, right, y, score, matches, scratch, with_strips && y >= strips_.first_row);
  });
  strips_.valid = with_strips;
}

void Correlator::compute(const cv::Mat& left, const cv::Mat& right, cv::Mat& score) {
  compute(left, right, score, scratch_matches_);
}

void Correlator::computeRows(const cv::Mat& left, const cv::Mat& right, const std::vector<std::uint8_t>& rows,
                             cv::Mat& score, cv::Mat& matches) {
  if (score.rows != left.rows || score.cols != params_.offsets || score.type() != CV_32F ||
      matches.size() != score.size() || matches.type() != CV_32S || static_cast<int>(rows.size()) != left.rows) {
    compute(left, right, score, matches);
    return;
  }
  prepare(left, right, score, matches);
  strips_.valid = false;
  forEachRow(left.rows, [&](int y, std::vector<std::uint8_t>& scratch) {
    if (rows[static_cast<std::size_t>(y)] != 0) correlateRowFast(left, nullptr, right, y, score, matches, scratch);
  });
}

void Correlator::updateRows(const cv::Mat& before, const cv::Mat& after, const cv::Mat& right,
                            const std::vector<std::uint8_t>& rows, cv::Mat& score, cv::Mat& matches) {
  if (before.size() != after.size() || before.type() != CV_8UC1) {
    throw InputError("correlation: the image before removal must be mono8 of the same size as after it");
  }
  if (score.rows != after.rows || score.cols != params_.offsets || score.type() != CV_32F ||
      matches.size() != score.size() || matches.type() != CV_32S || static_cast<int>(rows.size()) != after.rows) {
    compute(after, right, score, matches);
    return;
  }
  prepare(after, right, score, matches);
  strips_.valid = false;
  forEachRow(after.rows, [&](int y, std::vector<std::uint8_t>& scratch) {
    if (rows[static_cast<std::size_t>(y)] != 0) correlateRowFast(after, &before, right, y, score, matches, scratch);
  });
}

}  // namespace sg
