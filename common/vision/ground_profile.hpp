#pragma once
// Ground and background polyline (seed paper, Sec. III, figures 2 and 4a).
//
// A Hough transform over the row peaks of the correlation image finds the
// slanted ground line d = s * (y - y_h) (offset grows below the horizon row
// y_h); the vertical background line above the horizon is the offset that
// dominates the rows above it. Beyond the paper:
//  - a second Hough pass on the peaks the first line leaves unexplained finds a
//    second ground segment meeting the first one (slope change: ramps, crests);
//  - both segments are refined by a weighted least-squares fit on their peaks;
//  - when the ground texture is too weak (too little support), the line of the
//    previous frame (if recent) or the rig's mounting prior is used, and the
//    profile says so in GroundProfile::source.
#include <limits>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"
#include "config/params.hpp"
#include "vision/correlation.hpp"
#include "vision/segmentation_types.hpp"

namespace sg {

struct GroundParams {
  // Row peaks that vote.
  int max_peaks_per_row = 3;        // strongest local maxima of a row that vote
  float min_peak_score = 0.08f;     // a peak below this score (matched fraction of the row) does not vote
  float peak_ratio = 0.5f;          // a peak below this fraction of its row's maximum does not vote
  // Hough space: ground slope s (offset pixels per row) and horizon row.
  double min_slope = 0.03;          // s = B / camera height for a level rig: B 0.1..0.6 m, height 0.5..3 m
  double max_slope = 1.5;
  double slope_step = 0.004;
  // Acceptance of a measured line.
  double support_tolerance_px = 1.5;  // a row supports a line when one of its peaks is this close (offset pixels)
  int min_support_rows = 20;          // fewer supporting rows: the texture is too weak, fall back
  double min_support_fraction = 0.3;  // ... or a smaller fraction of the rows the line crosses
  // A line supported by fewer than this share of the rows it crosses is kept only when the
  // column strips then measure the ground's transversal slope (a tilted ground spreads each
  // row's match over many offsets, so its rows support the line less); otherwise it is taken
  // for object outlines lined up with chance peaks on weak texture, and the fallback is used.
  // 0: every line above min_support_fraction is kept.
  double corroborated_support_fraction = 0.5;
  bool piecewise = true;              // look for a second segment (slope change)
  int min_segment_rows = 15;          // rows supporting the second segment on its side
  // A slope change ahead: unless the second Hough pass found a near segment, a far segment
  // meeting the line (farSegment) replaces the pass's far one, or stands alone, when it explains
  // min_segment_rows more rows above its junction than the line does.
  bool far_segment_search = true;
  double far_min_slope_ratio = 0.2;   // flattest far segment, as a share of the line's slope
  // The second pass's segment farther than its junction also replaces the line above it when,
  // over the rows where each is the ground (its offset above the background's), its share of
  // supported rows is far_share_ratio times the line's, on at least far_share_min_rows rows. A
  // crest or a dip ahead shows a steep far segment on few rows, while the line's extension
  // crosses the offsets of what stands there at a shallow angle and gathers their chance peaks
  // row after row.
  double far_share_ratio = 2.0;       // 0: only the row counts decide
  int far_share_min_rows = 8;
  // Background line above the horizon.
  float min_background_score = 0.5f;  // summed score of the best background column; below: offset 0 (infinity)
  double background_row_share = 0.3;  // a row's background score: its matches over at least this share of the width
  // Fallback when the ground is not measured.
  // Transversal slope (beyond the paper): offsets of column strips around the line.
  int roll_strips = 8;                // column strips measured
  int roll_search_px = 12;            // offsets searched on either side of the line
  double min_roll_px = 1.0;           // a change across the image below this is ignored (level ground)
  int profile_band_rows = 24;         // rows per band of the along-the-line correction (0 = one shift)
  // A band whose shifted line would reach the background (within support_tolerance_px) on its
  // own first row measured what lies beyond the ground (hills past a crest): its shift is not used.
  bool band_above_background = true;
  bool prefer_previous = true;        // previous frame's line before the mounting prior
  int max_previous_age_frames = 10;   // a previous line older than this is not used
  // The mounting prior is flat ground. On a slope the ground meets the background elsewhere:
  // the prior moved to where the background's features end is used when the level prior is
  // refuted (rows showing something farther than its ground), or neither is and more rows support it.
  bool prior_background_edge = true;
  float background_edge_share = 0.6f;  // a row shows the background when this share of its features matches there
  int background_edge_gap_rows = 4;    // rows without it tolerated inside the background
  double refuting_ratio = 3.0;         // a line is refuted by min_support_rows rows beyond it, this many
                                       // times the other line's
  // On a transversal slope the ground meets the background along a slanted line. Where the
  // prior stands in for the ground line, the background's lower edge in column bands gives
  // that line: the prior is tilted to meet it (its offset per column) and placed where it
  // crosses the reference column.
  bool prior_tilt = true;
  int prior_tilt_bands = 16;            // column bands whose background edge is found
  double prior_tilt_inlier_rows = 3.0;  // a band's edge within this of the fitted line agrees
  int prior_tilt_min_bands = 8;         // fewest agreeing bands for a tilt

