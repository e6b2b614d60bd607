#pragma once
// Detections as the evaluation scores them: KITTI boxes [left, top, right,
// bottom], the calibrated score, and the distance where the detector has one.
#include <cmath>
#include <limits>
#include <vector>

#include "io/evaluation.hpp"
#include "vision/human_types.hpp"

namespace sg {

inline std::vector<ScoredBox> toScoredBoxes(const std::vector<HumanDetection>& humans) {
  std::vector<ScoredBox> out;
  out.reserve(humans.size());
  for (const HumanDetection& h : humans) {
    ScoredBox b;
    b.box = {h.box.x, h.box.y, h.box.x + h.box.width, h.box.y + h.box.height};
    b.score = h.score;
    b.distance_m = std::isfinite(h.distance_m) && h.distance_m > 0.0f ? static_cast<double>(h.distance_m)
                                                                      : std::numeric_limits<double>::quiet_NaN();
    out.push_back(b);
  }
  return out;
}

}  // namespace sg
