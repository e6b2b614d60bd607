#pragma once
// Shared helpers of the vision tests: KITTI-layout real pairs and comparisons.
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "camera/stereo_rig.hpp"

namespace sg::test {

struct RealPair {
  std::string name;
  cv::Mat left, right;
  StereoRig rig;
};

// Reads calib/<frame>.txt (P2/P3 rows): f = P2[0][0], baseline = (P2[0][3] - P3[0][3]) / f.
inline bool readKittiRig(const std::string& path, int width, int height, double camera_height_m, StereoRig& rig) {
  std::ifstream in(path);
  std::string line;
  std::vector<double> p2, p3;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    std::vector<double>* target = key == "P2:" ? &p2 : key == "P3:" ? &p3 : nullptr;
    if (!target) continue;
    double v;
    while (ls >> v) target->push_back(v);
  }
  if (p2.size() < 12 || p3.size() < 12) return false;
  rig.focal_px = p2[0];
  rig.cx_px = p2[2];
  rig.cy_px = p2[6];
  rig.baseline_m = (p2[3] - p3[3]) / p2[0];
  rig.width = width;
  rig.height = height;
  rig.mounting = Mounting{camera_height_m, 0.0};
  return true;
}

inline std::vector<RealPair> loadKittiRigPairs() {
  const std::string dir = std::string(SG_SHARED_DATA_DIR) + "/kitti/kitti_rig";
  std::vector<RealPair> pairs;
  std::vector<cv::String> files;
  cv::glob(dir + "/image_2/*.png", files, false);
  double height = 1.65;
  std::ifstream(dir + "/camera_height_m") >> height;
  for (const cv::String& f : files) {
    const std::string file = f;
    const std::string name = file.substr(file.find_last_of('/') + 1, file.size() - file.find_last_of('/') - 5);
    RealPair p;
    p.name = name;
    p.left = cv::imread(dir + "/image_2/" + name + ".png", cv::IMREAD_GRAYSCALE);
    p.right = cv::imread(dir + "/image_3/" + name + ".png", cv::IMREAD_GRAYSCALE);
    if (p.left.empty() || p.right.empty()) continue;
    if (!readKittiRig(dir + "/calib/" + name + ".txt", p.left.cols, p.left.rows, height, p.rig)) continue;
    pairs.push_back(std::move(p));
  }
  return pairs;
}

inline bool sameBits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  const std::size_t row_bytes = static_cast<std::size_t>(a.cols) * a.elemSize();
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), row_bytes) != 0) return false;
  return true;
}

inline double iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double uni = a.area() + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

}  // namespace sg::test
