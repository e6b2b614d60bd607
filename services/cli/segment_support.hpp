#pragma once
// Pieces shared by `stereoguard segment` and `stereoguard bench`: the default
// rig used without a calibration file, and the YAML configuration of the
// Section III segmentation.
#include <string>

#include <nlohmann/json.hpp>

#include "camera/stereo_rig.hpp"
#include "config/params.hpp"
#include "vision/feature_image.hpp"
#include "vision/segmenter.hpp"

namespace sg::cli {

// `--config FILE` of segment/bench: {features: {...}, segmentation: {...}}.
struct SegmentConfig {
  FeatureParams features;
  SegmenterParams segmentation;
  template <class V>
  void visit(V& v) {
    v.group("features", features);
    v.group("segmentation", segmentation);
  }
};

// Reads FILE into `config` (ParamError naming file and key); empty path keeps the defaults.
void loadSegmentConfig(const std::string& path, SegmentConfig& config);

// KITTI-like rig for pairs without calibration: f = 721.5 px, B = 0.54 m,
// principal point at the image centre, mounting height 1.65 m, level.
StereoRig defaultRig(int width, int height);

// The per-frame JSON of DESIGN.md for one segmentation (frame, size, ground, obstacles, timing_ms).
nlohmann::json segmentationJson(const std::string& frame, const SegmentationResult& result, const StereoRig& rig);

}  // namespace sg::cli
