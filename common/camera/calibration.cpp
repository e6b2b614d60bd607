#include "camera/calibration.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <yaml-cpp/yaml.h>

#include "config/errors.hpp"

namespace sg {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& file, const std::string& message) { throw InputError(file + ": " + message); }

std::string readText(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path, "file not found");
  if (fs::is_directory(path, ec)) fail(path, "is a directory, expected a calibration file");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r\n");
  return s.substr(begin, end - begin + 1);
}

// Parses a whole token as a finite double.
std::optional<double> parseNumber(const std::string& token) {
  if (token.empty()) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(token.c_str(), &end);
  if (end != token.c_str() + token.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::string dims(const cv::Mat& m) { return std::to_string(m.rows) + "x" + std::to_string(m.cols); }

// ---------------------------------------------------------------------------
// Documents holding named matrices and numbers: YAML (yaml-cpp) and OpenCV
// FileStorage (XML or "%YAML:1.0" with !!opencv-matrix). Both name the file
// and the field in every error.

class CalibDoc {
 public:
  explicit CalibDoc(std::string file) : file_(std::move(file)) {}
  virtual ~CalibDoc() = default;
  CalibDoc(const CalibDoc&) = delete;
  CalibDoc& operator=(const CalibDoc&) = delete;

  virtual bool has(const std::string& key) const = 0;
  // The matrix under `key` as CV_64F (rows x cols); a plain list is 1 x N.
  virtual cv::Mat matrix(const std::string& key) const = 0;
  virtual std::optional<double> number(const std::string& key) const = 0;

  const std::string& file() const { return file_; }

  cv::Mat requireMatrix(const std::string& key) const {
    if (!has(key)) fail(file_, "missing field '" + key + "'");
    return matrix(key);
  }

  // A matrix of an exact shape; a vector of `rows * cols` numbers is accepted and reshaped.
  cv::Mat requireShape(const std::string& key, int rows, int cols) const {
    cv::Mat m = requireMatrix(key);
    if (m.rows == rows && m.cols == cols) return m;
    if (m.total() == static_cast<std::size_t>(rows * cols) && (m.rows == 1 || m.cols == 1)) {
      return m.reshape(1, rows).clone();
    }
    fail(file_, "field '" + key + "' is " + dims(m) + ", expected " + std::to_string(rows) + "x" +
                    std::to_string(cols));
  }

  cv::Mat requireDistortion(const std::string& key) const {
    cv::Mat m = requireMatrix(key);
    const std::size_t n = m.total();
    if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
      fail(file_, "field '" + key + "' has " + std::to_string(n) + " coefficients, expected 0, 4, 5, 8, 12 or 14");
    }
    return n == 0 ? cv::Mat::zeros(1, 5, CV_64F) : m.reshape(1, 1).clone();
  }

  std::optional<int> integer(const std::string& key) const {
    const auto v = number(key);
    if (!v) return std::nullopt;
    if (*v != std::floor(*v) || *v < 1.0 || *v > 100000.0) {
      fail(file_, "field '" + key + "' = " + std::to_string(*v) + " must be a positive whole number");
    }
    return static_cast<int>(*v);
  }

 protected:
  std::string file_;
};

class YamlDoc final : public CalibDoc {
 public:
  YamlDoc(const std::string& file, const std::string& text) : CalibDoc(file) {
    try {
      root_ = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      fail(file, "not valid YAML (line " + std::to_string(e.mark.line + 1) + "): " + e.msg);
    }
    if (!root_.IsMap()) fail(file, "expected a YAML mapping of calibration fields");
  }

  bool has(const std::string& key) const override { return static_cast<bool>(root_[key]); }

  cv::Mat matrix(const std::string& key) const override {
    const YAML::Node node = root_[key];
    YAML::Node data;
    int rows = 0;
    int cols = 0;
    if (node.IsMap()) {
      if (!node["data"]) fail(file_, "field '" + key + "' has no 'data'");
      data = node["data"];
      rows = dimension(node, key, "rows");
      cols = dimension(node, key, "cols");
    } else if (node.IsSequence()) {
      data = node;
      rows = 1;
      cols = static_cast<int>(node.size());
    } else {
      fail(file_, "field '" + key + "' must be a matrix (rows, cols, data) or a list of numbers");
    }
    if (!data.IsSequence()) fail(file_, "field '" + key + "': 'data' must be a list of numbers");
    if (data.size() != static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols)) {
      fail(file_, "field '" + key + "' has " + std::to_string(data.size()) + " numbers, expected rows x cols = " +
                      std::to_string(rows * cols));
    }
    cv::Mat m(rows, cols, CV_64F);
    for (std::size_t i = 0; i < data.size(); ++i) {
      const auto value = data[i].IsScalar() ? parseNumber(data[i].Scalar()) : std::nullopt;
      if (!value) {
        fail(file_, "field '" + key + "': element " + std::to_string(i) + " ('" +
                        (data[i].IsScalar() ? data[i].Scalar() : std::string("not a scalar")) + "') is not a number");
      }
      m.at<double>(static_cast<int>(i)) = *value;
    }
    return m;
  }

  std::optional<double> number(const std::string& key) const override {
    const YAML::Node node = root_[key];
    if (!node) return std::nullopt;
    const auto value = node.IsScalar() ? parseNumber(node.Scalar()) : std::nullopt;
    if (!value) {
      fail(file_, "field '" + key + "' must be a number, got '" + (node.IsScalar() ? node.Scalar() : "a non-scalar") +
                      "'");
    }
    return value;
  }

 private:
  int dimension(const YAML::Node& node, const std::string& key, const char* which) const {
    const YAML::Node item = node[which];
    if (!item) fail(file_, "field '" + key + "' has no '" + which + "'");
    const auto value = item.IsScalar() ? parseNumber(item.Scalar()) : std::nullopt;
    if (!value || *value < 0.0 || *value > 64.0 || *value != std::floor(*value)) {
      fail(file_, "field '" + key + "': '" + which + "' must be a whole number within 0..64");
    }
    return static_cast<int>(*value);
  }

  YAML::Node root_;
};

