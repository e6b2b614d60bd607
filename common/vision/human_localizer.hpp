#pragma once
// Human shape localization inside the obstacle clusters of the Section III
// segmentation (seed paper, Sec. II applied as Sec. V proposes):
//
//  1. candidates: vertical symmetry of edges and grey levels, searched only in
//     each cluster's box (plus a margin), with human aspect ratios and sizes in
//     metres checked through the cluster's offset; the feet are put on the
//     ground line of the segmentation (GroundProfile), never on a flat-road model;
//  2. filters for evident errors: too few edges, uniform texture, boxes
//     straddling clusters at other offsets, duplicates (non-maximum suppression);
//  3. stereo refinement: the left box is matched in the right image around the
//     cluster offset (ZNCC, parabola, then Gauss-Newton for a sub-pixel offset),
//     Z = f B / d and its 1-sigma uncertainty;
//  4. ground contact: the box bottom is moved to the ground row of the refined
//     offset (paper, figure 1);
//  5. shape validation: OpenCV's HOG people detector on the refined box,
//     combined with the symmetry into one calibrated score in [0, 1].
//
// Not re-entrant: one localizer per thread; it keeps its scratch across frames
// (compute() runs its own parallel bands).
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/objdetect.hpp>

#include "camera/stereo_rig.hpp"
#include "config/params.hpp"
#include "vision/human_types.hpp"
#include "vision/segmentation_types.hpp"
#include "vision/symmetry.hpp"

namespace sg {

struct CandidateParams {
  double min_height_m = 0.9;      // smallest person (a child), metres
  double max_height_m = 2.1;      // tallest person, metres
  double min_width_m = 0.18;      // narrowest person box (side view), metres
  double max_width_m = 1.0;       // widest person box (walking, arms swinging), metres
  double min_aspect = 1.4;        // box height / width
  double max_aspect = 5.0;
  double region_margin = 0.25;    // search region = cluster box grown by this share of the person width range
  bool contact_at_column = true;  // the feet row of the search read from the ground line at the cluster's
                                  // centre column (a transversal slope), not at the line's reference column
  int min_height_px = 16;         // smaller boxes cannot be validated
  int max_per_cluster = 4;        // candidates kept per cluster after suppression
  double min_symmetry = 0.12;     // symmetry score below which a candidate is dropped ...
  bool validate_best_asymmetric = true;  // ... unless it is the best of a cluster that has none above
  double extent_min_edge_share = 0.15;  // a column belongs to the object when its edge weight >= this x box height
  int extent_gap_px = 2;          // edge-free columns tolerated when growing a box to the object's extent
  bool extent_unassigned_matches = true;  // unassigned features matching at the cluster's offset extend it
  int extent_grey_tolerance = 12;  // grey levels of that match (as the segmentation's)
  int extent_ground_margin = 60;   // ground-labelled pixels matching the offset better than the line by this
  int extent_ground_max_cost = 40; // ... within this 5-pixel SAD at the offset (grey levels)
  double extent_ground_clearance_px = 2.0;  // rows whose line offset is this near the cluster's cannot tell
  bool extent_blind_band = true;   // a box at the image's left edge may grow into the columns
                                   // the right camera cannot see at the cluster's offset
  bool widen_in_cluster = true;    // a scored box inside a person-wide cluster grows towards its sides

