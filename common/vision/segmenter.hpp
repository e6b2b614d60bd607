#pragma once
// The Section III stereo segmentation (seed paper) as one object: correlation
// image -> ground/background polyline -> removal -> obstacles one by one.
// Keeps the previous frame's ground line for the weak-texture fallback and
// reuses its images across frames. Not re-entrant: one Segmenter per thread.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"
#include "config/params.hpp"
#include "vision/correlation.hpp"
#include "vision/feature_image.hpp"
#include "vision/feature_removal.hpp"
#include "vision/ground_profile.hpp"
#include "vision/obstacle_extraction.hpp"
#include "vision/segmentation_types.hpp"
#include "vision/standing_people.hpp"

namespace sg {

struct SegmenterParams {
  CorrelationParams correlation;
  GroundParams ground;
  RemovalParams removal;
  ObstacleParams obstacles;
  StandingParams standing;
  bool parallel = true;  // TBB row bands; false runs the serial references (identical results)

  template <class V>
  void visit(V& v) {
    v.group("correlation", correlation);
    v.group("ground", ground);
    v.group("removal", removal);
    v.group("obstacles", obstacles);
    v.group("standing", standing);
    v.field("parallel", parallel, 0, 1, "", "run the row-band parallel paths");
  }
  void validate() const {
    validateParams(*this, "segmentation");
    ground.validate();
    standing.validate();
  }
};

class Segmenter {
 public:
  explicit Segmenter(const SegmenterParams& params = {});

  // left_features/right_features: CV_8UC1 feature images of the same size (FeatureExtractor).
  // Fills every field of `out` except timing_ms["features"]; out.timing_ms["total"]
  // covers this call. `rig` supplies the mounting prior for the fallback.
  void compute(const cv::Mat& left_features, const cv::Mat& right_features, const StereoRig& rig,
               SegmentationResult& out);

  // Forget the previous frame's ground line (a new sequence starts).
  void reset();

  const SegmenterParams& params() const { return params_; }

  // Diagnostics (the probes' ceiling studies, never the services): with a CV_16UC1 map of
  // the same size as the images, the feature pixels whose value there is >= 2 (the
  // synthetic scenes' object ids, SceneTruth::object_id) are never removed as ground or
  // background, as a removal without chance matches would do. The map must outlive the
  // calls; nullptr (the default) turns it off.
  void setRemovalExemptions(const cv::Mat* object_ids) { removal_exemptions_ = object_ids; }

 private:
  friend void segmentPair(FeatureExtractor&, Segmenter&, const cv::Mat&, const cv::Mat&, const StereoRig&,
                          SegmentationResult&);
  // compute() without touching timing_ms["features"] (segmentPair sets it: no map node
  // is erased and re-created per frame).
  void run(const cv::Mat& left_features, const cv::Mat& right_features, const StereoRig& rig,
           SegmentationResult& out);
  // Gives the exempted feature pixels the removal took back to the obstacle stage.
  void restoreExempted(const cv::Mat& left_features, cv::Mat& labels);

  SegmenterParams params_;
  Correlator correlator_;
  GroundEstimator ground_;
  FeatureRemover remover_;
  ObstacleExtractor obstacles_;
  StandingPeopleFinder standing_;
  GroundProfile previous_ground_;     // last measured (Hough) profile
  GroundProfile measured_ground_;     // this frame's measured profile, before the roll's corrections
  int previous_age_frames_ = 0;       // frames since it was measured
  bool have_previous_ = false;
  cv::Mat remaining_;                 // left features still unexplained
  cv::Mat matches_;                   // CV_32S companion of the correlation
  cv::Mat obstacle_score_;            // correlation while obstacles are taken out
  std::vector<std::uint8_t> changed_rows_;
  const cv::Mat* removal_exemptions_ = nullptr;
};

// Feature images of both images, then the segmentation; adds timing_ms["features"]
// and makes timing_ms["total"] cover both. left/right: mono8 of the same size.
void segmentPair(FeatureExtractor& features, Segmenter& segmenter, const cv::Mat& left, const cv::Mat& right,
                 const StereoRig& rig, SegmentationResult& out);

}  // namespace sg