class OpenCvDoc final : public CalibDoc {
 public:
  OpenCvDoc(const std::string& file, const std::string& text) : CalibDoc(file) {
    try {
      storage_.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    } catch (const cv::Exception& e) {
      fail(file, "cannot parse the OpenCV calibration file: " + e.msg);
    } catch (const std::length_error& e) {
      // OpenCV 4.6's YAML parser throws this on a key that is only ':'.
      fail(file, std::string("cannot parse the OpenCV calibration file: malformed key (") + e.what() + ")");
    }
    if (!storage_.isOpened()) fail(file, "cannot parse the OpenCV calibration file");
    if (!storage_.root().isMap()) fail(file, "expected a mapping of calibration fields at the top level");
  }

  bool has(const std::string& key) const override { return !storage_[key].empty() && !storage_[key].isNone(); }

  cv::Mat matrix(const std::string& key) const override {
    const cv::FileNode node = storage_[key];
    if (node.isMap()) {
      const cv::FileNode data = node["data"];
      const cv::FileNode rows = node["rows"];
      const cv::FileNode cols = node["cols"];
      if (data.empty()) fail(file_, "field '" + key + "' has no 'data'");
      if (rows.empty() || cols.empty()) fail(file_, "field '" + key + "' has no 'rows'/'cols'");
      const bool whole = (rows.isInt() || rows.isReal()) && (cols.isInt() || cols.isReal());
      const double nrows = whole ? static_cast<double>(rows) : -1.0;
      const double ncols = whole ? static_cast<double>(cols) : -1.0;
      if (!(nrows >= 0.0 && nrows <= 64.0 && ncols >= 0.0 && ncols <= 64.0) || nrows != std::floor(nrows) ||
          ncols != std::floor(ncols)) {
        fail(file_, "field '" + key + "': 'rows' and 'cols' must be whole numbers within 0..64");
      }
      const int expected = static_cast<int>(nrows) * static_cast<int>(ncols);
      if (data.isSeq() && static_cast<int>(data.size()) != expected) {
        fail(file_, "field '" + key + "' has " + std::to_string(data.size()) + " numbers, expected rows x cols = " +
                        std::to_string(expected));
      }
      cv::Mat m;
      try {
        node >> m;
      } catch (const cv::Exception& e) {
        fail(file_, "field '" + key + "' is not a valid matrix: " + e.msg);
      }
      if (m.empty() && expected != 0) fail(file_, "field '" + key + "' is not a valid matrix");
      cv::Mat out;
      m.convertTo(out, CV_64F);
      return out;
    }
    if (node.isSeq()) {
      cv::Mat m(1, static_cast<int>(node.size()), CV_64F);
      for (int i = 0; i < m.cols; ++i) {
        const cv::FileNode item = node[i];
        if (!item.isReal() && !item.isInt()) {
          fail(file_, "field '" + key + "': element " + std::to_string(i) + " is not a number");
        }
        m.at<double>(i) = static_cast<double>(item);
      }
      return m;
    }
    fail(file_, "field '" + key + "' must be a matrix");
  }

