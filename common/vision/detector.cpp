#include "vision/detector.hpp"

#include <chrono>

namespace sg {

namespace {
double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

Detector::Detector(const DetectorParams& params)
    : params_(params),
      features_(params.features),
      segmenter_(params.segmenter),
      localizer_(params.localizer),
      tracker_(params.tracker) {
  params_.validate();
}

void Detector::reset() {
  segmenter_.reset();
  tracker_.reset();
}

void Detector::compute(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig, double time_s,
                       DetectionResult& out) {
  const auto start = std::chrono::steady_clock::now();
  segmentPair(features_, segmenter_, left, right, rig, out.segmentation);
  out.timing_ms = out.segmentation.timing_ms;
  out.timing_ms.erase("total");
  const auto t_loc = std::chrono::steady_clock::now();
  localizer_.compute(left, right, rig, out.segmentation, out.humans);
  out.timing_ms["localization"] = msSince(t_loc);
  if (params_.tracking) {
    const auto t_track = std::chrono::steady_clock::now();
    tracker_.update(time_s, out.humans);
    out.timing_ms["tracking"] = msSince(t_track);
  }
  out.timing_ms["total"] = msSince(start);
}

}  // namespace sg
