#pragma once
// One generated scene (randomSceneParams(seed)) through the detector, a new
// sequence each time: independent single frames.
#include <cstdint>

#include "io/synthetic_scene.hpp"
#include "vision/detector.hpp"

namespace sg::test {

struct SeedDetection {
  StereoPair pair;
  DetectionResult result;
};

inline SeedDetection detectSyntheticSeed(Detector& detector, std::uint64_t seed) {
  SeedDetection out{renderSyntheticScene(randomSceneParams(seed), seed), {}};
  detector.reset();
  detector.compute(out.pair.left, out.pair.right, out.pair.rig, 0.0, out.result);
  return out;
}

}  // namespace sg::test
