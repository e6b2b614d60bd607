#include "vision/symmetry.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"
#include "vision/parallel_bands.hpp"
#include "vision/simd_match.hpp"

namespace sg {

namespace {

// A box of half-width k and this height fits the search's height and aspect limits.
bool admissible(const SymmetrySearch& search, int k, int height) {
  if (height < search.min_height_px || height > search.max_height_px) return false;
  const double aspect = static_cast<double>(height) / (2 * k + 1);
  return aspect >= search.min_aspect && aspect <= search.max_aspect;
}

// Sum of a CV_64F integral image over rows [r0, r1] and columns [c0, c1] (inclusive).
double boxSum(const cv::Mat& integral, int r0, int r1, int c0, int c1) {
  return integral.at<double>(r1 + 1, c1 + 1) - integral.at<double>(r0, c1 + 1) - integral.at<double>(r1 + 1, c0) +
         integral.at<double>(r0, c0);
}

// Index i of n rows or columns, reflected at the border (BORDER_REFLECT_101).
int reflect101(int i, int n) {
  if (n == 1) return 0;
  if (i < 0) return -i;
  if (i >= n) return 2 * n - 2 - i;
  return i;
}

// |gx| + |gy| of the 3x3 Sobel at column c of rows up / mid / down, whose left and right
// neighbours are columns cl and cr.
int sobelMagnitude(const std::uint8_t* up, const std::uint8_t* mid, const std::uint8_t* down, int c, int cl, int cr) {
  const int gx = (up[cr] + 2 * mid[cr] + down[cr]) - (up[cl] + 2 * mid[cl] + down[cl]);
  const int gy = (down[cl] + 2 * down[c] + down[cr]) - (up[cl] + 2 * up[c] + up[cr]);
  return std::abs(gx) + std::abs(gy);
}

}  // namespace

SymmetryScanner::SymmetryScanner(const SymmetryParams& params) : params_(params) { params_.validate(); }

void SymmetryScanner::edgeWeightsReference(const cv::Mat& grey, const cv::Mat& cluster_mask, cv::Mat& weights) const {
  if (grey.type() != CV_8UC1) throw InputError("symmetry: grey region must be CV_8UC1");
  if (!cluster_mask.empty() && (cluster_mask.size() != grey.size() || cluster_mask.type() != CV_8UC1)) {
    throw InputError("symmetry: cluster mask must be CV_8UC1 of the region's size");
  }
  cv::Mat gx, gy;
  cv::Sobel(grey, gx, CV_16S, 1, 0, 3);
  cv::Sobel(grey, gy, CV_16S, 0, 1, 3);
  weights.create(grey.size(), CV_32FC1);
  const float outside = cluster_mask.empty() ? 1.0f : params_.outside_cluster_edge_weight;
  const float inv_full = 1.0f / (params_.full_weight_ratio * static_cast<float>(params_.edge_threshold));
  for (int r = 0; r < grey.rows; ++r) {
    const auto* px = gx.ptr<std::int16_t>(r);
    const auto* py = gy.ptr<std::int16_t>(r);
    const std::uint8_t* m = cluster_mask.empty() ? nullptr : cluster_mask.ptr<std::uint8_t>(r);
    auto* w = weights.ptr<float>(r);
    for (int c = 0; c < grey.cols; ++c) {
      const int mag = std::abs(static_cast<int>(px[c])) + std::abs(static_cast<int>(py[c]));
      if (mag < params_.edge_threshold) {
        w[c] = 0.0f;
      } else {
        // Strong edges (silhouettes) count more than weak texture: weight ramps to 1 at full_weight_ratio x threshold.
        const float strength = std::min(1.0f, static_cast<float>(mag) * inv_full);
        w[c] = strength * ((m == nullptr || m[c] != 0) ? 1.0f : outside);
      }
    }
  }
}

void SymmetryScanner::edgeWeights(const cv::Mat& grey, const cv::Mat& cluster_mask, cv::Mat& weights) const {
  if (grey.type() != CV_8UC1) throw InputError("symmetry: grey region must be CV_8UC1");
  if (!cluster_mask.empty() && (cluster_mask.size() != grey.size() || cluster_mask.type() != CV_8UC1)) {
    throw InputError("symmetry: cluster mask must be CV_8UC1 of the region's size");
  }
  weights.create(grey.size(), CV_32FC1);
  if (grey.empty()) return;
  // The region's place in its image: cv::Sobel reads the image's pixels around a
  // region and reflects (BORDER_REFLECT_101) only at the image's own border.
  cv::Size whole;
  cv::Point ofs;
  grey.locateROI(whole, ofs);
  const std::size_t step = grey.step[0];
  const float outside = cluster_mask.empty() ? 1.0f : params_.outside_cluster_edge_weight;
  const std::uint32_t one_bits = std::bit_cast<std::uint32_t>(1.0f);
  const std::uint32_t outside_bits = std::bit_cast<std::uint32_t>(outside);
  const float inv_full = 1.0f / (params_.full_weight_ratio * static_cast<float>(params_.edge_threshold));
  const int threshold = params_.edge_threshold;
  const int cols = grey.cols;
  const int left_col = reflect101(ofs.x - 1, whole.width) - ofs.x;          // region column of the left neighbour of 0
  const int right_col = reflect101(ofs.x + cols, whole.width) - ofs.x;      // ... of the right neighbour of cols - 1
  for (int r = 0; r < grey.rows; ++r) {
    // Rows above and below, as pointers relative to the region's row 0 (inside the parent image).
    const std::uint8_t* base = grey.ptr<std::uint8_t>(0);
    const auto* up = base + static_cast<std::ptrdiff_t>(reflect101(ofs.y + r - 1, whole.height) - ofs.y) *
                                static_cast<std::ptrdiff_t>(step);
    const auto* mid = base + static_cast<std::ptrdiff_t>(r) * static_cast<std::ptrdiff_t>(step);
    const auto* down = base + static_cast<std::ptrdiff_t>(reflect101(ofs.y + r + 1, whole.height) - ofs.y) *
                                  static_cast<std::ptrdiff_t>(step);
    const std::uint8_t* m = cluster_mask.empty() ? nullptr : cluster_mask.ptr<std::uint8_t>(r);
    auto* w = weights.ptr<float>(r);
    auto pixel = [&](int c, int cl, int cr) {
      const int mag = sobelMagnitude(up, mid, down, c, cl, cr);
      const float strength = std::min(1.0f, static_cast<float>(mag) * inv_full);
      const float factor = (m == nullptr || m[c] != 0) ? 1.0f : outside;
      w[c] = mag < threshold ? 0.0f : strength * factor;
    };
    pixel(0, left_col, cols > 1 ? 1 : right_col);
    // Interior columns: no border test, a branch-free body for the vectoriser.
    for (int c = 1; c < cols - 1; ++c) {
      const int gx = (up[c + 1] + 2 * mid[c + 1] + down[c + 1]) - (up[c - 1] + 2 * mid[c - 1] + down[c - 1]);
      const int gy = (down[c - 1] + 2 * down[c] + down[c + 1]) - (up[c - 1] + 2 * up[c] + up[c + 1]);
      const int mag = std::abs(gx) + std::abs(gy);
      const float strength = std::min(1.0f, static_cast<float>(mag) * inv_full);
      w[c] = mag < threshold ? 0.0f : strength;
    }
    if (m != nullptr) {
      // Times 1 inside the cluster, else `outside` (the same single product as in
      // pixel()), the factor selected by bits: a second vector loop.
      for (int c = 1; c < cols - 1; ++c) {
        const std::uint32_t inside = 0u - ((static_cast<std::uint32_t>(m[c]) + 255u) >> 8);  // all ones where m != 0
        w[c] *= std::bit_cast<float>((inside & one_bits) | (~inside & outside_bits));
      }
    }
    if (cols > 1) pixel(cols - 1, cols - 2, right_col);
  }
}

float SymmetryScanner::edgeWeightAt(const cv::Mat& image, int y, int x) const {
  const std::uint8_t* up = image.ptr<std::uint8_t>(reflect101(y - 1, image.rows));
  const std::uint8_t* mid = image.ptr<std::uint8_t>(y);
  const std::uint8_t* down = image.ptr<std::uint8_t>(reflect101(y + 1, image.rows));
  const int mag = sobelMagnitude(up, mid, down, x, reflect101(x - 1, image.cols), reflect101(x + 1, image.cols));
  const float inv_full = 1.0f / (params_.full_weight_ratio * static_cast<float>(params_.edge_threshold));
  return mag < params_.edge_threshold ? 0.0f : std::min(1.0f, static_cast<float>(mag) * inv_full);
}

cv::Mat SymmetryScanner::scratch(std::vector<double>& storage, int rows, int cols, int type) {
  const std::size_t bytes = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type);
  const std::size_t words = (bytes + sizeof(double) - 1) / sizeof(double);
  if (storage.size() < words) storage.resize(words);
  return cv::Mat(rows, cols, type, storage.data());
}