  template <class V>
  void visit(V& v) {
    v.field("min_height_m", min_height_m, 0.3, 3.0, "metres", "smallest person searched (a child)");
    v.field("max_height_m", max_height_m, 0.5, 3.5, "metres", "tallest person searched");
    v.field("min_width_m", min_width_m, 0.05, 2.0, "metres", "narrowest person box");
    v.field("max_width_m", max_width_m, 0.1, 3.0, "metres", "widest person box");
    v.field("min_aspect", min_aspect, 0.5, 10.0, "", "smallest box height / width");
    v.field("max_aspect", max_aspect, 0.5, 10.0, "", "largest box height / width");
    v.field("region_margin", region_margin, 0.0, 2.0, "", "search margin around a cluster, share of max width");
    v.field("min_height_px", min_height_px, 4, 1000, "pixels", "smallest box height kept");
    v.field("max_per_cluster", max_per_cluster, 1, 32, "", "candidates kept per cluster");
    v.field("min_symmetry", min_symmetry, 0.0, 1.0, "", "smallest symmetry score kept");
    v.field("validate_best_asymmetric", validate_best_asymmetric, 0, 1, "",
            "a cluster without a candidate above min_symmetry validates its most symmetric one (side views)");
    v.field("extent_min_edge_share", extent_min_edge_share, 0.0, 1.0, "",
            "column edge weight (share of the box height) that extends a box sideways");
    v.field("extent_gap_px", extent_gap_px, 0, 50, "pixels", "edge-free columns tolerated when extending a box");
    v.field("extent_unassigned_matches", extent_unassigned_matches, 0, 1, "",
            "features left unassigned that match the right image at the cluster's offset count as the cluster's "
            "when a box is extended sideways (a walking person's legs)");
    v.field("extent_grey_tolerance", extent_grey_tolerance, 0, 255, "grey levels",
            "grey difference of that match");
    v.field("extent_ground_margin", extent_ground_margin, 0, 1275, "grey levels",
            "features the removal gave the ground count as the cluster's when a box is extended sideways if their "
            "5-pixel SAD at the cluster's offset (+-1) beats that at the ground line's offset (+-1) by this "
            "(a walking person's legs against the ground behind them); 0 counts none");
    v.field("extent_ground_max_cost", extent_ground_max_cost, 0, 1275, "grey levels",
            "largest 5-pixel SAD at the cluster's offset of such a pixel");
    v.field("extent_ground_clearance_px", extent_ground_clearance_px, 0.0, 20.0, "pixels",
            "rows whose ground line offset is within this of the cluster's (near the feet) cannot tell the two "
            "apart: their ground pixels stay the ground's");
    v.field("contact_at_column", contact_at_column, 0, 1, "",
            "the search's feet row is where the ground line has the cluster's offset at the cluster's centre "
            "column (on a transversal slope the line's offset changes along the row)");
    v.field("extent_blind_band", extent_blind_band, 0, 1, "",
            "a box touching the left band that the right camera cannot see at the cluster's offset grows into it "
            "on its edges alone (one-sided); unassigned features there count as the cluster's");
    v.field("widen_in_cluster", widen_in_cluster, 0, 1, "",
            "after scoring, a box inside a cluster no wider than max_width_m grows on both sides by the smaller of "
            "its distances to the cluster's sides (a walking person's stride; the score and the centre stay)");
  }
};

struct FilterParams {
  double min_edge_density = 0.04;         // edge weight per pixel in the box
  double min_grey_stddev = 5.0;           // grey levels; below = uniform texture
  double max_foreign_share = 0.45;        // share of the box's obstacle pixels labelled with other clusters
  double same_object_depth_m = 0.3;       // clusters this close in distance to the box's own are not "other"
  // A box in the middle of a cluster much wider than a person (a car's side, a wall: a figure
  // there is the structure's texture or a person within the offset tolerance of it) needs a
  // score of interior_min_score. In the middle: the cluster is wider than interior_min_width_m
  // and reaches interior_margin_widths box widths beyond the box on both sides.
  double interior_min_width_m = 1.5;
  double interior_margin_widths = 1.0;
  double interior_min_score = 0.7;
  // A box at one end of such a structure (the cluster reaches interior_margin_widths box widths
  // beyond it on one side only: the end of a car or a wall, or a person beside it) needs end_min_score.
  double end_min_score = 0.41;
  double nms_iou = 0.25;                  // duplicates: intersection over union above this
  double nms_containment = 0.7;           // duplicates: share of the smaller box inside the larger one

  template <class V>
  void visit(V& v) {
    v.field("min_edge_density", min_edge_density, 0.0, 1.0, "", "edge weight per pixel below which a box is dropped");
    v.field("min_grey_stddev", min_grey_stddev, 0.0, 128.0, "grey levels", "uniform texture below this");
    v.field("max_foreign_share", max_foreign_share, 0.0, 1.0, "",
            "share of obstacle pixels of other clusters above which a box straddles two clusters");
    v.field("same_object_depth_m", same_object_depth_m, 0.0, 100.0, "metres",
            "clusters within this distance of the box's own cluster count as the same object (a rider and the bicycle)");
    v.field("interior_min_width_m", interior_min_width_m, 0.0, 100.0, "metres",
            "a box in the middle of a cluster wider than this (a structure; 0: no such test) ...");
    v.field("interior_margin_widths", interior_margin_widths, 0.0, 100.0, "box widths",
            "... which reaches this many box widths beyond it on both sides ...");
    v.field("interior_min_score", interior_min_score, 0.0, 1.0, "", "... is kept only when it scores at least this");
    v.field("end_min_score", end_min_score, 0.0, 1.0, "",
            "a box at one end of such a cluster (reaching that far beyond it on one side only) is kept only "
            "when it scores at least this (0: no such test)");
    v.field("nms_iou", nms_iou, 0.0, 1.0, "", "non-maximum suppression overlap (IoU)");
    v.field("nms_containment", nms_containment, 0.0, 1.0, "", "non-maximum suppression containment");
  }
};

struct RefineParams {
  int search_radius_px = 3;         // offsets searched around the cluster offset
  int iterations = 4;               // Gauss-Newton sub-pixel iterations
  double min_zncc = 0.5;            // below (at the sub-pixel offset): not trusted, the cluster offset is kept
  double min_integer_zncc = 0.1;    // below (best integer offset): no correlation peak, no refinement
  double offset_sigma_px = 0.15;    // 1-sigma precision of a trusted refined offset (pixels)
  double fallback_sigma_px = 0.5;   // 1-sigma precision of the cluster offset (pixels)
  int min_pixels = 24;              // fewest edge pixels needed to match