  template <class V>
  void visit(V& v) {
    v.field("max_peaks_per_row", max_peaks_per_row, 1, 16, "", "row peaks voting in the Hough transform");
    v.field("min_peak_score", min_peak_score, 0.0, 1.0, "score", "weakest peak that votes");
    v.field("peak_ratio", peak_ratio, 0.0, 1.0, "", "weakest peak relative to its row maximum");
    v.field("min_slope", min_slope, 0.001, 10.0, "offset px per row", "smallest ground slope searched");
    v.field("max_slope", max_slope, 0.001, 10.0, "offset px per row", "largest ground slope searched");
    v.field("slope_step", slope_step, 0.0001, 1.0, "offset px per row", "slope resolution of the Hough space");
    v.field("support_tolerance_px", support_tolerance_px, 0.1, 10.0, "pixels", "peak distance supporting a line");
    v.field("min_support_rows", min_support_rows, 1, 100000, "rows", "support needed to accept a measured line");
    v.field("min_support_fraction", min_support_fraction, 0.0, 1.0, "", "support fraction needed");
    v.field("corroborated_support_fraction", corroborated_support_fraction, 0.0, 1.0, "",
            "a line supported by fewer than this share of its rows is kept only when the strips measure a "
            "transversal slope (tilted ground); else the fallback is used (0: off)");
    v.field("piecewise", piecewise, 0, 1, "", "fit a second ground segment (slope change)");
    v.field("far_segment_search", far_segment_search, 0, 1, "",
            "with piecewise: search a far segment meeting the line at a junction row (slope change ahead)");
    v.field("far_min_slope_ratio", far_min_slope_ratio, 0.0, 1.0, "",
            "flattest far segment as a share of the line's slope (a rise ahead; flatter: poles standing)");
    v.field("far_share_ratio", far_share_ratio, 0.0, 100.0, "",
            "with piecewise: a far segment of the second pass replaces the line above their junction when its share "
            "of supported rows, where each is the ground, is this many times the line's (0: off)");
    v.field("far_share_min_rows", far_share_min_rows, 1, 100000, "rows",
            "supported rows such a far segment needs");
    v.field("min_segment_rows", min_segment_rows, 1, 100000, "rows", "support needed by the second segment");
    v.field("min_background_score", min_background_score, 0.0, 1e9, "score", "weakest accepted background line");
    v.field("background_row_share", background_row_share, 0.0, 1.0, "",
            "a row's score for the background: its matches over at least this share of the image width (rows of few features say less)");
    v.field("roll_strips", roll_strips, 0, 64, "", "column strips for the transversal slope (0 = off)");
    v.field("roll_search_px", roll_search_px, 1, 64, "pixels", "offsets searched around the line per strip");
    v.field("min_roll_px", min_roll_px, 0.0, 100.0, "pixels", "smallest offset change across the image that counts");
    v.field("profile_band_rows", profile_band_rows, 0, 100000, "rows",
            "row band of the ground line's measured correction (0 = one shift for the whole line)");
    v.field("prefer_previous", prefer_previous, 0, 1, "", "use the previous frame's line before the prior");
    v.field("max_previous_age_frames", max_previous_age_frames, 0, 100000, "frames", "oldest usable previous line");
    v.field("band_above_background", band_above_background, 0, 1, "",
            "drop a band's correction when it would bring the ground down to the background's offset on the band's "
            "first row (the band measured the hills beyond a crest)");
    v.field("prior_background_edge", prior_background_edge, 0, 1, "",
            "also try the prior moved to meet the background's lower edge; keep the one not refuted, else the better supported");
    v.field("background_edge_share", background_edge_share, 0.0, 1.0, "",
            "share of a row's features matching the background offset that marks a background row");
    v.field("background_edge_gap_rows", background_edge_gap_rows, 0, 100000, "rows",
            "rows without the background tolerated inside it");
    v.field("refuting_ratio", refuting_ratio, 1.0, 1000.0, "",
            "rows beyond a prior line, relative to the other line's, that refute it");
    v.field("prior_tilt", prior_tilt, 0, 1, "",
            "tilt the mounting prior to the background's lower edge measured in column bands (transversal slope)");
    v.field("prior_tilt_bands", prior_tilt_bands, 3, 256, "", "column bands whose background edge is found");
    v.field("prior_tilt_inlier_rows", prior_tilt_inlier_rows, 0.0, 100.0, "rows",
            "a band's edge within this of the fitted line agrees with it");
    v.field("prior_tilt_min_bands", prior_tilt_min_bands, 2, 256, "", "fewest agreeing bands for a tilt");
  }
  void validate() const {
    validateParams(*this, "ground");
    if (min_slope >= max_slope) throw ParamError("parameter 'ground.min_slope' must be below 'ground.max_slope'");
  }
};

// One straight ground segment d = slope * (row - horizon_row).
struct GroundLine {
  double slope = 0.0;        // offset pixels per row
  double horizon_row = 0.0;  // row where the offset is 0
  int support_rows = 0;
  double offsetAt(double row) const { return slope * (row - horizon_row); }
  // The row where this line and `other` (of another slope) have the same offset.
  double junctionRow(const GroundLine& other) const {
    return (slope * horizon_row - other.slope * other.horizon_row) / (slope - other.slope);
  }
};

class GroundEstimator {
 public:
  explicit GroundEstimator(const GroundParams& params = {});