  std::optional<double> number(const std::string& key) const override {
    const cv::FileNode node = storage_[key];
    if (node.empty() || node.isNone()) return std::nullopt;
    if (!node.isReal() && !node.isInt()) fail(file_, "field '" + key + "' must be a number");
    const double value = static_cast<double>(node);
    if (!std::isfinite(value)) fail(file_, "field '" + key + "' must be a finite number");
    return value;
  }

 private:
  cv::FileStorage storage_;
};

// ---------------------------------------------------------------------------

void checkCameraMatrix(const CalibDoc& doc, const std::string& key, const cv::Mat& m) {
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(m.at<double>(i))) fail(doc.file(), "field '" + key + "' holds a NaN or infinite value");
  }
  if (!(m.at<double>(0, 0) > 0.0) || !(m.at<double>(1, 1) > 0.0)) {
    fail(doc.file(), "field '" + key + "': focal lengths fx, fy must be positive");
  }
}

// Rig of an already rectified pair from its two 3x4 projection matrices.
StereoRig rigFromProjections(const cv::Mat& pl, const cv::Mat& pr, const std::string& file, const std::string& left_key,
                             const std::string& right_key) {
  for (int i = 0; i < 12; ++i) {
    if (!std::isfinite(pl.at<double>(i))) fail(file, "field '" + left_key + "' holds a NaN or infinite value");
    if (!std::isfinite(pr.at<double>(i))) fail(file, "field '" + right_key + "' holds a NaN or infinite value");
  }
  StereoRig rig;
  rig.focal_px = pl.at<double>(0, 0);
  rig.cx_px = pl.at<double>(0, 2);
  rig.cy_px = pl.at<double>(1, 2);
  if (!(rig.focal_px > 0.0)) {
    fail(file, "field '" + left_key + "': focal length P[0][0] = " + std::to_string(rig.focal_px) +
                   " must be positive");
  }
  const double fr = pr.at<double>(0, 0);
  // A rectified pair shares focal length and principal row; the column may not differ
  // either, since the rig has no disparity offset term.
  if (std::abs(fr - rig.focal_px) > 1e-3 * rig.focal_px || std::abs(pr.at<double>(1, 2) - rig.cy_px) > 0.5 ||
      std::abs(pr.at<double>(0, 2) - rig.cx_px) > 0.5) {
    fail(file, "field '" + right_key + "': focal length or principal point differs from '" + left_key +
                   "' (not a rectified pair with zero disparity offset)");
  }
  if (std::abs(pr.at<double>(1, 3) - pl.at<double>(1, 3)) > 1e-3 * rig.focal_px &&
      std::abs(pr.at<double>(0, 3) - pl.at<double>(0, 3)) < 1e-6) {
    fail(file, "field '" + right_key + "': vertical stereo rigs are not supported");
  }
  rig.baseline_m = (pl.at<double>(0, 3) - pr.at<double>(0, 3)) / rig.focal_px;
  if (rig.baseline_m < 0.0) {
    fail(file, "field '" + right_key + "': baseline " + std::to_string(rig.baseline_m) +
                   " m is negative (left and right swapped?)");
  }
  return rig;
}

