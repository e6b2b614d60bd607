#pragma once
// The detect/evaluate tools' configuration: a YAML document with any of the
// groups features, segmentation, localizer, tracker and the keys tracking and
// frame_period_s. The localization service's config (config/localization.yaml)
// is accepted as is: its service-only keys (transport, join_*) are skipped.
#include <cstddef>
#include <string>

#include "vision/detector.hpp"

namespace sg::cli {

// Frames read from an endless source (synthetic) when --frames is not given.
inline constexpr std::size_t kDefaultEndlessFrames = 10;

struct DetectorConfig {
  DetectorParams detector;
  double frame_period_s = 0.1;  // tracker time of frame i = i * frame_period_s (as the localization service)
};

// Defaults when `path` is empty; ParamError naming the file and key otherwise.
DetectorConfig loadDetectorConfig(const std::string& path);

}  // namespace sg::cli
