#pragma once
// The whole per-frame method in one object: feature images and the Section III
// segmentation, then human localization (Sec. II + V) and tracking. A thin
// composition of FeatureExtractor, Segmenter, HumanLocalizer and HumanTracker:
// the DDS services run the same four objects in separate processes and get the
// same results.
//
// Not re-entrant: one Detector per camera/thread.
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"
#include "config/params.hpp"
#include "vision/feature_image.hpp"
#include "vision/human_localizer.hpp"
#include "vision/human_tracker.hpp"
#include "vision/human_types.hpp"
#include "vision/segmentation_types.hpp"
#include "vision/segmenter.hpp"

namespace sg {

struct DetectorParams {
  FeatureParams features;
  SegmenterParams segmenter;
  LocalizerParams localizer;
  TrackerParams tracker;
  bool tracking = true;  // run the tracker (off: every detection stays unconfirmed, track_id -1)

  template <class V>
  void visit(V& v) {
    v.group("features", features);
    v.group("segmentation", segmenter);
    v.group("localizer", localizer);
    v.group("tracker", tracker);
    v.field("tracking", tracking, 0, 1, "", "track people across frames");
  }
  void validate() const {
    features.validate();
    segmenter.validate();
    localizer.validate();
    tracker.validate();
  }
};

struct DetectionResult {
  SegmentationResult segmentation;
  std::vector<HumanDetection> humans;        // strongest first
  std::map<std::string, double> timing_ms;   // segmentation stages + "localization", "tracking", "total"
};

class Detector {
 public:
  explicit Detector(const DetectorParams& params);

  // left/right: rectified CV_8UC1 of the same size; time_s: frame time (seconds,
  // non-decreasing within a sequence) for the tracker.
  void compute(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig, double time_s, DetectionResult& out);

  // A new sequence starts: forget tracks and the previous ground line.
  void reset();

  const DetectorParams& params() const { return params_; }
  // People-detector (HOG) evaluations since construction: about one per shape-validated box.
  long hogDetectCalls() const { return localizer_.hogDetectCalls(); }
  // Diagnostics: Segmenter::setRemovalExemptions.
  void setRemovalExemptions(const cv::Mat* object_ids) { segmenter_.setRemovalExemptions(object_ids); }

 private:
  DetectorParams params_;
  FeatureExtractor features_;
  Segmenter segmenter_;
  HumanLocalizer localizer_;
  HumanTracker tracker_;
};

}  // namespace sg
