#pragma once
// synthetic[:SEED] — an endless stream of synthetic scenes with ground truth:
// frame i is renderSyntheticScene(randomSceneParams(SEED + i), SEED + i).
// size() is unknown (nullopt); callers bound it with --frames.
#include <cstdint>
#include <optional>
#include <string>

#include "camera/calibration.hpp"
#include "io/frame_source.hpp"

namespace sg {

class SyntheticSource final : public FrameSource {
 public:
  // `calib_path`, when not empty, replaces the generator's rig: focal length,
  // baseline, image size (when the file knows it) and mounting prior.
  explicit SyntheticSource(std::uint64_t seed, const std::string& calib_path = "");

  bool next(StereoPair& pair) override;
  std::optional<std::size_t> size() const override { return std::nullopt; }
  std::string describe() const override;

 private:
  std::uint64_t seed_;
  std::uint64_t position_ = 0;
  std::optional<StereoCalibration> calib_;
};

// Parses the SEED of "synthetic[:SEED]" (default 1). Throws InputError on anything else.
std::uint64_t parseSyntheticSeed(const std::string& spec);

}  // namespace sg
