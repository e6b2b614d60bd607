#pragma once
// Pedestrian detection scored with the KITTI object protocol (moderate
// difficulty), plus the distance error the benchmark itself does not score.
//
// Per frame, labels are sorted into
//  - counted:  Pedestrian with box height >= min_height_px, occlusion <= max_occlusion,
//              truncation <= max_truncation;
//  - ignored:  other Pedestrians, Person_sitting and Cyclist (a detection on them
//              is neither a true nor a false positive);
//  - DontCare: a detection lying mostly inside one is ignored;
//  - anything else (cars, misc obstacles): a detection there is a false positive.
// Detections lower than min_height_px are ignored (as KITTI does). Detections are
// matched greedily from the highest score, at IoU >= min_iou, first to counted
// labels, then to ignored ones; a label's box is taken as pixel edges for that
// (labelEdges below).
//
// Average precision: KITTI's 40 recall points (1/40 .. 1), precision
// interpolated as the best precision at that recall or above.
// Distance error: |Z - Z_label| / Z_label of every true positive with a
// distance, Z_label = label location z, binned by Z_label.
#include <array>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/params.hpp"
#include "io/stereo_pair.hpp"

namespace sg {

struct EvaluationParams {
  double min_height_px = 25.0;   // KITTI moderate
  int max_occlusion = 1;         // KITTI moderate: partly occluded at most
  double max_truncation = 0.3;   // KITTI moderate
  double min_iou = 0.5;          // KITTI pedestrian overlap
  double dontcare_overlap = 0.5; // share of a detection inside a DontCare box that makes it ignored

  template <class V>
  void visit(V& v) {
    v.field("min_height_px", min_height_px, 0.0, 10000.0, "pixels", "smallest counted box height (moderate: 25)");
    v.field("max_occlusion", max_occlusion, 0, 3, "", "largest counted occlusion level (moderate: 1)");
    v.field("max_truncation", max_truncation, 0.0, 1.0, "", "largest counted truncation (moderate: 0.3)");
    v.field("min_iou", min_iou, 0.01, 1.0, "", "intersection over union for a match (pedestrians: 0.5)");
    v.field("dontcare_overlap", dontcare_overlap, 0.0, 1.0, "", "share inside a DontCare box that ignores a detection");
  }
  void validate() const { validateParams(*this, "evaluation"); }
};

// A KITTI label's box names the first and the last pixel the object covers (one cut by
// the right edge of a 1242-pixel-wide image ends at 1241, by the bottom of a 375-row one
// at 374). A detection's box gives pixel edges instead: right = left + width, bottom =
// top + height. The label as pixel edges (right and bottom one further), which is how it
// is compared with detections: as given, a detection covering exactly the object's
// pixels would be one pixel wider and taller than its label (IoU 0.86 for a person 9 x 33
// pixels in size).
std::array<double, 4> labelEdges(const std::array<double, 4>& label_box);
// The same as a rectangle (x, y, width, height), as HumanDetection boxes are.
cv::Rect2f labelEdgesRect(const std::array<double, 4>& label_box);

// A detection as scored: box of pixel edges [left, top, right, bottom].
struct ScoredBox {
  std::array<double, 4> box{};
  double score = 0.0;
  double distance_m = std::numeric_limits<double>::quiet_NaN();  // NaN: the detector gives none
};

enum class Outcome { kTruePositive, kFalsePositive, kIgnored };
const char* toString(Outcome outcome);

// One detection after matching.
struct ScoredDetection {
  std::string frame;
  std::size_t index = 0;        // in the frame's detection list
  ScoredBox detection;
  Outcome outcome = Outcome::kFalsePositive;
  int label = -1;               // matched label index in the frame's label list, or -1
  double iou = 0.0;
  double label_distance_m = std::numeric_limits<double>::quiet_NaN();
  double distance_rel_error = std::numeric_limits<double>::quiet_NaN();  // |Z - Zl| / Zl for true positives
  double bottom_error_px = std::numeric_limits<double>::quiet_NaN();     // detection bottom - label bottom (edges)
};

// Per-frame outcome, also for the report's gallery.
struct FrameEvaluation {
  std::string frame;
  std::vector<ScoredDetection> detections;
  std::vector<int> counted_labels;     // label indices counted as ground truth
  std::vector<double> counted_distance_m;  // their label distance z (same order; NaN when unknown)
  std::vector<int> missed_labels;      // counted labels no detection matched
};

struct PrPoint {
  double threshold = 0.0;   // lowest score kept
  double precision = 1.0;
  double recall = 0.0;
  double fp_per_frame = 0.0;
};

struct DistanceBin {
  double lo_m = 0.0, hi_m = 0.0;   // label distance range [lo, hi)
  int labels = 0;                  // counted labels in the range
  int found = 0;                   // of them, matched by a detection (at the lowest threshold)
  int count = 0;                   // true positives with a distance (the error statistics below)
  double median = std::numeric_limits<double>::quiet_NaN();  // of |Z - Zl| / Zl
  double p90 = std::numeric_limits<double>::quiet_NaN();
};

struct EvaluationSummary {
  int frames = 0;
  int ground_truth = 0;          // counted labels
  int detections = 0;            // detections not ignored
  int true_positives = 0;        // at the lowest threshold
  int false_positives = 0;
  double recall = 0.0;           // at the lowest threshold
  double precision = 0.0;
  double fp_per_frame = 0.0;
  double average_precision = 0.0;  // KITTI 40-point
  std::vector<PrPoint> curve;      // one point per distinct score, highest first
  bool has_distance = false;       // false when no true positive carries a distance
  DistanceBin distance_all;
  std::vector<DistanceBin> distance_bins;  // 0-10, 10-20, 20-30, 30+ m; recall per range too
};

class Evaluator {
 public:
  explicit Evaluator(const EvaluationParams& params = {});

  // Scores one frame; the result is kept for the summary and returned.
  const FrameEvaluation& addFrame(const std::string& frame, const std::vector<ObjectLabel>& labels,
                                  const std::vector<ScoredBox>& detections);

  EvaluationSummary summary() const;
  // Highest recall reachable with at most `max_fp_per_frame` false positives per frame.
  double recallAtFpPerFrame(double max_fp_per_frame) const;

  const std::vector<FrameEvaluation>& frames() const { return frames_; }
  bool isCounted(const ObjectLabel& label) const;

 private:
  EvaluationParams params_;
  std::vector<FrameEvaluation> frames_;
};

// Median and 90th percentile (nearest rank on the sorted values); NaN when empty.
double percentile(std::vector<double> values, double q);

// Logistic model p = 1 / (1 + exp(-(w0 + w1 x1 + w2 x2))) fitted by Newton's
// method (with a small ridge term) to samples (x1, x2, positive).
struct LogisticSample {
  double x1 = 0.0;
  double x2 = 0.0;
  bool positive = false;
};
struct LogisticFit {
  std::array<double, 3> weights{};  // w0 (bias), w1, w2
  int samples = 0;
  int positives = 0;
  double log_loss = 0.0;            // mean negative log-likelihood at the fit
};
LogisticFit fitLogistic(const std::vector<LogisticSample>& samples, double ridge = 1e-3);

// The summary as JSON (metrics.json).
nlohmann::json toJson(const EvaluationSummary& summary);

}  // namespace sg
