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
  // The segmentation's stages, entry by entry: the keys are the same every frame,
  // so in steady state no map node is freed or allocated.
  for (auto it = out.timing_ms.begin(); it != out.timing_ms.end();) {
    const bool ours = it->first == "localization" || it->first == "tracking" || it->first == "total";
    if (!ours && out.segmentation.timing_ms.count(it->first) == 0) it = out.timing_ms.erase(it);
    else ++it;
  }
  for (const auto& [stage, ms] : out.segmentation.timing_ms) {
    if (stage != "total") out.timing_ms[stage] = ms;
  }
  if (!params_.tracking) out.timing_ms.erase("tracking");
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