  template <class V>
  void visit(V& v) {
    v.field("search_radius_px", search_radius_px, 0, 16, "pixels", "offsets searched around the cluster offset");
    v.field("iterations", iterations, 0, 20, "", "Gauss-Newton sub-pixel iterations");
    v.field("min_zncc", min_zncc, -1.0, 1.0, "", "correlation at the sub-pixel offset below which it is not used");
    v.field("min_integer_zncc", min_integer_zncc, -1.0, 1.0, "", "correlation at the best integer offset needed to refine");
    v.field("offset_sigma_px", offset_sigma_px, 0.01, 5.0, "pixels", "precision of a refined offset (1 sigma)");
    v.field("fallback_sigma_px", fallback_sigma_px, 0.01, 5.0, "pixels", "precision of the cluster offset (1 sigma)");
    v.field("min_pixels", min_pixels, 4, 100000, "pixels", "fewest edge pixels to match the box");
  }
};

struct ShapeParams {
  bool enabled = true;                 // HOG validation on/off (off: shape_score = 0)
  int detector = 0;                    // 0: OpenCV default people detector (64x128), 1: Daimler (48x96)
  double person_height_fraction = 0.75;// share of the detector window height a person fills
  int shift_cells = 1;                 // window shifts (in 8-pixel cells) tried around the box, each way
  // When the margin at person_height_fraction lies in [rescale_margin_min, rescale_margin_max]
  // (neither clearly a person nor clearly not), the window is also tried with the person
  // filling these shares of it (0: not tried), and the largest margin counts.
  double smaller_person_fraction = 0.65;
  double larger_person_fraction = 0.85;
  double rescale_margin_min = -2.0;
  double rescale_margin_max = 0.0;
  // Clutter flattened before the window is read: image pixels the segmentation labelled
  // ground or background are replaced by their flatten_px x flatten_px box mean (0: off).
  int flatten_px = 5;
  // The detector reads windows every 8-pixel cell: a person lying between two positions
  // scores lower than one on a position. The window is also read at the half-cell
  // positions between them (three more detector calls), the largest margin counting,
  // unless the margin at the whole cells is below half_cell_margin_min (clearly no person).
  bool half_cell_windows = true;
  double half_cell_margin_min = -2.0;

  template <class V>
  void visit(V& v) {
    v.field("enabled", enabled, 0, 1, "", "run the HOG people detector on each refined box");
    v.field("detector", detector, 0, 1, "", "0 = default 64x128 people detector, 1 = Daimler 48x96");
    v.field("person_height_fraction", person_height_fraction, 0.3, 1.0, "",
            "share of the detector window a person's height fills (training margin)");
    v.field("shift_cells", shift_cells, 0, 4, "cells", "window shifts tried around the box in each direction");
    v.field("smaller_person_fraction", smaller_person_fraction, 0.0, 1.0, "",
            "also tried: the person filling this share of the window (0: not tried)");
    v.field("larger_person_fraction", larger_person_fraction, 0.0, 1.0, "",
            "also tried: the person filling this share of the window (0: not tried)");
    v.field("rescale_margin_min", rescale_margin_min, -100.0, 100.0, "",
            "the other shares are tried when the first margin is at least this ...");
    v.field("rescale_margin_max", rescale_margin_max, -100.0, 100.0, "", "... and at most this");
    v.field("half_cell_windows", half_cell_windows, 0, 1, "",
            "also read the detector window at the half-cell positions between its 8-pixel steps");
    v.field("half_cell_margin_min", half_cell_margin_min, -100.0, 100.0, "",
            "the half-cell positions are read when the margin at the whole cells is at least this");
    v.field("flatten_px", flatten_px, 0, 31, "pixels",
            "ground and background feature pixels inside the window are replaced by their box mean of this size "
            "before HOG reads it (0: the image as it is)");
  }
};

// score = 1 / (1 + exp(-(bias + w_symmetry * symmetry + w_shape * shape_score))).
// Defaults fitted by `stereoguard evaluate --fit-score` on synthetic seeds 0-79
// (config/localization.yaml says how); the tests score seeds from 1000 on.
struct ScoreParams {
  double bias = 1.074;
  double w_symmetry = 0.655;
  double w_shape = 2.081;
  double min_score = 0.295;  // detections below are dropped

