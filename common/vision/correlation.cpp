#include "vision/correlation.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "config/errors.hpp"

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

void Correlator::computeReference(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches) {
  prepare(left, right, score, matches);
  for (int y = 0; y < left.rows; ++y) correlateRow(left, right, y, score, matches);
}

void Correlator::compute(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches) {
  prepare(left, right, score, matches);
  const int band = params_.band_rows;
  const int bands = (left.rows + band - 1) / band;
  tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& range) {
    for (int b = range.begin(); b != range.end(); ++b) {
      const int y1 = std::min((b + 1) * band, left.rows);
      for (int y = b * band; y < y1; ++y) correlateRow(left, right, y, score, matches);
    }
  });
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
  const int band = params_.band_rows;
  const int bands = (left.rows + band - 1) / band;
  tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& range) {
    for (int b = range.begin(); b != range.end(); ++b) {
      const int y1 = std::min((b + 1) * band, left.rows);
      for (int y = b * band; y < y1; ++y)
        if (rows[static_cast<std::size_t>(y)] != 0) correlateRow(left, right, y, score, matches);
    }
  });
}

}  // namespace sg
