#include "io/kitti_format.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "config/errors.hpp"

namespace sg {

namespace {

const char* const kFieldNames[] = {"type",   "truncated", "occluded", "alpha", "left", "top", "right", "bottom",
                                   "height", "width",     "length",   "x",     "y",    "z",   "rotation_y", "score"};

double parseNumber(const std::string& token, const std::string& what, int field) {
  const char* begin = token.c_str();
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  if (end == begin || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
    throw InputError(what + ": field " + std::to_string(field + 1) + " (" + kFieldNames[field] + ") = '" + token +
                     "' is not a finite number");
  }
  return value;
}

std::ofstream openForWrite(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write '" + path + "'");
  return out;
}

void finish(std::ofstream& out, const std::string& path) {
  out.flush();
  if (!out) throw InputError("error while writing '" + path + "'");
}

}  // namespace

ObjectLabel parseKittiLabelLine(const std::string& line, const std::string& what) {
  std::istringstream in(line);
  std::vector<std::string> tokens;
  for (std::string t; in >> t;) tokens.push_back(t);
  if (tokens.size() != 15 && tokens.size() != 16) {
    throw InputError(what + ": expected 15 fields (16 with a score), found " + std::to_string(tokens.size()));
  }
  ObjectLabel label;
  label.type = tokens[0];
  double v[16];
  for (std::size_t i = 1; i < tokens.size(); ++i) v[i] = parseNumber(tokens[i], what, static_cast<int>(i));
  label.truncation = v[1];
  if (v[2] != std::floor(v[2]) || v[2] < -1.0 || v[2] > 3.0) {
    throw InputError(what + ": field 3 (occluded) = '" + tokens[2] + "' must be an integer in -1..3");
  }
  label.occlusion = static_cast<int>(v[2]);
  label.alpha = v[3];
  label.box = {v[4], v[5], v[6], v[7]};
  label.dimensions_m = {v[8], v[9], v[10]};
  label.location_m = {v[11], v[12], v[13]};
  label.rotation_y = v[14];
  if (tokens.size() == 16) label.score = v[15];
  return label;
}

std::vector<ObjectLabel> readKittiLabels(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("cannot read label file '" + path + "'");
  std::vector<ObjectLabel> labels;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    labels.push_back(parseKittiLabelLine(line, "label file '" + path + "' line " + std::to_string(number)));
  }
  if (in.bad()) throw InputError("error while reading label file '" + path + "'");
  return labels;
}

std::string formatKittiLabelLine(const ObjectLabel& l) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "%s %.2f %d %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f",
                l.type.c_str(), l.truncation, l.occlusion, l.alpha, l.box[0], l.box[1], l.box[2], l.box[3],
                l.dimensions_m[0], l.dimensions_m[1], l.dimensions_m[2], l.location_m[0], l.location_m[1],
                l.location_m[2], l.rotation_y);
  std::string s = buf;
  if (l.score) {
    std::snprintf(buf, sizeof buf, " %.4f", *l.score);
    s += buf;
  }
  return s;
}

void writeKittiLabels(const std::string& path, const std::vector<ObjectLabel>& labels) {
  for (const auto& l : labels) {
    if (l.type.empty() || l.type.find_first_of(" \t\r\n") != std::string::npos) {
      throw InputError("label file '" + path + "': object type '" + l.type + "' must be one word");
    }
  }
  std::ofstream out = openForWrite(path);
  for (const auto& l : labels) out << formatKittiLabelLine(l) << "\n";
  finish(out, path);
}

void writeKittiCalib(const std::string& path, const StereoRig& rig) {
  rig.validate("calibration for '" + path + "'");
  const double f = rig.focal_px;
  const double p2[12] = {f, 0.0, rig.cx_px, 0.0, 0.0, f, rig.cy_px, 0.0, 0.0, 0.0, 1.0, 0.0};
  double p3[12];
  std::copy(std::begin(p2), std::end(p2), std::begin(p3));
  p3[3] = -f * rig.baseline_m;
  const double r0[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  // Velodyne (x forward, y left, z up) to camera (x right, y down, z forward).
  const double velo[12] = {0, -1, 0, 0, 0, 0, -1, 0, 1, 0, 0, 0};
  const double imu[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  std::ofstream out = openForWrite(path);
  auto line = [&](const char* name, const double* values, int count) {
    out << name << ":";
    char buf[32];
    for (int i = 0; i < count; ++i) {
      std::snprintf(buf, sizeof buf, " %.12e", values[i]);
      out << buf;
    }
    out << "\n";
  };
  line("P0", p2, 12);
  line("P1", p3, 12);
  line("P2", p2, 12);
  line("P3", p3, 12);
  line("R0_rect", r0, 9);
  line("Tr_velo_to_cam", velo, 12);
  line("Tr_imu_to_velo", imu, 12);
  finish(out, path);
}

void writeKittiDisparity(const std::string& path, const cv::Mat& disparity) {
  if (disparity.type() != CV_32F) throw InputError("disparity for '" + path + "' must be CV_32F");
  cv::Mat out(disparity.size(), CV_16U);
  for (int v = 0; v < disparity.rows; ++v) {
    const auto* in = disparity.ptr<float>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < disparity.cols; ++u) {
      const double d = static_cast<double>(in[u]);
      o[u] = (std::isfinite(d) && d > 0.0) ? static_cast<std::uint16_t>(std::min(65535.0, std::round(d * 256.0))) : 0;
    }
  }
  if (!cv::imwrite(path, out)) throw InputError("cannot write '" + path + "'");
}

cv::Mat readKittiDisparity(const std::string& path) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw InputError("cannot read disparity '" + path + "'");
  if (raw.type() != CV_16U || raw.channels() != 1) throw InputError("disparity '" + path + "' must be a 16-bit grey PNG");
  cv::Mat d;
  raw.convertTo(d, CV_32F, 1.0 / 256.0);
  return d;
}

void writeKittiFrame(const std::string& dir, const StereoPair& pair) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const char* sub : {"image_2", "image_3", "calib", "label_2", "disp_2"}) {
    fs::create_directories(fs::path(dir) / sub, ec);
    if (ec) throw InputError("cannot create '" + (fs::path(dir) / sub).string() + "': " + ec.message());
  }
  const fs::path root(dir);
  const std::string name = pair.id;
  auto writeImage = [](const fs::path& p, const cv::Mat& image) {
    if (!cv::imwrite(p.string(), image)) throw InputError("cannot write '" + p.string() + "'");
  };
  writeImage(root / "image_2" / (name + ".png"), pair.left);
  writeImage(root / "image_3" / (name + ".png"), pair.right);
  writeKittiCalib((root / "calib" / (name + ".txt")).string(), pair.rig);
  writeKittiLabels((root / "label_2" / (name + ".txt")).string(), pair.labels);
  if (pair.truth) writeKittiDisparity((root / "disp_2" / (name + ".png")).string(), pair.truth->disparity);
}

}  // namespace sg