  template <class V>
  void visit(V& v) {
    v.field("bias", bias, -100.0, 100.0, "", "logistic score: constant term");
    v.field("w_symmetry", w_symmetry, -100.0, 100.0, "", "logistic score: weight of the symmetry score");
    v.field("w_shape", w_shape, -100.0, 100.0, "", "logistic score: weight of the HOG margin");
    v.field("min_score", min_score, 0.0, 1.0, "", "detections scoring below are dropped");
  }
};

struct LocalizerParams {
  bool parallel = true;  // symmetry axes and candidate boxes in parallel bands (TBB); identical results
  SymmetryParams symmetry;
  CandidateParams candidates;
  FilterParams filters;
  RefineParams refine;
  ShapeParams shape;
  ScoreParams score;

  template <class V>
  void visit(V& v) {
    v.field("parallel", parallel, 0, 1, "", "scan symmetry axes and validate candidate boxes in parallel bands");
    v.group("symmetry", symmetry);
    v.group("candidates", candidates);
    v.group("filters", filters);
    v.group("refine", refine);
    v.group("shape", shape);
    v.group("score", score);
  }
  // Ranges plus the cross-field rules (min < max).
  void validate() const;
};

// Row (fractional) where the ground offset at `column` equals `offset_px` (on a transversal
// slope the ground's offset changes along the row; NaN: at the reference column), the crossing
// nearest `near_row`; from the mounting prior when the profile has no ground; NaN when neither
// gives one inside the image.
double groundRowForOffset(const GroundProfile& ground, const StereoRig& rig, double offset_px, double near_row,
                          double column = std::numeric_limits<double>::quiet_NaN());

// Intersection over union of two boxes; 0 when either is empty.
double boxIoU(const cv::Rect2f& a, const cv::Rect2f& b);

// Shape validation's clutter flattening: every pixel of `patch` (CV_8UC1) under a
// ground or background label gets the k x k box mean of the patch (edges replicated,
// rounded to nearest); other pixels keep their value. `labels` (CV_8UC1) covers the
// patch from pixel `at` on; `scratch` only grows.
void flattenClutter(cv::Mat& patch, const cv::Mat& labels, cv::Point at, int k, std::vector<double>& scratch);

class HumanLocalizer {
 public:
  explicit HumanLocalizer(const LocalizerParams& params);

  // People in the left image, strongest first. `left`/`right` CV_8UC1 rectified.
  void compute(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig, const SegmentationResult& segmentation,
               std::vector<HumanDetection>& out);

  // Same result from the plain serial implementation (fresh scratch per region and
  // box, cv::Sobel/cv::compare, every symmetry table of every axis), kept as the
  // reference of compute(); bit-identical.
  void computeReference(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                        const SegmentationResult& segmentation, std::vector<HumanDetection>& out);

  // Step 3 on its own: refined offset of `box` (left image) around `offset_px`;
  // `mask` (CV_8U, box size, may be empty) selects the pixels matched.
  // Returns false when the match is not trusted (offset_px then unchanged).
  bool refineOffset(const cv::Mat& left, const cv::Mat& right, const cv::Rect& box, const cv::Mat& mask,
                    float& offset_px, float& zncc);

  // Step 5 on its own: HOG margin of the person in `box` (larger = more person-like).
  // `labels` (CV_8UC1 SegmentLabel per pixel, may be empty) marks the clutter that
  // shape.flatten_px flattens.
  float shapeScore(const cv::Mat& left, const cv::Rect2f& box, const cv::Mat& labels = cv::Mat());

