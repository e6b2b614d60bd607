#pragma once
// Vertical symmetry of grey levels and edges inside an image region
// (seed paper, Sec. II: "a human shape is characterized by a strong vertical
// symmetry"). Used by HumanLocalizer inside each obstacle cluster only
// (Sec. V), never over the whole frame.
//
// For a candidate axis column x, half-width k and rows [top, bottom]:
//  - edge symmetry: the share of edge weight whose mirror pixel about x
//    (within +- mirror_tolerance_px) is also an edge, corrected for the share
//    expected by chance at the box's edge density, in [0, 1];
//  - grey symmetry: the normalised cross-correlation of the left half with
//    the mirrored right half, in [-1, 1];
//  - horizontal coverage: the share of the edge weight of the band widened by
//    k/2 on both sides that falls inside the box (low when the box is too narrow);
//  - column occupancy: the share of the box's columns holding any edge
//    (low when the box is too wide).
// The box top is not searched: it is the row where the edge weight of the
// stripe starts (top_edge_fraction of the stripe's weight lies above it).
//
// Not re-entrant: one scanner per thread; it keeps its scratch across calls
// (compute() runs its own bands of axes in parallel).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "config/params.hpp"

namespace sg {

struct SymmetryParams {
  int edge_threshold = 48;                  // Sobel |gx|+|gy| (grey levels, 3x3) marking an edge
  float full_weight_ratio = 3.0f;           // an edge weighs 1 from this multiple of edge_threshold on (less below)
  int mirror_tolerance_px = 1;              // a mirrored edge may be this far off its ideal column
  float outside_cluster_edge_weight = 0.2f; // weight of edges that the segmentation did not put in the cluster
  float grey_weight = 0.25f;                // share of grey symmetry in the symmetry score (rest: edges)
  float top_edge_fraction = 0.02f;          // stripe edge weight above the box top (fraction)
  int axis_step_px = 1;                     // spacing of candidate axes
  int width_step_px = 2;                    // spacing of candidate widths

  template <class V>
  void visit(V& v) {
    v.field("edge_threshold", edge_threshold, 1, 2040, "grey levels", "Sobel |gx|+|gy| (3x3) marking an edge pixel");
    v.field("full_weight_ratio", full_weight_ratio, 1.0, 20.0, "",
            "edges weigh magnitude / (ratio * edge_threshold), at most 1: silhouettes count more than texture");
    v.field("mirror_tolerance_px", mirror_tolerance_px, 0, 4, "pixels",
            "an edge's mirror may be this far from its ideal column (legs and arms are not exactly symmetric)");
    v.field("outside_cluster_edge_weight", outside_cluster_edge_weight, 0.0, 1.0, "",
            "weight of edges not labelled with the cluster (background, ground texture)");
    v.field("grey_weight", grey_weight, 0.0, 1.0, "", "share of grey-level symmetry in the symmetry score");
    v.field("top_edge_fraction", top_edge_fraction, 0.0, 0.3, "",
            "share of the stripe's edge weight allowed above the box top");
    v.field("axis_step_px", axis_step_px, 1, 16, "pixels", "spacing of candidate symmetry axes");
    v.field("width_step_px", width_step_px, 1, 16, "pixels", "spacing of candidate box widths");
  }
  void validate() const { validateParams(*this, "symmetry"); }
};

// What to search in one region (all coordinates relative to the region).
struct SymmetrySearch {
  int min_half_width_px = 2;   // half-width range of candidate boxes
  int max_half_width_px = 20;
  int bottom_row = 0;          // box bottom (row, inclusive)
  int min_height_px = 4;       // box heights accepted (bottom - top + 1)
  int max_height_px = 1000;
  double min_aspect = 1.5;     // height / width accepted
  double max_aspect = 5.0;
};

struct SymmetryCandidate {
  cv::Rect box;               // relative to the region
  int axis_col = 0;           // relative to the region
  float edge_symmetry = 0.0f; // [0, 1]
  float grey_symmetry = 0.0f; // [-1, 1]
  float coverage = 0.0f;      // [0, 1]
  float occupancy = 0.0f;     // [0, 1]
  float score = 0.0f;         // combined: symmetry * coverage * occupancy, [0, 1]
  float edge_density = 0.0f;  // edge weight per pixel inside the box
  float grey_stddev = 0.0f;   // grey-level standard deviation inside the box
};

class SymmetryScanner {
 public:
  explicit SymmetryScanner(const SymmetryParams& params);

  // Edge weight image (CV_32F, [0, 1]) of a grey region: Sobel edges, weight 1
  // where `cluster_mask` (CV_8U, same size, may be empty) is non-zero, else
  // outside_cluster_edge_weight. Like cv::Sobel, a region inside a larger image
  // takes its border pixels from that image (reflected at the image's own
  // border). Integer Sobel without scratch; `weights` is only (re)allocated when
  // it does not already have the region's size and type.
  void edgeWeights(const cv::Mat& grey, const cv::Mat& cluster_mask, cv::Mat& weights) const;
  // Same with cv::Sobel, the reference of edgeWeights(); bit-identical.
  void edgeWeightsReference(const cv::Mat& grey, const cv::Mat& cluster_mask, cv::Mat& weights) const;
  // The weight edgeWeights() gives pixel (y, x) of `image` (CV_8UC1, not a region) inside
  // the cluster: the same Sobel, reflected at the image border, and the same ramp.
  float edgeWeightAt(const cv::Mat& image, int y, int x) const;

