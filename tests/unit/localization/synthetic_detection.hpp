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

// exempt_objects: the removal never takes the objects' features (Segmenter::setRemovalExemptions).
inline SeedDetection detectSyntheticSeed(Detector& detector, std::uint64_t seed, bool exempt_objects = false) {
  SeedDetection out{renderSyntheticScene(randomSceneParams(seed), seed), {}};
  detector.reset();
  detector.setRemovalExemptions(exempt_objects ? &out.pair.truth->object_id : nullptr);
  detector.compute(out.pair.left, out.pair.right, out.pair.rig, 0.0, out.result);
  detector.setRemovalExemptions(nullptr);
  return out;
}

}  // namespace sg::test