  // Logistic combination of the two cues.
  double combinedScore(double symmetry, double shape_score) const;

  const LocalizerParams& params() const { return params_; }
  // cv::HOGDescriptor::detect calls since construction (one or more per validated box).
  long hogDetectCalls() const;

 private:
  // Scratch of the steps applied to one candidate box (3-5); one per band of
  // candidates, so that bands run in parallel.
  struct BoxWorkspace {
    cv::HOGDescriptor hog;
    long hog_calls = 0;  // detect() calls made with this workspace
    cv::Mat hog_canvas;
    std::array<cv::Mat, 3> hog_shifted;  // the canvas without its first half cell: columns, rows, both
    std::vector<cv::Point> hog_found;
    std::vector<double> hog_weights;
    std::vector<double> samples_l;
    std::vector<cv::Point> samples_p;
    std::vector<double> scores;
    // Storage behind the per-box headers; it only grows.
    std::vector<double> labels_mask_store, box_weights_store, box_mask_store, patch_store,
        flat_store;
  };

  // Bands to use now: 1 unless params.parallel, else TBB's parallelism limit (at most kMaxBands).
  int bands() const;
  BoxWorkspace& workspace(int band);
  bool refineOffset(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& right, const cv::Rect& box,
                    const cv::Mat& mask, float& offset_px, float& zncc) const;
  // HOG margin with the person filling `frac` of the window height.
  float shapeScoreAt(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& labels, const cv::Rect2f& box,
                     double frac) const;
  float shapeScore(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& labels, const cv::Rect2f& box) const;
  // The score a box must reach where it lies in its cluster: interior_min_score in the middle of
  // a structure, end_min_score at one of its ends, 0 elsewhere (FilterParams).
  double structureMinScore(const StereoRig& rig, const SegmentationResult& segmentation, const HumanDetection& h) const;
  // A kept box inside a cluster no wider than the widest person (candidates.max_width_m at the
  // cluster's offset) grows on both sides by the smaller of its distances to the cluster's
  // sides (candidates.widen_in_cluster).
  void widenInCluster(const StereoRig& rig, const SegmentationResult& segmentation, HumanDetection& h) const;
  // Steps 3-5 on candidate h (refined offset, ground contact, distance, shape
  // score, the box widened in its cluster); false when it is dropped.
  bool validateCandidate(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                         const SegmentationResult& segmentation, HumanDetection& h, bool reference) const;
  void computeImpl(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                   const SegmentationResult& segmentation, std::vector<HumanDetection>& out, bool reference);
  void candidatesInCluster(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                           const SegmentationResult& segmentation, const ObstacleCluster& cluster,
                           std::vector<HumanDetection>& out, bool reference);
  // Per label, 1 where the cluster stands at another distance than `own_cluster` (a box
  // over it straddles two objects); computed once per cluster.
  std::array<std::uint8_t, 256> foreignLabels(const SegmentationResult& segmentation, const StereoRig& rig,
                                              const ObstacleCluster& own_cluster) const;
  // Share of the box's obstacle pixels whose label `foreign` marks.
  double foreignShare(const SegmentationResult& segmentation, const cv::Rect& box,
                      const std::array<std::uint8_t, 256>& foreign) const;

  LocalizerParams params_;
  SymmetryScanner scanner_;
  cv::HOGDescriptor hog_;  // the configured people detector, copied into each workspace
  std::vector<SymmetryCandidate> sym_scratch_;
  std::vector<HumanDetection> candidates_;
  std::vector<HumanDetection> extended_;
  std::vector<std::uint8_t> kept_;  // per candidate: survived steps 3-5
  cv::Mat region_mask_, region_weights_;
  std::vector<HumanDetection> local_;
  std::vector<BoxWorkspace> workspaces_;  // workspace 0 also serves the reference and the public steps
  // Storage behind the per-region headers of the fast path; it only grows.
  std::vector<double> region_mask_store_, region_weights_store_;
  std::vector<double> column_sums_;  // per region column: edge weight from each row down to the candidates' bottom
  std::vector<std::uint8_t> column_ready_;
};

// Greedy non-maximum suppression by score (keeps the higher score of two
// boxes overlapping more than `iou` or one mostly inside the other).
void suppressDuplicates(std::vector<HumanDetection>& detections, double iou, double containment);
// Same result without a temporary buffer (stable insertion sort, kept boxes compacted in place).
void suppressDuplicatesInPlace(std::vector<HumanDetection>& detections, double iou, double containment);

}  // namespace sg