// Validates what is known of the rig before the image size is.
void validateWithoutSize(const StereoRig& rig, const std::string& what) {
  StereoRig probe = rig;
  if (probe.width == 0 || probe.height == 0) {
    probe.width = 16384;
    probe.height = 16384;
  }
  probe.validate(what);
}

void attachMountingFile(StereoCalibration& calib, const std::string& calib_file) {
  if (calib.rig.mounting) return;
  // Beside the file, or, for a KITTI layout's DIR/calib/NNNNNN.txt, in DIR.
  const fs::path folder = fs::path(calib_file).parent_path();
  std::vector<fs::path> candidates{folder / "camera_height_m"};
  if (folder.filename() == "calib") candidates.push_back(folder.parent_path() / "camera_height_m");
  for (const fs::path& file : candidates) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) continue;
    calib.rig.mounting = Mounting{readNumberFile(file.string()), 0.0};
    return;
  }
}

void attachMountingKeys(StereoCalibration& calib, const CalibDoc& doc) {
  const auto height = doc.number("camera_height_m");
  const auto pitch = doc.number("camera_pitch_rad");
  if (pitch && !height) fail(doc.file(), "field 'camera_pitch_rad' given without 'camera_height_m'");
  if (height) calib.rig.mounting = Mounting{*height, pitch.value_or(0.0)};
}

// Computes R1 R2 P1 P2 and the rectified rig of a raw calibration at calib.image_size.
void computeRectification(StereoCalibration& calib) {
  cv::Mat q;
  try {
    cv::stereoRectify(calib.M1, calib.D1, calib.M2, calib.D2, calib.image_size, calib.R, calib.T, calib.R1,
                      calib.R2, calib.P1, calib.P2, q, cv::CALIB_ZERO_DISPARITY, 0.0, calib.image_size);
  } catch (const cv::Exception& e) {
    fail(calib.source, "cannot rectify this calibration: " + e.msg);
  }
  if (std::abs(calib.P2.at<double>(1, 3)) > std::abs(calib.P2.at<double>(0, 3))) {
    fail(calib.source, "field 'T': vertical stereo rigs are not supported");
  }
  const StereoRig previous = calib.rig;
  calib.rig = rigFromProjections(calib.P1, calib.P2, calib.source, "P1 (rectified)", "P2 (rectified)");
  calib.rig.mounting = previous.mounting;
}

// ---------------------------------------------------------------------------
// KITTI text

StereoCalibration readKittiText(const std::string& path, const std::string& text) {
  // Values stay text until used: raw-data files also hold dates and names (calib_time).
  std::map<std::string, std::string> fields;
  std::istringstream lines(text);
  std::string line;
  int line_no = 0;
  while (std::getline(lines, line)) {
    ++line_no;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    line = trim(line);
    if (line.empty()) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos || colon == 0) {
      fail(path, "line " + std::to_string(line_no) + ": expected 'NAME: numbers', got '" + line + "'");
    }
    const std::string key = trim(line.substr(0, colon));
    if (!fields.emplace(key, line.substr(colon + 1)).second) fail(path, "field '" + key + "' appears twice");
  }

  const auto has = [&](const char* key) { return fields.count(key) != 0; };
  std::string left_key;
  std::string right_key;
  if (has("P_rect_02") || has("P_rect_03")) {
    left_key = "P_rect_02";
    right_key = "P_rect_03";
  } else if (has("P0") || has("P3")) {
    left_key = "P2";
    right_key = "P3";
  } else if (has("P1_roi") || has("P2_roi")) {
    left_key = "P1_roi";
    right_key = "P2_roi";
  } else if (has("P1") && has("P2")) {
    left_key = "P1";  // Karlsruhe sequences: P1 left, P2 right
    right_key = "P2";
  } else {
    left_key = "P2";
    right_key = "P3";
  }
  const auto projection = [&](const std::string& key) {
    const auto it = fields.find(key);
    if (it == fields.end()) fail(path, "missing field '" + key + "'");
    std::istringstream tokens(it->second);
    std::vector<double> values;
    std::string token;
    while (tokens >> token) {
      const auto value = parseNumber(token);
      if (!value) fail(path, "field '" + key + "': '" + token + "' is not a finite number");
      values.push_back(*value);
    }
    if (values.size() != 12) {
      fail(path, "field '" + key + "' has " + std::to_string(values.size()) + " numbers, expected 12");
    }
    return cv::Mat(3, 4, CV_64F, values.data()).clone();
  };
  const cv::Mat pl = projection(left_key);
  const cv::Mat pr = projection(right_key);

  StereoCalibration calib;
  calib.source = path;
  calib.rig = rigFromProjections(pl, pr, path, left_key, right_key);
  calib.P1 = pl;
  calib.P2 = pr;
  return calib;
}