namespace {

// Integral (CV_64F, (rows+1) x (cols+1)) of a CV_32S image of small integers:
// every entry is an exact integer.
void integralOf(const cv::Mat& src, cv::Mat& dst) {
  double* above = dst.ptr<double>(0);
  for (int c = 0; c <= src.cols; ++c) above[c] = 0.0;
  for (int r = 0; r < src.rows; ++r) {
    const auto* s = src.ptr<std::int32_t>(r);
    double* below = dst.ptr<double>(r + 1);
    below[0] = 0.0;
    double run = 0.0;
    for (int c = 0; c < src.cols; ++c) {
      run += s[c];
      below[c + 1] = above[c + 1] + run;
    }
    above = below;
  }
}

}  // namespace

void SymmetryScanner::prepare(const cv::Mat& grey, const cv::Mat& weights) {
  if (grey.type() != CV_8UC1 || weights.type() != CV_32FC1 || grey.size() != weights.size()) {
    throw InputError("symmetry: grey (CV_8UC1) and weights (CV_32FC1) must have the same size");
  }
  // The mirrored sums are 32-bit: at most 2 kWeightScale^2 per row and pair.
  if (grey.rows > kMaxRows) {
    throw InputError("symmetry: region of " + std::to_string(grey.rows) + " rows is taller than the " +
                     std::to_string(kMaxRows) + " rows the 32-bit sums allow");
  }
  grey_ = grey;  // read only, for this call
  const int rows = weights.rows;
  const int cols = weights.cols;
  wq_ = scratch(wq_store_, rows, cols, CV_32SC1);
  mq_ = scratch(mq_store_, rows, cols, CV_32SC1);
  const int tol = params_.mirror_tolerance_px;
  for (int r = 0; r < rows; ++r) {
    const float* w = weights.ptr<float>(r);
    auto* q = wq_.ptr<std::int32_t>(r);
    // Rounded to the nearest step (halves up; w >= 0): exact in double, and a vector loop.
    for (int c = 0; c < cols; ++c) {
      q[c] = static_cast<std::int32_t>(static_cast<double>(std::clamp(w[c], 0.0f, 1.0f)) * kWeightScale + 0.5);
    }
    // Horizontal max filter: the mirror side tolerates a few pixels of asymmetry
    // (one shift at a time each way: vector loops).
    auto* m = mq_.ptr<std::int32_t>(r);
    std::memcpy(m, q, static_cast<std::size_t>(cols) * sizeof(std::int32_t));
    for (int d = 1; d <= tol && d < cols; ++d) {
      for (int c = d; c < cols; ++c) m[c] = std::max(m[c], q[c - d]);
      for (int c = 0; c + d < cols; ++c) m[c] = std::max(m[c], q[c + d]);
    }
  }
  weight_integral_ = scratch(wint_store_, rows + 1, cols + 1, CV_64FC1);
  mirror_integral_ = scratch(mint_store_, rows + 1, cols + 1, CV_64FC1);
  grey_integral_ = scratch(gint_store_, rows + 1, cols + 1, CV_64FC1);
  grey_sq_integral_ = scratch(gsq_store_, rows + 1, cols + 1, CV_64FC1);
  integralOf(wq_, weight_integral_);
  integralOf(mq_, mirror_integral_);
  cv::integral(grey, grey_integral_, grey_sq_integral_, CV_64F, CV_64F);
  col_nonzero_ = scratch(colnz_store_, rows + 1, cols, CV_32SC1);
  // (cv::Mat::setTo allocates a buffer of its own for wide rows.)
  std::memset(col_nonzero_.ptr<int>(0), 0, static_cast<std::size_t>(cols) * sizeof(int));
  for (int r = 0; r < rows; ++r) {
    const auto* q = wq_.ptr<std::int32_t>(r);
    const int* above = col_nonzero_.ptr<int>(r);
    int* below = col_nonzero_.ptr<int>(r + 1);
    for (int c = 0; c < cols; ++c) below[c] = above[c] + (q[c] >= kWeightScale / 4 ? 1 : 0);
  }
}