  // score: CV_32F rows x D correlation image; matches: its CV_32S counts (rows with few
  // features weigh less for the background line; empty: every row's score counts in full). `previous`: the last
  // measured profile and its age in frames (for the fallback), or nullptr.
  // Fast path (table-driven Hough votes, vectorised neighbourhood search, no
  // allocation once sized); bit-identical to computeReference.
  // refuse_measured: the measured line is not used (it was not corroborated): the fallback is.
  void compute(const cv::Mat& score, const cv::Mat& matches, const StereoRig& rig, const GroundProfile* previous,
               int previous_age_frames, GroundProfile& out, bool refuse_measured = false);
  void computeReference(const cv::Mat& score, const cv::Mat& matches, const StereoRig& rig,
                        const GroundProfile* previous, int previous_age_frames, GroundProfile& out,
                        bool refuse_measured = false);
  // Whether the last compute's measured line needs the strips' corroboration
  // (corroborated_support_fraction): false when none was measured.
  bool needsCorroboration() const { return needs_corroboration_; }

  // The main (first) line of the last compute, when measured.
  const std::optional<GroundLine>& mainLine() const { return main_line_; }
  const std::optional<GroundLine>& secondLine() const { return second_line_; }
  // The Hough maxima of the last compute, before the refit: the first pass's, and the
  // second pass's (on the peaks the first line leaves) when it ran.
  const std::optional<GroundLine>& mainHoughLine() const { return main_hough_; }
  const std::optional<GroundLine>& secondHoughLine() const { return second_hough_; }

  // Transversal slope: fills ground.offset_per_column / reference_column from the
  // offsets of column strips of the ground rows around the line (feature images).
  // Vector kernel over the left feature pixels; bit-identical to estimateRollReference.
  // With `strips` (the correlation of these feature images, split into roll_strips column
  // strips) the counts are read from there instead of matched again.
  void estimateRoll(const cv::Mat& left_features, const cv::Mat& right_features, const StereoRig& rig,
                    GroundProfile& ground, const StripMatches* strips = nullptr);
  void estimateRollReference(const cv::Mat& left_features, const cv::Mat& right_features, const StereoRig& rig,
                             GroundProfile& ground);

  // For a line from the mounting prior (ground.source == kPrior) and no transversal slope
  // measured: finds the background's lower edge in prior_tilt_bands column bands of the
  // feature images and fits a line through them. When enough bands agree on a tilt that
  // changes the offset by min_roll_px or more across the image, the prior gets that offset per
  // column; a prior moved to the background's edge is also placed where the fitted edge
  // crosses the reference column (the level prior keeps its rows: the mounting puts it under
  // the camera). Returns true when the line was tilted. Plain code shared by the fast and the
  // reference paths.
  bool tiltPrior(const cv::Mat& left_features, const cv::Mat& right_features, const StereoRig& rig,
                 GroundProfile& ground);

  const GroundParams& params() const { return params_; }