// ---------------------------------------------------------------------------
// OpenCV stereo calibration (M1 D1 M2 D2 R T and/or P1 P2)

StereoCalibration readOpenCvStereo(const CalibDoc& doc, cv::Size image_size) {
  StereoCalibration calib;
  calib.source = doc.file();
  const auto width = doc.integer("image_width");
  const auto height = doc.integer("image_height");
  if (width.has_value() != height.has_value()) {
    fail(doc.file(), std::string("missing field '") + (width ? "image_height" : "image_width") + "'");
  }
  if (width) calib.image_size = cv::Size(*width, *height);
  if (!calib.image_size.empty() && !image_size.empty() && calib.image_size != image_size) {
    fail(doc.file(), "calibrated for " + sizeText(calib.image_size) + " images, used with " + sizeText(image_size));
  }
  if (calib.image_size.empty()) calib.image_size = image_size;
  attachMountingKeys(calib, doc);

  const char* raw_keys[] = {"M1", "D1", "M2", "D2", "R", "T"};
  bool any_raw = false;
  for (const char* key : raw_keys) any_raw = any_raw || doc.has(key);

  if (any_raw) {
    calib.M1 = doc.requireShape("M1", 3, 3);
    calib.D1 = doc.requireDistortion("D1");
    calib.M2 = doc.requireShape("M2", 3, 3);
    calib.D2 = doc.requireDistortion("D2");
    checkCameraMatrix(doc, "M1", calib.M1);
    checkCameraMatrix(doc, "M2", calib.M2);
    const cv::Mat r = doc.requireMatrix("R");
    if (r.total() == 3) {
      cv::Rodrigues(r.reshape(1, 3), calib.R);
    } else if (r.rows == 3 && r.cols == 3) {
      calib.R = r;
    } else {
      fail(doc.file(), "field 'R' is " + dims(r) + ", expected 3x3 or a 3-element rotation vector");
    }
    if (std::abs(cv::determinant(calib.R) - 1.0) > 1e-3) {
      fail(doc.file(), "field 'R' is not a rotation matrix (determinant " + std::to_string(cv::determinant(calib.R)) +
                           ")");
    }
    calib.T = doc.requireShape("T", 3, 1);
    if (!std::isfinite(cv::norm(calib.T)) || cv::norm(calib.T) <= 0.0) {
      fail(doc.file(), "field 'T' must be a finite non-zero translation (metres)");
    }
    calib.needs_rectification = true;
    const char* rect_keys[] = {"R1", "R2", "P1", "P2"};
    bool all_rect = true;
    for (const char* key : rect_keys) all_rect = all_rect && doc.has(key);
    if (all_rect) {
      // Use the file's own rectification (as written by cv::stereoRectify).
      calib.R1 = doc.requireShape("R1", 3, 3);
      calib.R2 = doc.requireShape("R2", 3, 3);
      calib.P1 = doc.requireShape("P1", 3, 4);
      calib.P2 = doc.requireShape("P2", 3, 4);
      const auto mounting = calib.rig.mounting;
      calib.rig = rigFromProjections(calib.P1, calib.P2, doc.file(), "P1", "P2");
      calib.rig.mounting = mounting;
    } else if (!calib.image_size.empty()) {
      computeRectification(calib);
    }
  } else if (doc.has("P1") || doc.has("P2")) {
    calib.P1 = doc.requireShape("P1", 3, 4);
    calib.P2 = doc.requireShape("P2", 3, 4);
    const auto mounting = calib.rig.mounting;
    calib.rig = rigFromProjections(calib.P1, calib.P2, doc.file(), "P1", "P2");
    calib.rig.mounting = mounting;
  } else if (doc.has("camera_matrix") || doc.has("projection_matrix")) {
    fail(doc.file(), "a single ROS camera_info file; give both as 'left.yaml,right.yaml'");
  } else {
    fail(doc.file(), "missing field 'M1' (expected M1 D1 M2 D2 R T, or rectified P1 P2)");
  }
  return calib;
}