void SymmetryScanner::buildAxisReference(int axis, int max_half, int rows) {
  // Seven prefix tables over half-widths k and rows r, in exact integers:
  //   t(k, r + 1) = t(k, r) + t(k - 1, r + 1) - t(k - 1, r) + v(k, r).
  const std::size_t width = static_cast<std::size_t>(rows) + 1;
  for (auto* t : {&pe_, &pm_, &pa_, &pb_, &paa_, &pbb_, &pab_}) {
    t->assign((static_cast<std::size_t>(max_half) + 1) * width, 0);
  }
  auto at = [width](std::vector<std::int64_t>& t, int k, int r) -> std::int64_t& {
    return t[static_cast<std::size_t>(k) * width + static_cast<std::size_t>(r)];
  };
  for (int k = 1; k <= max_half; ++k) {
    const int cl = axis - k;
    const int cr = axis + k;
    for (int r = 0; r < rows; ++r) {
      const std::int64_t wl = wq_.at<std::int32_t>(r, cl);
      const std::int64_t wr = wq_.at<std::int32_t>(r, cr);
      const std::int64_t ml = mq_.at<std::int32_t>(r, cl);
      const std::int64_t mr = mq_.at<std::int32_t>(r, cr);
      const std::int64_t a = grey_.at<std::uint8_t>(r, cl);
      const std::int64_t b = grey_.at<std::uint8_t>(r, cr);
      const std::int64_t values[7] = {wl + wr, wl * mr + ml * wr, a, b, a * a, b * b, a * b};
      std::vector<std::int64_t>* tables[7] = {&pe_, &pm_, &pa_, &pb_, &paa_, &pbb_, &pab_};
      for (int i = 0; i < 7; ++i) {
        std::vector<std::int64_t>& t = *tables[i];
        at(t, k, r + 1) = at(t, k, r) + at(t, k - 1, r + 1) - at(t, k - 1, r) + values[i];
      }
    }
  }
  reference_width_ = width;
}

