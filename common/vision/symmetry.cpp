#include "vision/symmetry.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"

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

void SymmetryScanner::edgeWeights(const cv::Mat& grey, const cv::Mat& cluster_mask, cv::Mat& weights) const {
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

void SymmetryScanner::prepare(const cv::Mat& grey, const cv::Mat& weights) {
  if (grey.type() != CV_8UC1 || weights.type() != CV_32FC1 || grey.size() != weights.size()) {
    throw InputError("symmetry: grey (CV_8UC1) and weights (CV_32FC1) must have the same size");
  }
  grey.convertTo(grey_f_, CV_64F);
  grey.copyTo(grey_u8_);
  weights.copyTo(weights_);
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

void SymmetryScanner::buildAxis(int axis, int max_half, int rows) {
  // Each table is a 2-D prefix sum over half-widths k and rows r:
  //   t(k, r + 1) = ((t(k, r) + t(k - 1, r + 1)) - t(k - 1, r)) + v(k, r).
  // The grey tables hold integers far below 2^53: their doubles are exact whatever the
  // order, so they are summed as integers. The edge tables keep the reference's
  // floating-point order; updates on the anti-diagonal k + r of a strip of kStrip rows
  // do not depend on each other, which hides the adder latency.
  const cv::Size size(rows + 1, max_half + 1);
  for (cv::Mat* t : {&pe_, &pm_, &pa_, &pb_, &paa_, &pbb_, &pab_}) {
    t->create(size, CV_64FC1);
    t->row(0).setTo(0.0);
  }
  auto rowOf = [&](cv::Mat& t, int k) { return t.ptr<double>(k); };
  for (int k = 1; k <= max_half; ++k)
    for (cv::Mat* t : {&pe_, &pm_, &pa_, &pb_, &paa_, &pbb_, &pab_}) t->ptr<double>(k)[0] = 0.0;

  // Grey tables: column sums down to each row, accumulated over k, as 64-bit integers.
  {
    for (int k = 1; k <= max_half; ++k) {
      const int cl = axis - k;
      const int cr = axis + k;
      double* ta = rowOf(pa_, k);
      double* tb = rowOf(pb_, k);
      double* taa = rowOf(paa_, k);
      double* tbb = rowOf(pbb_, k);
      double* tab = rowOf(pab_, k);
      const double* ua = rowOf(pa_, k - 1);
      const double* ub = rowOf(pb_, k - 1);
      const double* uaa = rowOf(paa_, k - 1);
      const double* ubb = rowOf(pbb_, k - 1);
      const double* uab = rowOf(pab_, k - 1);
      std::int64_t sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;  // column sums of rows < r + 1
      for (int r = 0; r < rows; ++r) {
        const std::uint8_t* g = grey_u8_.ptr<std::uint8_t>(r);
        const std::int64_t a = g[cl];
        const std::int64_t b = g[cr];
        sa += a;
        sb += b;
        saa += a * a;
        sbb += b * b;
        sab += a * b;
        // t(k, r + 1) = t(k - 1, r + 1) + column k summed over rows <= r (exact integers).
        const auto at = static_cast<std::size_t>(r) + 1;
        ta[at] = ua[at] + static_cast<double>(sa);
        tb[at] = ub[at] + static_cast<double>(sb);
        taa[at] = uaa[at] + static_cast<double>(saa);
        tbb[at] = ubb[at] + static_cast<double>(sbb);
        tab[at] = uab[at] + static_cast<double>(sab);
      }
    }
  }

  // Edge tables, the reference's order of operations on skewed strips of kStrip rows of k.
  constexpr int kStrip = 4;
  for (int k0 = 1; k0 <= max_half; k0 += kStrip) {
    const int kn = std::min(kStrip, max_half - k0 + 1);
    double* te[kStrip];
    double* tm[kStrip];
    for (int j = 0; j < kn; ++j) {
      te[j] = rowOf(pe_, k0 + j);
      tm[j] = rowOf(pm_, k0 + j);
    }
    const double* pe_prev = rowOf(pe_, k0 - 1);
    const double* pm_prev = rowOf(pm_, k0 - 1);
    for (int step = 0; step < rows + kn - 1; ++step) {
      for (int j = 0; j < kStrip; ++j) {
        const int r = step - j;
        if (j >= kn || r < 0 || r >= rows) continue;
        const int k = k0 + j;
        const float* w = weights_.ptr<float>(r);
        const float* m = mirror_.ptr<float>(r);
        const double wlv = w[axis - k];
        const double wrv = w[axis + k];
        const double mlv = m[axis - k];
        const double mrv = m[axis + k];
        const double* ue = j == 0 ? pe_prev : te[j - 1];
        const double* um = j == 0 ? pm_prev : tm[j - 1];
        const auto at = static_cast<std::size_t>(r);
        te[j][at + 1] = te[j][at] + ue[at + 1] - ue[at] + 0.5 * (wlv + wrv);
        tm[j][at + 1] = tm[j][at] + um[at + 1] - um[at] + 0.5 * (wlv * mrv + mlv * wrv);
      }
    }
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

SymmetryCandidate SymmetryScanner::evaluate(int axis, int half, int top, int bottom) const {
  SymmetryCandidate c;
  c.axis_col = axis;
  c.box = cv::Rect(axis - half, top, 2 * half + 1, bottom - top + 1);
  const double esum = tableSum(pe_, half, top, bottom);
  const double msum = tableSum(pm_, half, top, bottom);
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
  const double sa = tableSum(pa_, half, top, bottom);
  const double sb = tableSum(pb_, half, top, bottom);
  const double var_a = tableSum(paa_, half, top, bottom) - sa * sa / n;
  const double var_b = tableSum(pbb_, half, top, bottom) - sb * sb / n;
  const double cov = tableSum(pab_, half, top, bottom) - sa * sb / n;
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
                              std::vector<SymmetryCandidate>& out) {
  computeImpl(grey, weights, search, out, false);
}

void SymmetryScanner::computeReference(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
                                       std::vector<SymmetryCandidate>& out) {
  computeImpl(grey, weights, search, out, true);
}

void SymmetryScanner::computeImpl(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
                                  std::vector<SymmetryCandidate>& out, bool reference) {
  out.clear();
  prepare(grey, weights);
  const int cols = grey.cols;
  const int bottom = std::clamp(search.bottom_row, 0, grey.rows - 1);
  const int rows = bottom + 1;
  const int kmin = std::max(1, search.min_half_width_px);
  for (int axis = kmin; axis + kmin < cols; axis += params_.axis_step_px) {
    const int kmax = std::min({search.max_half_width_px, axis, cols - 1 - axis});
    if (kmax < kmin) continue;
    if (reference) buildAxisReference(axis, kmax, rows);
    else buildAxis(axis, kmax, rows);
    SymmetryCandidate best;
    bool found = false;
    for (int k = kmin; k <= kmax; k += params_.width_step_px) {
      const int top = findTop(axis - k, axis + k, bottom);
      const int height = bottom - top + 1;
      if (height < search.min_height_px || height > search.max_height_px) continue;
      const double aspect = static_cast<double>(height) / (2 * k + 1);
      if (aspect < search.min_aspect || aspect > search.max_aspect) continue;
      const SymmetryCandidate c = evaluate(axis, k, top, bottom);
      if (!found || c.score > best.score) {
        best = c;
        found = true;
      }
    }
    if (found) out.push_back(best);
  }
}

SymmetryCandidate SymmetryScanner::measure(const cv::Mat& grey, const cv::Mat& weights, int axis_col, int half_width,
                                           int top, int bottom) {
  if (axis_col - half_width < 0 || axis_col + half_width >= grey.cols || top < 0 || bottom >= grey.rows ||
      top > bottom || half_width < 1) {
    throw InputError("symmetry: box outside the region");
  }
  prepare(grey, weights);
  buildAxis(axis_col, half_width, bottom + 1);
  return evaluate(axis_col, half_width, top, bottom);
}

}  // namespace sg