// ---------------------------------------------------------------------------
// ROS camera_info pair

struct CameraInfo {
  cv::Size size;
  cv::Mat k, d, r, p;
};

CameraInfo readCameraInfo(const std::string& path) {
  const std::string text = readText(path);
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    fail(path, "NUL byte at offset " + std::to_string(nul) + ": not a text calibration file");
  }
  const YamlDoc doc(path, text);
  CameraInfo info;
  const char* required[] = {"image_width", "image_height", "camera_matrix", "distortion_coefficients",
                            "rectification_matrix", "projection_matrix"};
  for (const char* key : required) {
    if (!doc.has(key)) fail(path, std::string("missing field '") + key + "'");
  }
  info.size = cv::Size(*doc.integer("image_width"), *doc.integer("image_height"));
  info.k = doc.requireShape("camera_matrix", 3, 3);
  checkCameraMatrix(doc, "camera_matrix", info.k);
  info.d = doc.requireDistortion("distortion_coefficients");
  info.r = doc.requireShape("rectification_matrix", 3, 3);
  info.p = doc.requireShape("projection_matrix", 3, 4);
  return info;
}

bool isIdentity(const cv::Mat& m) { return cv::norm(m, cv::Mat::eye(m.size(), m.type()), cv::NORM_INF) < 1e-9; }

StereoCalibration readRosPair(const std::string& left_path, const std::string& right_path, cv::Size image_size) {
  const CameraInfo left = readCameraInfo(left_path);
  const CameraInfo right = readCameraInfo(right_path);
  const std::string both = left_path + "," + right_path;
  if (left.size != right.size) {
    fail(right_path, "image size " + sizeText(right.size) + " differs from " + left_path + " (" + sizeText(left.size) +
                         ")");
  }
  if (!image_size.empty() && image_size != left.size) {
    fail(left_path, "calibrated for " + sizeText(left.size) + " images, used with " + sizeText(image_size));
  }
  StereoCalibration calib;
  calib.source = both;
  calib.image_size = left.size;
  calib.rig = rigFromProjections(left.p, right.p, right_path, "projection_matrix (left)", "projection_matrix");
  calib.M1 = left.k;
  calib.D1 = left.d;
  calib.M2 = right.k;
  calib.D2 = right.d;
  calib.R1 = left.r;
  calib.R2 = right.r;
  calib.P1 = left.p;
  calib.P2 = right.p;
  calib.needs_rectification = cv::countNonZero(left.d != 0.0) > 0 || cv::countNonZero(right.d != 0.0) > 0 ||
                              !isIdentity(left.r) || !isIdentity(right.r) ||
                              cv::norm(left.k - left.p.colRange(0, 3), cv::NORM_INF) > 1e-9 ||
                              cv::norm(right.k - right.p.colRange(0, 3), cv::NORM_INF) > 1e-9;
  attachMountingFile(calib, left_path);
  return calib;
}

bool startsWith(const std::string& text, const char* prefix) { return text.rfind(prefix, 0) == 0; }