  // Every axis/width of `search` whose box fits the height and aspect limits,
  // best-scoring width per axis. `grey` CV_8U and `weights` CV_32F, same size.
  // The edge weights are quantized to 1/512 steps, so every sum is an exact
  // integer. Fast path: the box top of every width is found first, so that an
  // axis with no admissible box costs nothing more; the edge and grey sums of
  // each half come from the region's integral images; the two mirrored
  // products (edge x mirrored edge, grey x grey) are summed per column pair in
  // 32-bit integers (vectors over the pairs), upwards from the bottom row and
  // only up to the highest box top. Scratch is kept across calls (no allocation
  // once it has grown to the largest region). A region may have at most 4095
  // rows (InputError above).
  //
  // bands > 1: the axes are dealt round-robin to that many bands, which run in
  // parallel (forEachBand), each with its own tables; the candidates come out in
  // axis order, identical for every number of bands.
  void compute(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
               std::vector<SymmetryCandidate>& out, int bands = 1);

  // Same with the serial reference: seven plain prefix tables over every
  // half-width and row of every axis; bit-identical to compute().
  void computeReference(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
                        std::vector<SymmetryCandidate>& out);

  // Symmetry measures of one box (relative to the region), for tests and tools.
  SymmetryCandidate measure(const cv::Mat& grey, const cv::Mat& weights, int axis_col, int half_width, int top,
                            int bottom);

  const SymmetryParams& params() const { return params_; }

 private:
  // Edge weights are quantized to integers in units of 1 / kWeightScale, so that
  // every sum below is an exact integer, whatever the order of summation.
  static constexpr int kWeightScale = 512;
  // The per-row mirrored sums are 32-bit: at most 2 * kWeightScale^2 per pair and row.
  static constexpr int kMaxRows = 4095;

  // Sums over one box of the per-axis quantities (exact integers).
  struct BoxSums {
    double e = 0.0, m = 0.0;                          // edge weight, mirrored edge weight products
    double a = 0.0, b = 0.0, aa = 0.0, bb = 0.0, ab = 0.0;  // grey left/right halves
  };
  // One admissible width of an axis: half-width, box top, and its mirrored sums.
  struct AxisWidth {
    int half = 0;
    int top = 0;
    std::int64_t m = 0, ab = 0;
  };
  // Per-axis scratch of the fast path (one set per band of axes), reused across calls.
  struct AxisTables {
    std::vector<AxisWidth> widths;
    std::vector<std::size_t> order;   // widths by decreasing top
    std::vector<std::int32_t> sm, sab;  // per pair j: mirrored edge products, grey products, rows [r, bottom]
  };

  // For both paths: the region's quantized weights, their mirror (max over
  // +-mirror_tolerance_px), integrals and column counts, and a header of `grey`.
  void prepare(const cv::Mat& grey, const cv::Mat& weights);
  void computeImpl(const cv::Mat& grey, const cv::Mat& weights, const SymmetrySearch& search,
                   std::vector<SymmetryCandidate>& out, bool reference, int bands);
  // Best candidate of one axis (fast path); false when no width is admissible there.
  bool scanAxisFast(AxisTables& t, int axis, const SymmetrySearch& search, int bottom, SymmetryCandidate& best) const;
  void buildAxisReference(int axis, int max_half, int rows);
  BoxSums referenceSums(int half, int top, int bottom) const;
  SymmetryCandidate evaluate(int axis, int half, int top, int bottom, const BoxSums& sums) const;
  int findTop(int x0, int x1, int bottom) const;
  // A CV_64F/CV_32F/CV_32S header of exactly rows x cols over `storage`, which only grows.
  static cv::Mat scratch(std::vector<double>& storage, int rows, int cols, int type);

  SymmetryParams params_;
  cv::Mat wq_, mq_;       // CV_32S quantized weights and their mirror (both paths)
  cv::Mat weight_integral_;  // CV_64F (rows+1) x (cols+1), exact integers
  cv::Mat mirror_integral_;
  cv::Mat grey_integral_, grey_sq_integral_;
  cv::Mat col_nonzero_;   // CV_32S (rows+1) x cols: per column, count of edge pixels above row
  // Reference: per-axis prefix tables, (max_half+1) x (rows+1) row-major (row width
  // reference_width_), summed over pairs j <= k and rows < r.
  std::vector<std::int64_t> pe_, pm_, pa_, pb_, paa_, pbb_, pab_;
  std::size_t reference_width_ = 0;
  cv::Mat grey_;  // the region of the current call (a header, read only)
  // Storage behind the headers above, reused across calls.
  std::vector<double> wq_store_, mq_store_, wint_store_, mint_store_, gint_store_, gsq_store_, colnz_store_;
  std::vector<AxisTables> bands_;                // one per band of axes
  std::vector<SymmetryCandidate> axis_best_;     // per axis index: its best candidate ...
  std::vector<std::uint8_t> axis_found_;         // ... when it has one
};

}  // namespace sg
