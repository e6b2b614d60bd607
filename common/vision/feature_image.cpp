#include "vision/feature_image.hpp"

#include <algorithm>
#include <cstdlib>

#include "config/errors.hpp"
#include "vision/parallel_bands.hpp"
#include "vision/simd_match.hpp"

namespace sg {

FeatureExtractor::FeatureExtractor(const FeatureParams& params) : params_(params) { params_.validate(); }

void FeatureExtractor::checkInput(const cv::Mat& grey, cv::Mat& features) const {
  if (grey.empty() || grey.type() != CV_8UC1) throw InputError("feature extraction: the image must be non-empty mono8");
  features.create(grey.size(), CV_8UC1);
}

void FeatureExtractor::computeRows(const cv::Mat& grey, cv::Mat& features, int y0, int y1,
                                   std::vector<int>& scratch) const {
  const int w = grey.cols;
  const int h = grey.rows;
  const int r = params_.dilation_half_width_px;
  const int thr = params_.edge_threshold;
  scratch.resize(static_cast<std::size_t>(2 * w + 1));
  int* edge = scratch.data();          // 0/1 per column
  int* prefix = scratch.data() + w;    // prefix[x] = edges in [0, x), w + 1 entries
  for (int y = y0; y < y1; ++y) {
    // Replicated border: the rows above/below the image are the first/last row.
    const std::uint8_t* pm = grey.ptr<std::uint8_t>(std::max(y - 1, 0));
    const std::uint8_t* p0 = grey.ptr<std::uint8_t>(y);
    const std::uint8_t* pp = grey.ptr<std::uint8_t>(std::min(y + 1, h - 1));
    for (int x = 0; x < w; ++x) {
      const int xm = x > 0 ? x - 1 : 0;
      const int xp = x < w - 1 ? x + 1 : w - 1;
      const int gx = (pm[xp] + 2 * p0[xp] + pp[xp]) - (pm[xm] + 2 * p0[xm] + pp[xm]);
      const int gy = (pp[xm] + 2 * pp[x] + pp[xp]) - (pm[xm] + 2 * pm[x] + pm[xp]);
      edge[x] = (std::abs(gx) + std::abs(gy)) >= thr ? 1 : 0;
    }
    prefix[0] = 0;
    for (int x = 0; x < w; ++x) prefix[x + 1] = prefix[x] + edge[x];
    std::uint8_t* out = features.ptr<std::uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      const int a = std::max(x - r, 0);
      const int b = std::min(x + r + 1, w);
      const bool on = prefix[b] - prefix[a] > 0;
      out[x] = on ? std::max<std::uint8_t>(p0[x], 1) : std::uint8_t{0};
    }
  }
}

void FeatureExtractor::computeRowsFast(const cv::Mat& grey, cv::Mat& features, int y0, int y1,
                                       std::vector<std::uint8_t>& scratch) const {
  const int w = grey.cols;
  const int h = grey.rows;
  const int r = params_.dilation_half_width_px;
  const auto size = static_cast<std::size_t>(simd::featureScratchSize(w, r));
  if (scratch.size() < size) scratch.resize(size);
  for (int y = y0; y < y1; ++y) {
    simd::featureRow(grey.ptr<std::uint8_t>(std::max(y - 1, 0)), grey.ptr<std::uint8_t>(y),
                     grey.ptr<std::uint8_t>(std::min(y + 1, h - 1)), w, params_.edge_threshold, r, scratch.data(),
                     features.ptr<std::uint8_t>(y));
  }
}

void FeatureExtractor::computeReference(const cv::Mat& grey, cv::Mat& features) {
  checkInput(grey, features);
  if (band_scratch_.empty()) band_scratch_.resize(1);
  computeRows(grey, features, 0, grey.rows, band_scratch_[0]);
}

void FeatureExtractor::compute(const cv::Mat& grey, cv::Mat& features) {
  checkInput(grey, features);
  const int band = params_.band_rows;
  const int bands = (grey.rows + band - 1) / band;
  if (static_cast<int>(band_bytes_.size()) < bands) band_bytes_.resize(static_cast<std::size_t>(bands));
  forEachBand(bands, [&](int b) {
    const int y0 = b * band;
    const int y1 = std::min(y0 + band, grey.rows);
    computeRowsFast(grey, features, y0, y1, band_bytes_[static_cast<std::size_t>(b)]);
  });
}

}  // namespace sg
