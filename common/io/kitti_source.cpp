#include "io/kitti_source.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "camera/calibration.hpp"
#include "config/errors.hpp"
#include "io/image_file.hpp"

namespace sg {

namespace {

namespace fs = std::filesystem;

std::optional<Mounting> mountingFile(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return std::nullopt;
  return Mounting{readNumberFile(file.string()), 0.0};
}

}  // namespace

std::vector<ObjectLabel> readKittiLabelFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": label file not found");
  static const char* const kFields[] = {"type",   "truncated", "occluded", "alpha",      "left",  "top",
                                        "right",  "bottom",    "height",   "width",      "length", "x",
                                        "y",      "z",         "rotation_y", "score"};
  std::vector<ObjectLabel> labels;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::istringstream tokens(line);
    std::vector<std::string> fields;
    std::string token;
    while (tokens >> token) fields.push_back(token);
    if (fields.empty()) continue;
    const std::string where = path + ": line " + std::to_string(line_no);
    if (fields.size() != 15 && fields.size() != 16) {
      throw InputError(where + " has " + std::to_string(fields.size()) + " fields, expected 15 (or 16 with a score)");
    }
    std::vector<double> v(fields.size(), 0.0);
    for (std::size_t i = 1; i < fields.size(); ++i) {
      char* end = nullptr;
      v[i] = std::strtod(fields[i].c_str(), &end);
      if (end != fields[i].c_str() + fields[i].size() || !std::isfinite(v[i])) {
        throw InputError(where + ": field '" + kFields[i] + "' = '" + fields[i] + "' is not a number");
      }
    }
    ObjectLabel label;
    label.type = fields[0];
    label.truncation = v[1];
    label.occlusion = static_cast<int>(v[2]);
    label.alpha = v[3];
    label.box = {v[4], v[5], v[6], v[7]};
    label.dimensions_m = {v[8], v[9], v[10]};
    label.location_m = {v[11], v[12], v[13]};
    label.rotation_y = v[14];
    if (fields.size() == 16) label.score = v[15];
    labels.push_back(label);
  }
  return labels;
}

KittiSource::KittiSource(const std::string& dir, const std::string& calib_path)
    : dir_(dir), calib_path_(calib_path), loader_(mountingFile(fs::path(dir) / "camera_height_m")) {
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
  const std::string calib = calib_path_.empty() ? (root / "calib" / (id + ".txt")).string() : calib_path_;
  loader_.load((root / "image_2" / name).string(), (root / "image_3" / name).string(), calib, pair);
  if (has_labels_) pair.labels = readKittiLabelFile((root / "label_2" / (id + ".txt")).string());
  return true;
}

std::string KittiSource::describe() const {
  return "kitti:" + dir_ + " (" + std::to_string(names_.size()) + " frames" + (has_labels_ ? ", labels" : "") + ")";
}

}  // namespace sg