 private:
  std::vector<double> tilt_columns_, tilt_edges_, tilt_slopes_;  // tiltPrior's bands, reused
  struct Peak {
    int row;
    int offset;
    float weight;
  };
  void computeImpl(const cv::Mat& score, const cv::Mat& matches, const StereoRig& rig, const GroundProfile* previous,
                   int previous_age_frames, GroundProfile& out, bool reference, bool refuse_measured);
  void findPeaksReference(const cv::Mat& score);
  void keepStrongest(std::vector<Peak>& row_peaks);  // appends a row's strongest peaks to peaks_
  void findPeaks(const cv::Mat& score);  // vector test of the local maxima; same peaks as findPeaksReference
  std::optional<GroundLine> hough(const std::vector<std::uint8_t>& use, int rows, int offsets) const;
  std::optional<GroundLine> houghFast(const std::vector<std::uint8_t>& use, int rows, int offsets);
  // Roll: rows, strips and offsets to histogram; false when the roll is not estimated.
  bool rollSetUp(const cv::Mat& left, const StereoRig& rig, GroundProfile& ground);
  int rollBand(int y) const;  // band of ground row y in roll_hist_
  // The transversal slope and the line's correction from roll_hist_.
  void rollFit(int width, GroundProfile& ground);
  // profile_band_rows 0: one weighted line through all strips, and one shift for the line.
  void rollFitWhole(int width, GroundProfile& ground);
  // Each strip's peak in `hist` (one band): centre column relative to reference_column, shift
  // beyond `roll` per column, weight; into band_column_, band_residual_, band_weight_.
  void collectStrips(const double* hist, int width, float reference_column, double roll);
  // Weighted line shift + tilt * column through the collected strips, leaving out those
  // farther than max_deviation from the current line; false with fewer than min_strips.
  bool fitBandLine(double max_deviation, double& shift, double& tilt, int min_strips) const;
  // The strips' line fitted twice (outliers out), true when the strips agree with it.
  bool fitStrips(double& shift, double& tilt) const;
  // The far segment of a slope change ahead, if the rows above the line show one: a segment
  // through the line at a junction row, steeper or flatter, chosen where it is supported by
  // more of the rows above the junction than the line's own extension. Only rows where the
  // segment is ground (farther than the background by more than support_tolerance_px) count,
  // for both: rows where it would be the background say nothing about the ground; nor do the
  // rows next to the junction where the two lie within the tolerance of each other. The line
  // must stay supported below the junction on min_segment_rows rows. Kept when it explains at
  // least min_segment_rows more rows than the line, also once refitted to its peaks.
  // `floor`: the line's groundFloor, computed here on first use.
  std::optional<GroundLine> farSegment(const cv::Mat& score, const cv::Mat& matches, const GroundLine& line,
                                       std::optional<double>& floor);
  // The offset a row's ground must exceed to be ground rather than background beyond `line`:
  // the background the line alone leaves (backgroundOffset over the rows above its horizon) plus
  // support_tolerance_px. Kept in `floor` on first use; read from it after.
  double groundFloor(const cv::Mat& score, const cv::Mat& matches, const GroundLine& line,
                     std::optional<double>& floor);
  // Whether `far` (the second pass's segment, farther than the junction row `junction`) explains
  // the rows from row_begin to the junction better than `line`: on the rows where each is the
  // ground (its offset above the background's by more than support_tolerance_px), away from the
  // junction's shared rows, it is supported on far_share_min_rows rows or more and on
  // far_share_ratio times the line's share of its rows.
  bool farSegmentWinsOnItsRows(const cv::Mat& score, const cv::Mat& matches, const GroundLine& line,
                               const GroundLine& far, int row_begin, int junction, std::optional<double>& floor);
  // Row y has a peak within support_tolerance_px of offset d.
  bool peakNear(int y, double d) const;
  // Rows in [row_begin, row_end) where the line's offset lies in [0.5, offsets - 1] and above
  // `above`, and (the return) those of them supporting it (peakNear).
  int support(const GroundLine& line, int row_begin, int row_end, int offsets, int* crossed,
              double above = -std::numeric_limits<double>::infinity()) const;
  GroundLine refit(const GroundLine& line, int row_begin, int row_end) const;
  // The offset dominating the score of the first `rows_above` rows whose background would not
  // hide measured ground: a background at offset b hides every ground row nearer than b. With
  // `matches` (the score's counts), a row's score is taken over at least per_match_'s share of
  // the width; empty, every row's score counts in full.
  float backgroundOffset(const cv::Mat& score, const cv::Mat& matches, int rows_above,
                         const std::vector<float>& ground_per_row);
  // The background's offset to a fraction of a pixel, from the column sums of the last
  // backgroundOffset() around its (whole) offset.
  double refinedBackground(float background) const;
  // True when the ground rows a background at `offset` would hide show the ground (peaks on
  // `ground_per_row`) as a measured segment does (min_segment_rows, and min_support_fraction of
  // the hidden rows) and make up min_support_fraction of all the rows supporting the ground.
  bool hidesMeasuredGround(float offset, const std::vector<float>& ground_per_row) const;
  // The row below the first run of rows (from the top, gaps of background_edge_gap_rows
  // allowed) where at least background_edge_share of the features match the background
  // offset +-1; 0 when no row does.
  int backgroundEdgeRow(const cv::Mat& score, float background) const;
  // Rows in [row_begin, row_end) whose strongest peak (of those that vote) lies farther
  // than the line's ground by more than support_tolerance_px, and is not the background: what
  // stands on the ground is never farther than the ground behind it.
  int rowsBeyond(const GroundLine& line, int row_begin, int row_end, float background) const;