int SymmetryScanner::findTop(int x0, int x1, int bottom) const {
  const double total = boxSum(weight_integral_, 0, bottom, x0, x1);
  if (total <= 0.0) return bottom;
  const double limit = static_cast<double>(params_.top_edge_fraction) * total;
  // Smallest row r with weight of rows [0, r] > limit.
  int lo = 0;
  int hi = bottom;
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (boxSum(weight_integral_, 0, mid, x0, x1) > limit) hi = mid;
    else lo = mid + 1;
  }
  return lo;
}

SymmetryScanner::BoxSums SymmetryScanner::referenceSums(int half, int top, int bottom) const {
  auto sum = [&](const std::vector<std::int64_t>& t) {
    const std::size_t row = static_cast<std::size_t>(half) * reference_width_;
    return static_cast<double>(t[row + static_cast<std::size_t>(bottom) + 1] - t[row + static_cast<std::size_t>(top)]);
  };
  BoxSums s;
  s.e = sum(pe_);
  s.m = sum(pm_);
  s.a = sum(pa_);
  s.b = sum(pb_);
  s.aa = sum(paa_);
  s.bb = sum(pbb_);
  s.ab = sum(pab_);
  return s;
}

SymmetryCandidate SymmetryScanner::evaluate(int axis, int half, int top, int bottom, const BoxSums& sums) const {
  SymmetryCandidate c;
  c.axis_col = axis;
  c.box = cv::Rect(axis - half, top, 2 * half + 1, bottom - top + 1);
  // Weights are integers in units of 1 / kWeightScale: e counts each pair's two
  // weights, m each pair's two weight x mirrored-weight products.
  const double scale = kWeightScale;
  const double esum = sums.e;
  const double msum = sums.m;
  // Share of edges with a mirrored edge, corrected for chance: in dense
  // texture a dilated mirror finds an edge anyway, with probability equal to
  // the density of the dilated edge map.
  const double box_area = static_cast<double>(2 * half + 1) * (bottom - top + 1);
  const double chance = boxSum(mirror_integral_, top, bottom, axis - half, axis + half) / (scale * box_area);
  if (esum > 0.0 && chance < 0.999) {
    const double ratio = std::clamp(msum / (scale * esum), 0.0, 1.0);
    c.edge_symmetry = static_cast<float>(std::clamp((ratio - chance) / (1.0 - chance), 0.0, 1.0));
  } else {
    c.edge_symmetry = 0.0f;
  }

  const double n = static_cast<double>(half) * (bottom - top + 1);
  const double sa = sums.a;
  const double sb = sums.b;
  const double var_a = sums.aa - sa * sa / n;
  const double var_b = sums.bb - sb * sb / n;
  const double cov = sums.ab - sa * sb / n;
  c.grey_symmetry = (var_a > 1e-6 && var_b > 1e-6) ? static_cast<float>(cov / std::sqrt(var_a * var_b)) : 0.0f;

  const int x0 = axis - half;
  const int x1 = axis + half;
  const double inside = boxSum(weight_integral_, top, bottom, x0, x1);
  const int margin = std::max(1, half / 2);
  const double wide = boxSum(weight_integral_, top, bottom, std::max(0, x0 - margin),
                             std::min(wq_.cols - 1, x1 + margin));
  c.coverage = wide > 0.0 ? static_cast<float>(inside / wide) : 0.0f;
  int occupied = 0;
  for (int x = x0; x <= x1; ++x) {
    if (col_nonzero_.at<int>(bottom + 1, x) - col_nonzero_.at<int>(top, x) > 0) ++occupied;
  }
  c.occupancy = static_cast<float>(occupied) / static_cast<float>(x1 - x0 + 1);
  const double area = static_cast<double>(c.box.area());
  c.edge_density = static_cast<float>(inside / (scale * area));
  const double gs = boxSum(grey_integral_, top, bottom, x0, x1);
  const double gss = boxSum(grey_sq_integral_, top, bottom, x0, x1);
  c.grey_stddev = static_cast<float>(std::sqrt(std::max(0.0, gss / area - (gs / area) * (gs / area))));

  const float gw = params_.grey_weight;
  const float sym = (1.0f - gw) * c.edge_symmetry + gw * std::max(0.0f, c.grey_symmetry);
  c.score = sym * c.coverage * c.occupancy;
  return c;
}

