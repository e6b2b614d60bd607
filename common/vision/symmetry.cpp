#include "vision/symmetry.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"
#include "vision/parallel_bands.hpp"

namespace sg {

namespace {

// Sum of a CV_64F integral image over rows [r0, r1] and columns [c0, c1] (inclusive).
double boxSum(const cv::Mat& integral, int r0, int r1, int c0, int c1) {
  return integral.at<double>(r1 + 1, c1 + 1) - integral.at<double>(r0, c1 + 1) - integral.at<double>(r1 + 1, c0) +
         integral.at<double>(r0, c0);
}

// Sum over j = 1..k and rows [r0, r1] of a per-axis prefix table.
double tableSum(const cv::Mat& table, int k, int r0, int r1) {
  return table.at<double>(k, r1 + 1) - table.at<double>(k, r0);
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
  // Image row / column of region row / column i, reflected at the image border.
  auto reflect = [](int i, int n) {
    if (n == 1) return 0;
    if (i < 0) return -i;
    if (i >= n) return 2 * n - 2 - i;
    return i;
  };
  const float outside = cluster_mask.empty() ? 1.0f : params_.outside_cluster_edge_weight;
  const float inv_full = 1.0f / (params_.full_weight_ratio * static_cast<float>(params_.edge_threshold));
  const int threshold = params_.edge_threshold;
  const int cols = grey.cols;
  const int left_col = reflect(ofs.x - 1, whole.width) - ofs.x;          // region column of the left neighbour of 0
  const int right_col = reflect(ofs.x + cols, whole.width) - ofs.x;      // ... of the right neighbour of cols - 1
  for (int r = 0; r < grey.rows; ++r) {
    // Rows above and below, as pointers relative to the region's row 0 (inside the parent image).
    const std::uint8_t* base = grey.ptr<std::uint8_t>(0);
    const auto* up = base + static_cast<std::ptrdiff_t>(reflect(ofs.y + r - 1, whole.height) - ofs.y) *
                                static_cast<std::ptrdiff_t>(step);
    const auto* mid = base + static_cast<std::ptrdiff_t>(r) * static_cast<std::ptrdiff_t>(step);
    const auto* down = base + static_cast<std::ptrdiff_t>(reflect(ofs.y + r + 1, whole.height) - ofs.y) *
                                  static_cast<std::ptrdiff_t>(step);
    const std::uint8_t* m = cluster_mask.empty() ? nullptr : cluster_mask.ptr<std::uint8_t>(r);
    auto* w = weights.ptr<float>(r);
    auto pixel = [&](int c, int cl, int cr) {
      const int gx = (up[cr] + 2 * mid[cr] + down[cr]) - (up[cl] + 2 * mid[cl] + down[cl]);
      const int gy = (down[cl] + 2 * down[c] + down[cr]) - (up[cl] + 2 * up[c] + up[cr]);
      const int mag = std::abs(gx) + std::abs(gy);
      const float strength = std::min(1.0f, static_cast<float>(mag) * inv_full);
      const float factor = (m == nullptr || m[c] != 0) ? 1.0f : outside;
      w[c] = mag < threshold ? 0.0f : strength * factor;
    };
    pixel(0, left_col, cols > 1 ? 1 : right_col);
    // Interior columns: no border test, a branch-free body for the vectoriser.
    if (m == nullptr) {
      for (int c = 1; c < cols - 1; ++c) {
        const int gx = (up[c + 1] + 2 * mid[c + 1] + down[c + 1]) - (up[c - 1] + 2 * mid[c - 1] + down[c - 1]);
        const int gy = (down[c - 1] + 2 * down[c] + down[c + 1]) - (up[c - 1] + 2 * up[c] + up[c + 1]);
        const int mag = std::abs(gx) + std::abs(gy);
        const float strength = std::min(1.0f, static_cast<float>(mag) * inv_full);
        w[c] = mag < threshold ? 0.0f : strength;
      }
    } else {
      for (int c = 1; c < cols - 1; ++c) {
        const int gx = (up[c + 1] + 2 * mid[c + 1] + down[c + 1]) - (up[c - 1] + 2 * mid[c - 1] + down[c - 1]);
        const int gy = (down[c - 1] + 2 * down[c] + down[c + 1]) - (up[c - 1] + 2 * up[c] + up[c + 1]);
        const int mag = std::abs(gx) + std::abs(gy);
        const float strength = std::min(1.0f, static_cast<float>(mag) * inv_full);
        const float factor = m[c] != 0 ? 1.0f : outside;
        w[c] = mag < threshold ? 0.0f : strength * factor;
      }
    }
    if (cols > 1) pixel(cols - 1, cols - 2, right_col);
  }
}

cv::Mat SymmetryScanner::scratch(std::vector<double>& storage, int rows, int cols, int type) {
  const std::size_t bytes = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type);
  const std::size_t words = (bytes + sizeof(double) - 1) / sizeof(double);
  if (storage.size() < words) storage.resize(words);
  return cv::Mat(rows, cols, type, storage.data());
}

void SymmetryScanner::prepare(const cv::Mat& grey, const cv::Mat& weights) {
  if (grey.type() != CV_8UC1 || weights.type() != CV_32FC1 || grey.size() != weights.size()) {
    throw InputError("symmetry: grey (CV_8UC1) and weights (CV_32FC1) must have the same size");
  }
  grey.convertTo(grey_f_, CV_64F);
  grey.copyTo(grey_u8_);
  weights_ = weights.clone();
  // Horizontal max filter: the mirror side tolerates a few pixels of asymmetry.
  const int tol = params_.mirror_tolerance_px;
  mirror_.create(weights.size(), CV_32FC1);
  for (int r = 0; r < weights.rows; ++r) {
    const float* w = weights_.ptr<float>(r);
    float* m = mirror_.ptr<float>(r);
    for (int c = 0; c < weights.cols; ++c) {
      float best = 0.0f;
      for (int d = std::max(0, c - tol); d <= std::min(weights.cols - 1, c + tol); ++d) best = std::max(best, w[d]);
      m[c] = best;
    }
  }
  cv::integral(weights_, weight_integral_, CV_64F);
  cv::integral(mirror_, mirror_integral_, CV_64F);
  cv::integral(grey, grey_integral_, grey_sq_integral_, CV_64F, CV_64F);
  col_nonzero_.create(weights.rows + 1, weights.cols, CV_32SC1);
  col_nonzero_.row(0).setTo(0);
  for (int r = 0; r < weights.rows; ++r) {
    const float* w = weights_.ptr<float>(r);
    const int* above = col_nonzero_.ptr<int>(r);
    int* below = col_nonzero_.ptr<int>(r + 1);
    for (int c = 0; c < weights.cols; ++c) below[c] = above[c] + (w[c] >= 0.25f ? 1 : 0);
  }
}

void SymmetryScanner::prepareFast(const cv::Mat& grey, const cv::Mat& weights) {
  if (grey.type() != CV_8UC1 || weights.type() != CV_32FC1 || grey.size() != weights.size()) {
    throw InputError("symmetry: grey (CV_8UC1) and weights (CV_32FC1) must have the same size");
  }
  const int rows = weights.rows;
  const int cols = weights.cols;
  weights_ = weights;  // read only, for this call
  const int tol = params_.mirror_tolerance_px;
  mirror_ = scratch(mirror_store_, rows, cols, CV_32FC1);
  for (int r = 0; r < rows; ++r) {
    const float* w = weights_.ptr<float>(r);
    float* m = mirror_.ptr<float>(r);
    for (int c = 0; c < cols; ++c) {
      float best = 0.0f;
      for (int d = std::max(0, c - tol); d <= std::min(cols - 1, c + tol); ++d) best = std::max(best, w[d]);
      m[c] = best;
    }
  }
  // cv::integral writes into headers of the right size without reallocating.
  weight_integral_ = scratch(wint_store_, rows + 1, cols + 1, CV_64FC1);
  mirror_integral_ = scratch(mint_store_, rows + 1, cols + 1, CV_64FC1);
  grey_integral_ = scratch(gint_store_, rows + 1, cols + 1, CV_64FC1);
  grey_sq_integral_ = scratch(gsq_store_, rows + 1, cols + 1, CV_64FC1);
  cv::integral(weights_, weight_integral_, CV_64F);
  cv::integral(mirror_, mirror_integral_, CV_64F);
  cv::integral(grey, grey_integral_, grey_sq_integral_, CV_64F, CV_64F);
  col_nonzero_ = scratch(colnz_store_, rows + 1, cols, CV_32SC1);
  col_nonzero_.row(0).setTo(0);
  for (int r = 0; r < rows; ++r) {
    const float* w = weights_.ptr<float>(r);
    const int* above = col_nonzero_.ptr<int>(r);
    int* below = col_nonzero_.ptr<int>(r + 1);
    for (int c = 0; c < cols; ++c) below[c] = above[c] + (w[c] >= 0.25f ? 1 : 0);
  }
}

void SymmetryScanner::buildAxisFast(AxisTables& t, int axis, int max_half, int rows) const {
  // Each table is a 2-D prefix sum over half-widths k and rows r:
  //   t(k, r + 1) = ((t(k, r) + t(k - 1, r + 1)) - t(k - 1, r)) + v(k, r).
  // Only two of the reference's seven are built: the sums of a, b, a^2, b^2 over
  // a box are exact integers taken from the region's integral images, and the
  // mirrored grey product a * b, an exact integer too, is kept as 32-bit column
  // sums per pair j (ab_prefix_). The two edge tables are floating-point sums
  // whose rounding must stay that of the reference. Their updates on one
  // anti-diagonal s = k + r + 1 depend only on the two previous anti-diagonals,
  // so they are stored skewed, row s + 1 holding t(k, s - k) for every k, and
  // each anti-diagonal is one vector loop over k with the reference's operations
  // in the reference's order. Rows 0 and 1 are zero (s = -1 and 0); t(k, r) is
  // row k + r + 1, column k.
  const int kmax = max_half;
  const int width = kmax + 1;
  const int skew_rows = rows + kmax + 2;
  t.pe = scratch(t.pe_store, skew_rows, width, CV_64FC1);
  t.pm = scratch(t.pm_store, skew_rows, width, CV_64FC1);
  for (cv::Mat* table : {&t.pe, &t.pm}) table->rowRange(0, 2).setTo(0.0);
  if (t.diagonal.size() < 2 * static_cast<std::size_t>(width)) t.diagonal.resize(2 * static_cast<std::size_t>(width));
  double* __restrict ve = t.diagonal.data();
  double* __restrict vm = ve + width;
  const float* w0 = weights_.ptr<float>(0);
  const float* m0 = mirror_.ptr<float>(0);
  const std::uint8_t* g0 = grey_rows_;  // the caller's region, set by computeImpl
  const auto wstep = static_cast<std::ptrdiff_t>(weights_.step1());
  const auto mstep = static_cast<std::ptrdiff_t>(mirror_.step1());
  const auto gstep = static_cast<std::ptrdiff_t>(grey_step_);
  for (int s = 1; s <= rows + kmax; ++s) {
    // k with a row r = s - 1 - k inside [0, rows - 1]; t(k, s - k) for smaller k
    // (rows below the region) is never read, for larger k it is 0 (r + 1 <= 0).
    const int klo = std::max(1, s - rows);
    const int khi = std::min(kmax, s - 1);
    for (int k = khi + 1; k <= kmax; ++k) ve[k] = vm[k] = 0.0;
    for (int k = klo; k <= khi; ++k) {
      const std::ptrdiff_t r = s - 1 - k;
      const float* w = w0 + r * wstep;
      const float* m = m0 + r * mstep;
      const double wl = w[axis - k];
      const double wr = w[axis + k];
      const double ml = m[axis - k];
      const double mr = m[axis + k];
      ve[k] = 0.5 * (wl + wr);
      vm[k] = 0.5 * (wl * mr + ml * wr);
    }
    double* __restrict e = t.pe.ptr<double>(s + 1);
    const double* __restrict e1 = t.pe.ptr<double>(s);
    const double* __restrict e2 = t.pe.ptr<double>(s - 1);
    double* __restrict mm = t.pm.ptr<double>(s + 1);
    const double* __restrict m1 = t.pm.ptr<double>(s);
    const double* __restrict m2 = t.pm.ptr<double>(s - 1);
    e[0] = mm[0] = 0.0;
    // Two half-widths per vector (lane-wise IEEE operations, the same as the scalar ones).
    typedef double F64x2 __attribute__((vector_size(16)));
    auto load = [](const double* p) {
      F64x2 v;
      std::memcpy(&v, p, sizeof v);
      return v;
    };
    auto store = [](double* p, F64x2 v) { std::memcpy(p, &v, sizeof v); };
    int k = klo;
    for (; k + 1 <= kmax; k += 2) {
      store(e + k, load(e1 + k) + load(e1 + k - 1) - load(e2 + k - 1) + load(ve + k));
      store(mm + k, load(m1 + k) + load(m1 + k - 1) - load(m2 + k - 1) + load(vm + k));
    }
    for (; k <= kmax; ++k) {
      e[k] = e1[k] + e1[k - 1] - e2[k - 1] + ve[k];
      mm[k] = m1[k] + m1[k - 1] - m2[k - 1] + vm[k];
    }
  }
  // Mirrored grey products: exact integers (at most 255^2 per pixel, 255^2 x rows per
  // column), summed down each column pair j as 32-bit integers, row by row.
  t.ab_prefix.resize(static_cast<std::size_t>(rows + 1) * static_cast<std::size_t>(width));
  std::int32_t* prev = t.ab_prefix.data();
  for (int j = 0; j <= kmax; ++j) prev[j] = 0;
  for (int r = 0; r < rows; ++r) {
    const std::uint8_t* g = g0 + static_cast<std::ptrdiff_t>(r) * gstep + axis;
    std::int32_t* __restrict cur = prev + width;
    cur[0] = 0;
    for (int j = 1; j <= kmax; ++j) cur[j] = prev[j] + static_cast<std::int32_t>(g[-j]) * static_cast<std::int32_t>(g[j]);
    prev = cur;
  }
}

void SymmetryScanner::buildAxisReference(int axis, int max_half, int rows) {
  const cv::Size size(rows + 1, max_half + 1);
  for (cv::Mat* t : {&pe_, &pm_, &pa_, &pb_, &paa_, &pbb_, &pab_}) {
    t->create(size, CV_64FC1);
    t->setTo(0.0);
  }
  for (int k = 1; k <= max_half; ++k) {
    const int cl = axis - k;
    const int cr = axis + k;
    for (int r = 0; r < rows; ++r) {
      const double wl = weights_.at<float>(r, cl);
      const double wr = weights_.at<float>(r, cr);
      const double ml = mirror_.at<float>(r, cl);
      const double mr = mirror_.at<float>(r, cr);
      const double a = grey_f_.at<double>(r, cl);
      const double b = grey_f_.at<double>(r, cr);
      const double values[7] = {0.5 * (wl + wr), 0.5 * (wl * mr + ml * wr), a, b, a * a, b * b, a * b};
      cv::Mat* tables[7] = {&pe_, &pm_, &pa_, &pb_, &paa_, &pbb_, &pab_};
      for (int i = 0; i < 7; ++i) {
        cv::Mat& t = *tables[i];
        t.at<double>(k, r + 1) =
            t.at<double>(k, r) + t.at<double>(k - 1, r + 1) - t.at<double>(k - 1, r) + values[i];
      }
    }
  }
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
  BoxSums s;
  s.e = tableSum(pe_, half, top, bottom);
  s.m = tableSum(pm_, half, top, bottom);
  s.a = tableSum(pa_, half, top, bottom);
  s.b = tableSum(pb_, half, top, bottom);
  s.aa = tableSum(paa_, half, top, bottom);
  s.bb = tableSum(pbb_, half, top, bottom);
  s.ab = tableSum(pab_, half, top, bottom);
  return s;
}

SymmetryScanner::BoxSums SymmetryScanner::fastSums(const AxisTables& t, int axis, int half, int top,
                                                   int bottom) const {
  // Columns axis - half .. axis - 1 and axis + 1 .. axis + half: the reference's
  // tables summed the same exact integers.
  // Skewed tables (buildAxisFast): t(k, r) is row k + r + 1, column k.
  auto skewSum = [&](const cv::Mat& table) {
    return table.at<double>(half + bottom + 2, half) - table.at<double>(half + top + 1, half);
  };
  BoxSums s;
  s.e = skewSum(t.pe);
  s.m = skewSum(t.pm);
  s.a = boxSum(grey_integral_, top, bottom, axis - half, axis - 1);
  s.b = boxSum(grey_integral_, top, bottom, axis + 1, axis + half);
  s.aa = boxSum(grey_sq_integral_, top, bottom, axis - half, axis - 1);
  s.bb = boxSum(grey_sq_integral_, top, bottom, axis + 1, axis + half);
  // Mirrored grey product: column sums over [top, bottom] of the pairs j <= half.
  const std::size_t width = static_cast<std::size_t>(t.pe.cols);
  const std::int32_t* below = t.ab_prefix.data() + static_cast<std::size_t>(bottom + 1) * width;
  const std::int32_t* above = t.ab_prefix.data() + static_cast<std::size_t>(top) * width;
  std::int64_t ab = 0;
  for (int j = 1; j <= half; ++j) ab += static_cast<std::int64_t>(below[j]) - static_cast<std::int64_t>(above[j]);
  s.ab = static_cast<double>(ab);
  return s;
}

SymmetryCandidate SymmetryScanner::evaluate(int axis, int half, int top, int bottom, const BoxSums& sums) const {
  SymmetryCandidate c;
  c.axis_col = axis;
  c.box = cv::Rect(axis - half, top, 2 * half + 1, bottom - top + 1);
  const double esum = sums.e;
  const double msum = sums.m;
  // Share of edges with a mirrored edge, corrected for chance: in dense
  // texture a dilated mirror finds an edge anyway, with probability equal to
  // the density of the dilated edge map.
  const double box_area = static_cast<double>(2 * half + 1) * (bottom - top + 1);
  const double chance = boxSum(mirror_integral_, top, bottom, axis - half, axis + half) / box_area;
  if (esum > 0.0 && chance < 0.999) {
    const double ratio = std::clamp(msum / esum, 0.0, 1.0);
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
                             std::min(weights_.cols - 1, x1 + margin));
  c.coverage = wide > 0.0 ? static_cast<float>(inside / wide) : 0.0f;
  int occupied = 0;
  for (int x = x0; x <= x1; ++x) {
    if (col_nonzero_.at<int>(bottom + 1, x) - col_nonzero_.at<int>(top, x) > 0) ++occupied;
  }
  c.occupancy = static_cast<float>(occupied) / static_cast<float>(x1 - x0 + 1);
  const double area = static_cast<double>(c.box.area());
  c.edge_density = static_cast<float>(inside / area);
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
  const int kmax = std::min({search.max_half_width_px, axis, weights_.cols - 1 - axis});
  if (kmax < kmin) return false;
  // The box top of every width, and which widths fit the height and aspect limits.
  t.tops.assign(static_cast<std::size_t>((kmax - kmin) / step + 1), -1);
  int widest = -1;
  for (int k = kmin, i = 0; k <= kmax; k += step, ++i) {
    const int top = findTop(axis - k, axis + k, bottom);
    const int height = bottom - top + 1;
    if (height < search.min_height_px || height > search.max_height_px) continue;
    const double aspect = static_cast<double>(height) / (2 * k + 1);
    if (aspect < search.min_aspect || aspect > search.max_aspect) continue;
    t.tops[static_cast<std::size_t>(i)] = top;
    widest = k;
  }
  if (widest < 0) return false;  // no admissible box on this axis: no tables
  buildAxisFast(t, axis, widest, bottom + 1);
  bool found = false;
  for (int k = kmin, i = 0; k <= widest; k += step, ++i) {
    const int top = t.tops[static_cast<std::size_t>(i)];
    if (top < 0) continue;
    const SymmetryCandidate c = evaluate(axis, k, top, bottom, fastSums(t, axis, k, top, bottom));
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
  if (reference) prepare(grey, weights);
  else prepareFast(grey, weights);
  grey_rows_ = grey.ptr<std::uint8_t>(0);
  grey_step_ = grey.step[0];
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
        const int height = bottom - top + 1;
        if (height < search.min_height_px || height > search.max_height_px) continue;
        const double aspect = static_cast<double>(height) / (2 * k + 1);
        if (aspect < search.min_aspect || aspect > search.max_aspect) continue;
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
