#pragma once
// Removal of ground and background features (seed paper, Sec. III, figure 3e):
// a left feature pixel that matches the right feature image at the polyline
// offset of its row (within offset_tolerance_px and grey_tolerance) belongs to
// the ground (rows from the horizon down) or the background (rows above); it is
// labelled so and cleared from the working feature image.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "config/params.hpp"
#include "vision/segmentation_types.hpp"

namespace sg {

struct RemovalParams {
  int offset_tolerance_px = 1;  // offsets within +-this of the polyline match (the line is quantised to rows)
  int grey_tolerance = 12;      // grey levels, as in the correlation
  int band_rows = 16;           // rows per TBB band
  // On a transversal slope the horizon tilts: below the horizon row, where the ground at a
  // column would be farther than the background, the background shows and is removed.
  bool background_beside_ground = true;

  template <class V>
  void visit(V& v) {
    v.field("offset_tolerance_px", offset_tolerance_px, 0, 16, "pixels", "offset tolerance around the polyline");
    v.field("grey_tolerance", grey_tolerance, 0, 254, "grey levels", "largest left/right grey difference that matches");
    v.field("background_beside_ground", background_beside_ground, 0, 1, "",
            "below the horizon row, match the background where the ground would be farther");
    v.field("band_rows", band_rows, 1, 4096, "rows", "rows per parallel band");
  }
  void validate() const { validateParams(*this, "removal"); }
};

class FeatureRemover {
 public:
  explicit FeatureRemover(const RemovalParams& params = {});

  // left: left feature image (CV_8UC1), not modified. right: right feature image.
  // remaining: copy of `left` without the removed pixels. labels: CV_8UC1,
  // kLabelNone / kLabelUnassigned / kLabelGround / kLabelBackground.
  // changed_rows[y] = 1 where a pixel was removed. Parallel row bands; bit-identical to computeReference.
  void compute(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& remaining,
               cv::Mat& labels, std::vector<std::uint8_t>& changed_rows);
  void computeReference(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& remaining,
                        cv::Mat& labels, std::vector<std::uint8_t>& changed_rows);

  const RemovalParams& params() const { return params_; }

 private:
  void prepare(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& remaining,
               cv::Mat& labels, std::vector<std::uint8_t>& changed_rows) const;
  void removeRows(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& remaining,
                  cv::Mat& labels, std::vector<std::uint8_t>& changed_rows, int y0, int y1) const;

  // Fast rows: offset windows computed per column, matched by a vector kernel over runs
  // of columns sharing a window. scratch: per band, reused.
  // The offset below which a ground row shows the background (-inf: none).
  float backgroundFloor(const GroundProfile& ground, bool ground_row) const;
  struct BandScratch {
    std::vector<std::uint8_t> marks;
  };
  void removeRowsFast(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& remaining,
                      cv::Mat& labels, std::vector<std::uint8_t>& changed_rows, int y0, int y1,
                      BandScratch& scratch) const;

  RemovalParams params_;
  std::vector<BandScratch> band_scratch_;
};

}  // namespace sg
