#include "io/kitti_source.hpp"

#include <filesystem>

#include "camera/calibration.hpp"
#include "config/errors.hpp"
#include "io/image_file.hpp"
#include "io/kitti_format.hpp"

namespace sg {

namespace fs = std::filesystem;

KittiSource::KittiSource(const std::string& dir, const std::string& calib_path)
    : dir_(dir), calib_path_(calib_path), loader_(folderMounting(dir)) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError("kitti:" + dir + ": directory not found");
  for (const char* sub : {"image_2", "image_3"}) {
    if (!fs::is_directory(fs::path(dir) / sub, ec)) {
      throw InputError("kitti:" + dir + ": missing directory " + (fs::path(dir) / sub).string());
    }
  }
  if (calib_path_.empty() && !fs::is_directory(fs::path(dir) / "calib", ec)) {
    throw InputError("kitti:" + dir + ": missing directory " + (fs::path(dir) / "calib").string() +
                     " (or give a calibration file)");
  }
  names_ = listImageFiles((fs::path(dir) / "image_2").string());
  if (names_.empty()) throw InputError("kitti:" + dir + ": no images in " + (fs::path(dir) / "image_2").string());
  has_labels_ = fs::is_directory(fs::path(dir) / "label_2", ec);
  if (!calib_path_.empty()) loadCalibration(calib_path_);  // fail early on a malformed file
}

bool KittiSource::next(StereoPair& pair) {
  if (position_ >= names_.size()) return false;
  const std::size_t index = position_++;  // move on even when this frame is bad
  const std::string& name = names_[index];
  const std::string id = fs::path(name).stem().string();
  const fs::path root(dir_);
  pair = StereoPair{};
  pair.id = id;
  pair.index = static_cast<std::int64_t>(index);
  pair.scene_start = true;  // KITTI object frames are unrelated images
  const std::string calib = calib_path_.empty() ? (root / "calib" / (id + ".txt")).string() : calib_path_;
  loader_.load((root / "image_2" / name).string(), (root / "image_3" / name).string(), calib, pair);
  if (has_labels_) pair.labels = readKittiLabels((root / "label_2" / (id + ".txt")).string());
  return true;
}

std::string KittiSource::describe() const {
  return "kitti:" + dir_ + " (" + std::to_string(names_.size()) + " frames" + (has_labels_ ? ", labels" : "") + ")";
}

}  // namespace sg
