#pragma once
// Loads a stereo pair from two image files and its calibration, rectifying when
// the calibration says so. Shared by the pairs: and kitti: sources. Rectifiers
// (and their remap tables) are built once per calibration file and image size.
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "camera/rectifier.hpp"
#include "io/stereo_pair.hpp"

namespace sg {

// The mounting prior of a pairs: or kitti: folder: DIR/camera_height_m (one
// number, metres; pitch 0) when that file exists.
std::optional<Mounting> folderMounting(const std::string& dir);

class StereoFileLoader {
 public:
  // `fallback_mounting` is used when the calibration carries no mounting prior.
  explicit StereoFileLoader(std::optional<Mounting> fallback_mounting = std::nullopt)
      : fallback_mounting_(fallback_mounting) {}

  // Reads both images as mono8, checks their sizes agree, rectifies, and fills
  // pair.left, pair.right and pair.rig. An empty `calib_path` means the nominal
  // rig (nominalCalibration). Throws InputError naming the file(s).
  void load(const std::string& left_path, const std::string& right_path, const std::string& calib_path,
            StereoPair& pair);

  // The rectifier for a calibration at an image size (loaded once, then cached;
  // the reference is valid until the next call).
  const Rectifier& rectifierFor(const std::string& calib_path, cv::Size image_size);

 private:
  static constexpr std::size_t kMaxCachedRectifiers = 16;
  std::optional<Mounting> fallback_mounting_;
  std::map<std::string, std::unique_ptr<Rectifier>> rectifiers_;
};

}  // namespace sg