std::string extensionLower(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

std::string sizeText(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

double readNumberFile(const std::string& path) {
  const std::string text = trim(readText(path));
  const auto value = parseNumber(text);
  if (!value) fail(path, "expected one number, got '" + text.substr(0, 40) + "'");
  return *value;
}

StereoCalibration loadCalibration(const std::string& path, cv::Size image_size) {
  if (path.empty()) throw InputError("calibration: empty path");
  std::error_code ec;
  if (const auto comma = path.find(','); comma != std::string::npos && !fs::exists(path, ec)) {
    const std::string left = trim(path.substr(0, comma));
    const std::string right = trim(path.substr(comma + 1));
    if (left.empty() || right.empty() || right.find(',') != std::string::npos) {
      throw InputError("calibration '" + path + "': expected 'left.yaml,right.yaml'");
    }
    StereoCalibration calib = readRosPair(left, right, image_size);
    validateWithoutSize(calib.rig, calib.source);
    setImageSize(calib, calib.image_size, left);
    return calib;
  }

  const std::string text = readText(path);
  // OpenCV's FileStorage reads the text as a C string and crashes on some inputs
  // with a NUL byte inside (found by tests/fuzz); no calibration format has one.
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    fail(path, "NUL byte at offset " + std::to_string(nul) + ": not a text calibration file");
  }
  const std::string head = trim(text.substr(0, 64));
  const std::string ext = extensionLower(path);
  StereoCalibration calib;
  if (startsWith(head, "%YAML") || startsWith(head, "<?xml") || startsWith(head, "<opencv_storage")) {
    // OpenCV 4.6's XML parser reads past the end of a text cut off inside a tag
    // after an attribute's '=' (found by tests/fuzz: "<?xml version="). A complete
    // document ends with its root's closing tag.
    if (head[0] == '<') {
      const std::size_t last = text.find_last_not_of(" \t\r\n");
      if (text[last] != '>') fail(path, "XML calibration file does not end with a closing tag (cut off?)");
    }
    const OpenCvDoc doc(path, text);
    try {
      calib = readOpenCvStereo(doc, image_size);
    } catch (const cv::Exception& e) {
      // OpenCV asserts on node kinds it did not expect; still a bad file, not a crash.
      fail(path, "not a usable OpenCV calibration: " + e.msg);
    }
  } else if (ext == ".yaml" || ext == ".yml") {
    const YamlDoc doc(path, text);
    calib = readOpenCvStereo(doc, image_size);
  } else if (ext == ".xml") {
    fail(path, "not an OpenCV FileStorage XML file");
  } else {
    calib = readKittiText(path, text);
    if (!image_size.empty()) calib.image_size = image_size;
  }
  attachMountingFile(calib, path);
  if (!calib.needs_rectification || !calib.P1.empty()) validateWithoutSize(calib.rig, calib.source);
  if (!calib.image_size.empty()) setImageSize(calib, calib.image_size, path);
  return calib;
}

void setImageSize(StereoCalibration& calib, cv::Size image_size, const std::string& what) {
  if (image_size.width <= 0 || image_size.height <= 0) {
    throw InputError(what + ": empty image size " + sizeText(image_size));
  }
  if (!calib.image_size.empty() && calib.image_size != image_size) {
    throw InputError(what + ": image size " + sizeText(image_size) + " differs from the calibration's " +
                     sizeText(calib.image_size) + " (" + calib.source + ")");
  }
  calib.image_size = image_size;
  if (calib.needs_rectification && calib.P1.empty()) computeRectification(calib);
  calib.rig.width = image_size.width;
  calib.rig.height = image_size.height;
  calib.rig.validate(calib.source);
}

StereoCalibration nominalCalibration(cv::Size image_size) {
  StereoCalibration calib;
  calib.source = "nominal";
  calib.rig.focal_px = 721.5;
  calib.rig.cx_px = image_size.width / 2.0;
  calib.rig.cy_px = image_size.height / 2.0;
  calib.rig.baseline_m = 0.54;
  calib.rig.mounting = Mounting{1.65, 0.0};
  calib.image_size = image_size;
  calib.rig.width = image_size.width;
  calib.rig.height = image_size.height;
  return calib;
}

}  // namespace sg