  GroundParams params_;
  std::vector<Peak> peaks_;
  std::vector<int> row_peak_begin_;  // peaks_ index of each row's first peak, rows + 1 entries
  mutable std::vector<float> accumulator_;
  std::vector<std::uint8_t> use_;
  std::vector<double> roll_hist_;        // per row band, strip and offset around the line
  int roll_first_row_ = 0;               // first row of band 0
  int roll_bands_ = 1;
  std::vector<double> roll_total_;       // roll_hist_ summed over the bands
  std::vector<double> band_column_;      // per strip of a band: centre column, shift beyond the roll, weight
  std::vector<double> band_residual_;
  std::vector<double> band_weight_;
  struct BandFit {
    float row;    // the band's centre row
    float shift;  // the line's correction there, at the reference column
    float tilt;   // the band's transversal slope (offset pixels per column)
  };
  std::vector<BandFit> band_fits_;       // the bands that passed the agreement test, top to bottom
  std::vector<int> vertex_rows_;         // rows of the corrected polyline's ground vertices
  // Scratch of the fast paths, sized on the first frame and reused.
  std::vector<Peak> row_peaks_;
  std::vector<int> bin_shift_;          // Hough bin - row - rows per slope and offset (slope-major)
  int slope_table_offsets_ = 0;         // offsets bin_shift_ was built for
  std::vector<int> vote_base_;          // voting peaks: row + rows, offset, weight
  std::vector<int> vote_offset_;
  std::vector<float> vote_weight_;
  std::vector<float> slope_rows_;       // Hough accumulator rows of three slopes and a zero row
  std::vector<float> window_sums_;      // 3x3 sums of one slope
  // houghFast's branch and bound over groups of consecutive slopes.
  struct GroupSpan {
    int first;       // a vote's windows run from bin row + rows + first ...
    int end;         // ... to before row + rows + end
    double repeats;  // slopes of one window at which a vote can fall into it (1 .. 3)
  };
  std::vector<GroupSpan> group_spans_;  // per group (level by level) and offset
  std::vector<double> bound_diff_;      // a group's bound: difference array over the bins
  struct OpenGroup {
    double bound;
    int group;
  };
  std::vector<OpenGroup> open_groups_;  // groups neither scanned nor dropped
  std::vector<float> background_sums_;
  std::vector<float> line_rows_;          // groundFloor: the line's offset per row
  std::vector<int> line_support_;         // farSegment: rows supporting the line, prefix sums
  std::vector<int> far_bound_;            // farSegment: most rows a segment ending at a row can gain
  std::vector<int> far_votes_;            // farSegment: per junction row, rows voting (difference array)
  struct FarRow {
    int row;
    int first;  // its peaks in far_peaks_
    int peaks;
  };
  std::vector<FarRow> far_rows_;          // farSegment: rows that may vote ...
  std::vector<double> far_peaks_;         // ... and their peaks' offsets
  std::vector<double> roll_sorted_;
  std::vector<std::uint8_t> roll_right_;  // padded right row
  std::vector<int> roll_counts_;
  bool needs_corroboration_ = false;
  std::optional<GroundLine> main_line_;
  std::optional<GroundLine> second_line_;
  std::optional<GroundLine> main_hough_;
  std::optional<GroundLine> second_hough_;
  bool prior_moved_ = false;  // the last compute's prior was moved to the background's edge
  float per_match_ = 1.0f;            // 1 / (background_row_share x width): the most one match adds to a row's score
};

}  // namespace sg
