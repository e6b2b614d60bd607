#pragma once
// Feature images (seed paper, Sec. III, figure 3c): edge extraction,
// binarization, horizontal morphological dilation, then the grey value is kept
// only where the dilated edge mask is set. 0 means "no information"; a grey
// value of 0 inside the mask is stored as 1.
//
// The paper says the dilated edge mask is "pixel-ORed" with the original image
// and that grey values are "only preserved in correspondence to areas with a
// relevant information content". A literal OR of a 0/255 mask with the grey
// image would keep every grey value outside the mask and saturate inside it,
// the opposite of that stated intent; we implement the intent (a masked copy),
// see docs/method.md.
//
// Not re-entrant: an extractor owns its scratch; use one per thread.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "config/params.hpp"

namespace sg {

struct FeatureParams {
  int edge_threshold = 48;        // Sobel |gx| + |gy| marking an edge (a 12-grey-level step gives 48)
  int dilation_half_width_px = 2; // horizontal dilation: mask[x] = any edge in [x - r, x + r]
  int band_rows = 16;             // rows per TBB band (fixed: results never depend on the thread count)

  template <class V>
  void visit(V& v) {
    v.field("edge_threshold", edge_threshold, 1, 2040, "Sobel |gx|+|gy| units",
            "gradient magnitude marking an edge; a step of s grey levels gives 4*s");
    v.field("dilation_half_width_px", dilation_half_width_px, 0, 32, "pixels",
            "half width of the horizontal dilation of the edge mask");
    v.field("band_rows", band_rows, 1, 4096, "rows", "rows per parallel band");
  }
  void validate() const { validateParams(*this, "features"); }
};

class FeatureExtractor {
 public:
  explicit FeatureExtractor(const FeatureParams& params = {});

  // grey: CV_8UC1. features: CV_8UC1 of the same size (reallocated only when the size changes).
  // Row bands in parallel (TBB); bit-identical to computeReference.
  void compute(const cv::Mat& grey, cv::Mat& features);
  // Serial reference.
  void computeReference(const cv::Mat& grey, cv::Mat& features);

  const FeatureParams& params() const { return params_; }

 private:
  void checkInput(const cv::Mat& grey, cv::Mat& features) const;
  // The one kernel: rows [y0, y1) of `features`; `scratch` holds 2 * width + 1 ints.
  void computeRows(const cv::Mat& grey, cv::Mat& features, int y0, int y1, std::vector<int>& scratch) const;

  // Fast kernel (vector Sobel, dilation and mask) for rows [y0, y1).
  void computeRowsFast(const cv::Mat& grey, cv::Mat& features, int y0, int y1, std::vector<std::uint8_t>& scratch) const;

  FeatureParams params_;
  std::vector<std::vector<int>> band_scratch_;  // reference: one per band, reused across frames
  std::vector<std::vector<std::uint8_t>> band_bytes_;  // fast path: one per band, reused across frames
};

}  // namespace sg