void SymmetryScanner::compute(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
                              std::vector<SymmetryCandidate>& out, int bands) {
  computeImpl(grey, weights, search, out, false, std::max(1, bands));
}

void SymmetryScanner::computeReference(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
                                       std::vector<SymmetryCandidate>& out) {
  computeImpl(grey, weights, search, out, true, 1);
}

bool SymmetryScanner::scanAxisFast(AxisTables& t, int axis, const SymmetrySearch& search, int bottom,
                                   SymmetryCandidate& best) const {
  const int kmin = std::max(1, search.min_half_width_px);
  const int step = params_.width_step_px;
  const int kmax = std::min({search.max_half_width_px, axis, wq_.cols - 1 - axis});
  if (kmax < kmin) return false;
  // The box top of every width, and which widths fit the height and aspect limits.
  t.widths.clear();
  int widest = -1;
  for (int k = kmin; k <= kmax; k += step) {
    const int top = findTop(axis - k, axis + k, bottom);
    if (!admissible(search, k, bottom - top + 1)) continue;
    t.widths.push_back({k, top, 0, 0});
    widest = k;
  }
  if (widest < 0) return false;  // no admissible box on this axis: no sums
  // The mirrored sums of pairs j <= widest, accumulated upwards from the bottom
  // row; a width is read off when the rows reach its top. Widths are visited
  // by decreasing top (stable insertion sort: at most a few dozen).
  t.order.resize(t.widths.size());
  for (std::size_t i = 0; i < t.widths.size(); ++i) {
    std::size_t j = i;
    while (j > 0 && t.widths[t.order[j - 1]].top < t.widths[i].top) {
      t.order[j] = t.order[j - 1];
      --j;
    }
    t.order[j] = i;
  }
  const auto width = static_cast<std::size_t>(widest) + 1;
  t.sm.assign(width, 0);
  t.sab.assign(width, 0);
  std::size_t next = 0;
  for (int r = bottom; next < t.order.size(); --r) {
    simd::mirroredRowSums(wq_.ptr<std::int32_t>(r), mq_.ptr<std::int32_t>(r), grey_.ptr<std::uint8_t>(r), axis, widest,
                          t.sm.data(), t.sab.data());
    while (next < t.order.size() && t.widths[t.order[next]].top == r) {
      AxisWidth& w = t.widths[t.order[next]];
      std::int64_t m = 0, ab = 0;
      for (int j = 1; j <= w.half; ++j) {
        m += t.sm[static_cast<std::size_t>(j)];
        ab += t.sab[static_cast<std::size_t>(j)];
      }
      w.m = m;
      w.ab = ab;
      ++next;
    }
  }
  bool found = false;
  for (const AxisWidth& w : t.widths) {
    BoxSums s;
    // Columns axis - half .. axis - 1 and axis + 1 .. axis + half, rows [top, bottom].
    s.e = boxSum(weight_integral_, w.top, bottom, axis - w.half, axis - 1) +
          boxSum(weight_integral_, w.top, bottom, axis + 1, axis + w.half);
    s.m = static_cast<double>(w.m);
    s.a = boxSum(grey_integral_, w.top, bottom, axis - w.half, axis - 1);
    s.b = boxSum(grey_integral_, w.top, bottom, axis + 1, axis + w.half);
    s.aa = boxSum(grey_sq_integral_, w.top, bottom, axis - w.half, axis - 1);
    s.bb = boxSum(grey_sq_integral_, w.top, bottom, axis + 1, axis + w.half);
    s.ab = static_cast<double>(w.ab);
    const SymmetryCandidate c = evaluate(axis, w.half, w.top, bottom, s);
    if (!found || c.score > best.score) {
      best = c;
      found = true;
    }
  }
  return found;
}

