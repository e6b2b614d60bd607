#include "io/pairs_source.hpp"

#include <filesystem>
#include <utility>

#include "camera/calibration.hpp"
#include "config/errors.hpp"
#include "io/image_file.hpp"

namespace sg {

namespace {

namespace fs = std::filesystem;

bool isFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

}  // namespace

std::string PairsSource::rightImageFor(const std::string& name) const {
  const fs::path right_dir = fs::path(dir_) / "right";
  const fs::path same = right_dir / name;
  if (isFile(same)) return same.string();
  // Common naming schemes: urban1_left.pgm / urban1_right.pgm, im0.png / im1.png.
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"left", "right"}, {"Left", "Right"},
                                 {"LEFT", "RIGHT"}, {"im0", "im1"}}) {
    const auto at = name.rfind(from);
    if (at == std::string::npos) continue;
    std::string other = name;
    other.replace(at, from.size(), to);
    if (isFile(right_dir / other)) return (right_dir / other).string();
  }
  return same.string();  // reported as missing by the loader
}

PairsSource::PairsSource(const std::string& dir, const std::string& calib_path)
    : dir_(dir), loader_(folderMounting(dir)) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError("pairs:" + dir + ": directory not found");
  const std::string left_dir = (fs::path(dir) / "left").string();
  if (!fs::is_directory(left_dir, ec)) throw InputError("pairs:" + dir + ": missing directory " + left_dir);
  if (!fs::is_directory(fs::path(dir) / "right", ec)) {
    throw InputError("pairs:" + dir + ": missing directory " + (fs::path(dir) / "right").string());
  }
  names_ = listImageFiles(left_dir);
  if (names_.empty()) throw InputError("pairs:" + dir + ": no images in " + left_dir);

  if (!calib_path.empty()) {
    calib_path_ = calib_path;
    loadCalibration(calib_path_);  // fail early on a malformed file
    return;
  }
  for (const char* candidate : {"calib.yaml", "calib.yml", "calib.xml", "calib.txt"}) {
    if (isFile(fs::path(dir) / candidate)) {
      calib_path_ = (fs::path(dir) / candidate).string();
      loadCalibration(calib_path_);
      return;
    }
  }
  if (fs::is_directory(fs::path(dir) / "calib", ec)) calib_dir_ = (fs::path(dir) / "calib").string();
}

std::string PairsSource::calibrationFor(const std::string& name) const {
  if (!calib_path_.empty() || calib_dir_.empty()) return calib_path_;
  const fs::path per_frame = fs::path(calib_dir_) / (fs::path(name).stem().string() + ".txt");
  if (isFile(per_frame)) return per_frame.string();
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(calib_dir_, ec)) {
    if (entry.is_regular_file(ec) && entry.path().filename() != "camera_height_m") {
      files.push_back(entry.path().string());
    }
  }
  if (files.size() == 1) return files.front();
  throw InputError(calib_dir_ + ": no calibration for frame '" + name + "' (expected " + per_frame.string() +
                   " or a single calibration file)");
}

bool PairsSource::next(StereoPair& pair) {
  if (position_ >= names_.size()) return false;
  const std::size_t index = position_++;  // move on even when this frame is bad
  const std::string& name = names_[index];
  const std::string left = (fs::path(dir_) / "left" / name).string();
  const std::string right = rightImageFor(name);
  pair = StereoPair{};
  pair.id = fs::path(name).stem().string();
  pair.index = static_cast<std::int64_t>(index);
  pair.scene_start = index == 0;  // a folder of pairs is a recorded sequence
  loader_.load(left, right, calibrationFor(name), pair);
  return true;
}

std::string PairsSource::describe() const {
  std::string calib = !calib_path_.empty() ? calib_path_ : !calib_dir_.empty() ? calib_dir_ : "nominal rig";
  return "pairs:" + dir_ + " (" + std::to_string(names_.size()) + " pairs, calibration " + calib + ")";
}

}  // namespace sg
