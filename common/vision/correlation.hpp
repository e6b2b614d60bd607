#pragma once
// Correlation image (seed paper, Sec. III, figure 3d): for every image row y
// and every offset d in 0..D-1, how well the left feature row matches the
// right feature row shifted by d (left x matches right x - d).
//
// Definition (docs/method.md):
//   match(y, x, d) = L(y, x) > 0 and R(y, x - d) > 0 and |L(y, x) - R(y, x - d)| <= grey_tolerance
//   matches(y, d)  = number of x in [d, W) with match(y, x, d)            (CV_32S)
//   score(y, d)    = matches(y, d) / max(N_L(y), min_row_features)        (CV_32F)
// where N_L(y) is the number of left feature pixels in row y. A row without
// left features scores 0 everywhere. Integer counting keeps every output exact:
// the serial reference and the parallel path give bit-identical images.
//
// Not re-entrant: a correlator owns its scratch; use one per thread.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "config/params.hpp"

namespace sg {

struct CorrelationParams {
  int offsets = 128;          // D: offsets 0..D-1 (pixels of disparity)
  int grey_tolerance = 12;    // grey levels: larger differences do not match (gain and noise between cameras)
  int min_row_features = 8;   // normaliser floor: a row with a handful of features cannot score 1
  int band_rows = 8;          // rows per TBB band (fixed: results never depend on the thread count)

  template <class V>
  void visit(V& v) {
    v.field("offsets", offsets, 1, 1024, "pixels", "number of offsets D (disparities 0..D-1)");
    v.field("grey_tolerance", grey_tolerance, 0, 254, "grey levels", "largest left/right grey difference that matches");
    v.field("min_row_features", min_row_features, 1, 100000, "pixels", "floor of the per-row normaliser");
    v.field("band_rows", band_rows, 1, 4096, "rows", "rows per parallel band");
  }
  void validate() const { validateParams(*this, "correlation"); }
};

// Number of left pixels in [x0, x1) matching the right row at offset d (right x - d), the inner loop.
int countRowMatches(const std::uint8_t* left, const std::uint8_t* right, int x0, int x1, int d, int grey_tolerance);

// The correlation's counts split by column strips: counts of row y, strip k (columns
// [k * cols / strips, (k + 1) * cols / strips)) and offset d at at(y, k)[d]. The row's
// matches(y, d) are the sums over its strips. Made by Correlator::compute when strips are
// asked for (setStrips), for the transversal slope (GroundEstimator::estimateRoll).
struct StripMatches {
  int strips = 0, rows = 0, cols = 0, offsets = 0, grey_tolerance = 0;
  int first_row = 0;        // rows above it were not split
  bool valid = false;       // describes the last compute()'s feature images
  std::vector<int> counts;  // rows x strips x offsets
  const int* at(int y, int k) const {
    return counts.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(strips) +
                            static_cast<std::size_t>(k)) * static_cast<std::size_t>(offsets);
  }
};

class Correlator {
 public:
  explicit Correlator(const CorrelationParams& params = {});

  // left, right: CV_8UC1 feature images of the same size. score: CV_32F rows x D;
  // matches: CV_32S rows x D. Parallel row bands (TBB), bit-identical to computeReference.
  void compute(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches);
  void compute(const cv::Mat& left, const cv::Mat& right, cv::Mat& score);
  void computeReference(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches);
  // Recomputes only the rows with rows[y] != 0 (score/matches already hold the other rows);
  // identical to a full compute on the same inputs.
  void computeRows(const cv::Mat& left, const cv::Mat& right, const std::vector<std::uint8_t>& rows, cv::Mat& score,
                   cv::Mat& matches);
  // After pixels were taken out of the left feature image: `matches` holds the
  // correlation of `before`, `after` is `before` with some pixels set to 0 on the
  // rows with rows[y] != 0. Each such row is updated by counting the removed
  // pixels out or the remaining ones afresh, whichever are fewer (a row where
  // `after` is not such a subset of `before` is recomputed). Identical to a full
  // compute of `after`.
  void updateRows(const cv::Mat& before, const cv::Mat& after, const cv::Mat& right,
                  const std::vector<std::uint8_t>& rows, cv::Mat& score, cv::Mat& matches);

  const CorrelationParams& params() const { return params_; }
  // compute() also counts the matches of `strips` column strips (0: not) on the rows from
  // first_row down (the ground rows: the counts cost the row a little more).
  void setStrips(int strips, int first_row = 0) {
    strip_count_ = strips;
    strip_first_row_ = first_row;
  }
  // The strips of the last compute(); `valid` is false after any other computation.
  const StripMatches& strips() const { return strips_; }

 private:
  void prepare(const cv::Mat& left, const cv::Mat& right, cv::Mat& score, cv::Mat& matches) const;
  // Serial reference of one row (countRowMatches per offset).
  void correlateRow(const cv::Mat& left, const cv::Mat& right, int y, cv::Mat& score, cv::Mat& matches) const;
  // Fast row: vector kernel over the left feature pixels only. `before` not null:
  // update from the correlation of `before` (see updateRows).
  // With_strips: a full row's counts strip by strip into strips_ (then summed).
  void correlateRowFast(const cv::Mat& left, const cv::Mat* before, const cv::Mat& right, int y, cv::Mat& score,
                        cv::Mat& matches, std::vector<std::uint8_t>& padded_right, bool with_strips = false);
  std::vector<std::uint8_t>& bandScratch(int band);
  // Runs fn(y, scratch) for every row of `rows` rows in parallel row bands.
  template <class Fn>
  void forEachRow(int rows, Fn&& fn);

  CorrelationParams params_;
  cv::Mat scratch_score_;  // for the score-only overload
  cv::Mat scratch_matches_;
  std::vector<std::vector<std::uint8_t>> band_scratch_;  // per band: padded right row, reused across frames
  int strip_count_ = 0, strip_first_row_ = 0;
  std::vector<int> strip_bounds_;  // the strips' first columns, then the width
  StripMatches strips_;
};

}  // namespace sg