void SymmetryScanner::computeImpl(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
                                  std::vector<SymmetryCandidate>& out, bool reference, int bands) {
  out.clear();
  prepare(grey, weights);
  const int cols = grey.cols;
  const int bottom = std::clamp(search.bottom_row, 0, grey.rows - 1);
  const int rows = bottom + 1;
  const int kmin = std::max(1, search.min_half_width_px);
  const int step = params_.width_step_px;
  if (reference) {
    // The plain scan: every table of every axis, then the widths.
    for (int axis = kmin; axis + kmin < cols; axis += params_.axis_step_px) {
      const int kmax = std::min({search.max_half_width_px, axis, cols - 1 - axis});
      if (kmax < kmin) continue;
      buildAxisReference(axis, kmax, rows);
      SymmetryCandidate best;
      bool found = false;
      for (int k = kmin; k <= kmax; k += step) {
        const int top = findTop(axis - k, axis + k, bottom);
        if (!admissible(search, k, bottom - top + 1)) continue;
        const SymmetryCandidate c = evaluate(axis, k, top, bottom, referenceSums(k, top, bottom));
        if (!found || c.score > best.score) {
          best = c;
          found = true;
        }
      }
      if (found) out.push_back(best);
    }
    return;
  }
  // Axis i is column kmin + i * axis_step_px; band b takes the axes i = b, b + bands, ...
  // (neighbouring axes cost about the same, so the bands are balanced).
  const int axes = kmin < cols - kmin ? (cols - kmin - kmin - 1) / params_.axis_step_px + 1 : 0;
  if (axes <= 0) return;
  bands = std::min(bands, axes);
  if (static_cast<int>(bands_.size()) < bands) bands_.resize(static_cast<std::size_t>(bands));
  axis_best_.resize(static_cast<std::size_t>(axes));
  axis_found_.assign(static_cast<std::size_t>(axes), 0);
  auto band = [&](int b) {
    AxisTables& tables = bands_[static_cast<std::size_t>(b)];
    for (int i = b; i < axes; i += bands) {
      const auto slot = static_cast<std::size_t>(i);
      const int axis = kmin + i * params_.axis_step_px;
      axis_found_[slot] = scanAxisFast(tables, axis, search, bottom, axis_best_[slot]) ? 1 : 0;
    }
  };
  if (bands == 1) band(0);
  else forEachBand(bands, band);
  for (int i = 0; i < axes; ++i) {
    if (axis_found_[static_cast<std::size_t>(i)] != 0) out.push_back(axis_best_[static_cast<std::size_t>(i)]);
  }
}

SymmetryCandidate SymmetryScanner::measure(const cv::Mat& grey, const cv::Mat& weights, int axis_col, int half_width,
                                           int top, int bottom) {
  if (axis_col - half_width < 0 || axis_col + half_width >= grey.cols || top < 0 || bottom >= grey.rows ||
      top > bottom || half_width < 1) {
    throw InputError("symmetry: box outside the region");
  }
  prepare(grey, weights);
  buildAxisReference(axis_col, half_width, bottom + 1);
  return evaluate(axis_col, half_width, top, bottom, referenceSums(half_width, top, bottom));
}

}  // namespace sg
