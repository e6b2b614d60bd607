#include "io/synthetic_source.hpp"

#include <cctype>

#include "config/errors.hpp"
#include "io/synthetic_scene.hpp"

namespace sg {

std::uint64_t parseSyntheticSeed(const std::string& spec) {
  const std::string prefix = "synthetic";
  if (spec.rfind(prefix, 0) != 0) throw InputError("frame source '" + spec + "': not a synthetic source");
  if (spec.size() == prefix.size()) return 1;
  const std::string digits = spec.substr(prefix.size() + 1);
  if (spec[prefix.size()] != ':' || digits.empty() || digits.size() > 18) {
    throw InputError("frame source '" + spec + "': expected synthetic or synthetic:SEED (SEED a whole number)");
  }
  for (char c : digits) {
    if (!std::isdigit(static_cast<unsigned char>(c))) {
      throw InputError("frame source '" + spec + "': SEED '" + digits + "' is not a whole number");
    }
  }
  return std::stoull(digits);
}

SyntheticSource::SyntheticSource(std::uint64_t seed, const std::string& calib_path) : seed_(seed) {
  if (!calib_path.empty()) calib_ = loadCalibration(calib_path);
}

bool SyntheticSource::next(StereoPair& pair) {
  const std::uint64_t seed = seed_ + position_;
  const auto index = static_cast<std::int64_t>(position_);
  ++position_;
  SyntheticSceneParams params = randomSceneParams(seed);
  if (calib_) {
    const StereoRig& rig = calib_->rig;
    params.focal_px = rig.focal_px;
    params.baseline_m = rig.baseline_m;
    if (!calib_->image_size.empty()) {
      params.width = calib_->image_size.width;
      params.height = calib_->image_size.height;
    }
    if (rig.mounting) {
      params.camera_height_m = rig.mounting->height_m;
      params.pitch_rad = rig.mounting->pitch_rad;
    }
  }
  pair = renderSyntheticScene(params, seed);
  pair.index = index;
  pair.scene_start = true;  // every seed is a scene of its own
  return true;
}

std::string SyntheticSource::describe() const {
  return "synthetic:" + std::to_string(seed_) + (calib_ ? " (rig from " + calib_->source + ")" : "");
}

}  // namespace sg
