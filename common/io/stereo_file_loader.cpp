#include "io/stereo_file_loader.hpp"

#include <filesystem>

#include "camera/calibration.hpp"
#include "config/errors.hpp"
#include "io/image_file.hpp"

namespace sg {

std::optional<Mounting> folderMounting(const std::string& dir) {
  const std::filesystem::path file = std::filesystem::path(dir) / "camera_height_m";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return std::nullopt;
  return Mounting{readNumberFile(file.string()), 0.0};
}

const Rectifier& StereoFileLoader::rectifierFor(const std::string& calib_path, cv::Size image_size) {
  const std::string key = calib_path + "\n" + sizeText(image_size);
  const auto it = rectifiers_.find(key);
  if (it != rectifiers_.end()) return *it->second;
  // KITTI layouts have one calibration file per frame: keep the cache small.
  if (rectifiers_.size() >= kMaxCachedRectifiers) rectifiers_.clear();
  StereoCalibration calib =
      calib_path.empty() ? nominalCalibration(image_size) : loadCalibration(calib_path, image_size);
  // A mounting file beats the nominal rig's guess, never a calibration's own prior.
  if (fallback_mounting_ && (calib_path.empty() || !calib.rig.mounting)) calib.rig.mounting = fallback_mounting_;
  setImageSize(calib, image_size, calib_path.empty() ? std::string("nominal rig") : calib_path);
  auto rectifier = std::make_unique<Rectifier>(std::move(calib));
  return *rectifiers_.emplace(key, std::move(rectifier)).first->second;
}

void StereoFileLoader::load(const std::string& left_path, const std::string& right_path,
                            const std::string& calib_path, StereoPair& pair) {
  const cv::Mat left = readMono8(left_path);
  const cv::Mat right = readMono8(right_path);
  if (left.size() != right.size()) {
    throw InputError(left_path + " (" + sizeText(left.size()) + ") and " + right_path + " (" +
                     sizeText(right.size()) + "): left and right images differ in size");
  }
  const Rectifier& rectifier = rectifierFor(calib_path, left.size());
  // Fresh outputs: the previous frame's buffers may still be held by a consumer.
  cv::Mat left_rectified;
  cv::Mat right_rectified;
  rectifier.rectify(left, right, left_rectified, right_rectified);
  pair.left = left_rectified;
  pair.right = right_rectified;
  pair.rig = rectifier.rig();
}

}  // namespace sg
