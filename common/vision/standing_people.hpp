#pragma once
// Far people standing on the ground line, found where the obstacle loop cannot see them.
//
// A person 20-40 m away is 8-15 px wide and 25-55 px tall. The ground removal takes
// most of such a figure's features (near the feet the ground's offset is the person's,
// and plain clothing matches itself at the ground's offset a few pixels away), and
// the few that stay are too few per row to lift the offset histogram of whole rows.
//
// This stage asks a local question instead, for every far offset d and every column x:
// on the rows a person standing at offset d would cover (from the ground contact row of
// d upwards), how many left feature pixels match the right image at d clearly better
// than at the ground/background line's offset of their row? The test compares sums of
// absolute differences over a 5-pixel horizontal window: a pixel of the ground (or of
// the background behind the person) matches at the line's offset, a pixel of a figure
// standing at d matches at d, and a plain pixel that matches both counts for neither.
// Rows where the line's offset is within ground_clearance_px of d cannot tell the two
// apart and are left out. A window of a person's width whose share of such pixels is
// high is an obstacle at d: its matching features are labelled as a new cluster, which
// the human localization then examines like any other.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "config/params.hpp"
#include "vision/segmentation_types.hpp"

namespace sg {

struct StandingParams {
  bool enabled = true;
  double near_m = 20.0;            // offsets of nearer people are left to the obstacle loop
  double far_m = 40.0;             // farthest distance searched (metres)
  double window_height_m = 1.6;    // rows examined above the contact row (an adult's height)
  double window_width_m = 0.4;     // columns summed (a person's shoulders)
  double ground_clearance_px = 2.0;  // rows whose line offset is within this of d are left out
  int cost_margin = 20;            // 5-pixel SAD at d must beat the line's by this (grey levels)
  int max_cost = 40;               // 5-pixel SAD at d at most this (grey levels)
  double min_density = 0.15;       // share of the window's rows x columns holding such pixels
  int min_pixels = 30;             // fewest such pixels in a window
  double min_zscore = 6.0;         // standard deviations above the mean window of its offset
  double top_gap_m = 0.2;          // rows without standing pixels a figure's top is followed across
  int max_clusters = 4;            // clusters added per frame
  int grey_tolerance = 12;         // a feature joins the cluster when it matches at d +-1 within this
  int row_step = 2;                // windows count every row_step-th row (a far person's rows are alike)

  template <class V>
  void visit(V& v) {
    v.field("enabled", enabled, 0, 1, "", "search far people standing on the ground line (local stereo test)");
    v.field("near_m", near_m, 1.0, 500.0, "metres", "nearest distance searched; nearer people are the obstacle loop's");
    v.field("far_m", far_m, 1.0, 500.0, "metres", "farthest distance searched");
    v.field("window_height_m", window_height_m, 0.3, 3.0, "metres", "rows examined above the ground contact");
    v.field("window_width_m", window_width_m, 0.1, 2.0, "metres", "columns summed into one window");
    v.field("ground_clearance_px", ground_clearance_px, 0.0, 20.0, "pixels",
            "rows whose ground/background offset is within this of d are left out (ambiguous)");
    v.field("cost_margin", cost_margin, 0, 1275, "grey levels",
            "5-pixel SAD at d must be lower than at the line's offset by this");
    v.field("max_cost", max_cost, 0, 1275, "grey levels", "largest 5-pixel SAD at d that matches");
    v.field("min_density", min_density, 0.0, 1.0, "", "share of the window's cells standing at d");
    v.field("min_pixels", min_pixels, 1, 100000, "pixels", "fewest standing pixels in a window");
    v.field("min_zscore", min_zscore, 0.0, 100.0, "",
            "a window's standing pixels exceed the mean over all windows of its offset by this many standard "
            "deviations (a figure stands out; a structure at that offset does not)");
    v.field("top_gap_m", top_gap_m, 0.0, 1.0, "metres",
            "gap in the standing pixels (a plain shirt) a cluster's top is followed up across");
    v.field("max_clusters", max_clusters, 0, 64, "", "clusters added per frame");
    v.field("grey_tolerance", grey_tolerance, 0, 255, "grey levels", "grey difference of a cluster pixel's match");
    v.field("row_step", row_step, 1, 8, "rows", "windows count every row_step-th row, each standing for row_step rows");
  }
  void validate() const;
};

class StandingPeopleFinder {
 public:
  explicit StandingPeopleFinder(const StandingParams& params = {});

  // Adds clusters for far figures standing on the ground line to `obstacles` and labels
  // their pixels in `labels` (feature pixels not already an obstacle's), up to
  // max_obstacles in all, none farther than max_range_m (0: far_m alone limits).
  // Returns the number added.
  int compute(const cv::Mat& left_features, const cv::Mat& right_features, const GroundProfile& ground,
              double baseline_m, double focal_px, int max_obstacles, double max_range_m, cv::Mat& labels,
              std::vector<ObstacleCluster>& obstacles);
  // The same, written plainly (pixel by pixel, column by column): identical results.
  int computeReference(const cv::Mat& left_features, const cv::Mat& right_features, const GroundProfile& ground,
                       double baseline_m, double focal_px, int max_obstacles, double max_range_m, cv::Mat& labels,
                       std::vector<ObstacleCluster>& obstacles);

 private:
  int run(const cv::Mat& left_features, const cv::Mat& right_features, const GroundProfile& ground, double baseline_m,
          double focal_px, int max_obstacles, double max_range_m, cv::Mat& labels,
          std::vector<ObstacleCluster>& obstacles, bool reference);
  struct Window {
    int offset = 0, x0 = 0, x1 = 0;  // columns [x0, x1)
    int pixels = 0;
    double density = 0.0;
  };
  StandingParams params_;
  std::vector<int> contact_;         // per searched offset and column: contact row (-1: none)
  // A row of line_cost_ (CV_16UC1: each pixel's 5-pixel SAD at the line's offset +-1),
  // computed on the row's first use in a frame.
  const std::uint16_t* lineCostRow(int y, const cv::Mat& left_features, const cv::Mat& right_features,
                                   const GroundProfile& ground);
  cv::Mat line_cost_;
  std::vector<std::uint8_t> line_cost_ready_;  // per row
  std::vector<int> line_round_;                // one row: the line's offset per column, rounded
  std::vector<int> column_count_;    // per column: standing pixels
  std::vector<int> column_cells_;    // per column: rows examined
  std::vector<int> window_top_, window_bottom_;  // per column: rows [top, bottom) of the current offset
  std::vector<std::uint8_t> diff_;       // one row: |left - right| at the current offset
  std::vector<std::uint16_t> sad_;       // one row: their 5-pixel sums
  std::vector<std::uint8_t> candidate_;  // one row: pixels worth the line's cost
  std::vector<Window> row_windows_;  // windows of one offset
  std::vector<Window> windows_;
  std::vector<Window> accepted_;
};

}  // namespace sg
