#pragma once
// Shared helpers of the vision tests: KITTI-layout real pairs and comparisons.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "camera/stereo_rig.hpp"
#include "vision/segmentation_types.hpp"

namespace sg::test {

struct RealPair {
  std::string name;
  cv::Mat left, right;
  StereoRig rig;
};

// The numbers of the first row of a KITTI calibration file that starts with `key:` (none when
// the file or the row is missing).
inline std::vector<double> kittiCalibRow(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string k;
    ls >> k;
    if (k != key + ":") continue;
    std::vector<double> row;
    double v;
    while (ls >> v) row.push_back(v);
    return row;
  }
  return {};
}

// Reads calib/<frame>.txt (P2/P3 rows): f = P2[0][0], baseline = (P2[0][3] - P3[0][3]) / f.
inline bool readKittiRig(const std::string& path, int width, int height, double camera_height_m, StereoRig& rig) {
  const std::vector<double> p2 = kittiCalibRow(path, "P2"), p3 = kittiCalibRow(path, "P3");
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

// True disparities over the visible pixels of object `index` of a synthetic scene
// (object_id 2 + index): 10th percentile, median and 90th percentile, NaN when none is
// visible. A near person's visible surface is nearer than the centre of its label, by up to
// 2 pixels at 6 m; a vehicle or a wall seen at an angle spans many offsets.
struct DisparitySpread {
  double low = std::nan("");
  double median = std::nan("");
  double high = std::nan("");
};
inline DisparitySpread visibleDisparities(const cv::Mat& disparity, const cv::Mat& object_id, std::size_t index) {
  std::vector<float> values;
  const int id = 2 + static_cast<int>(index);
  for (int y = 0; y < object_id.rows; ++y)
    for (int x = 0; x < object_id.cols; ++x)
      if (object_id.at<std::uint16_t>(y, x) == id) values.push_back(disparity.at<float>(y, x));
  DisparitySpread s;
  if (values.empty()) return s;
  auto at = [&](double q) {
    const auto it = values.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), it, values.end());
    return static_cast<double>(*it);
  };
  s.low = at(0.1);
  s.median = at(0.5);
  s.high = at(0.9);
  return s;
}

// The obstacle acceptance criterion for one object: the cluster's box has IoU >= 0.5
// with the object's box, and its offset (or the offset range of a grown cluster) is
// within +-1 of the object's centre offset or of the offsets its visible surface shows
// (10th to 90th percentile: the face a cluster was found on may be any of them).
inline bool clusterFindsObject(const ObstacleCluster& c, const cv::Rect& box, double centre_offset,
                               const DisparitySpread& surface) {
  const double lo = std::min<double>(c.offset_px, c.min_offset_px) - 1.0;
  const double hi = std::max<double>(c.offset_px, c.max_offset_px) + 1.0;
  const bool centre = centre_offset >= lo && centre_offset <= hi;
  const bool visible = std::isfinite(surface.low) && surface.low <= hi && surface.high >= lo;
  return iou(c.box, box) >= 0.5 && (centre || visible);
}

// Left pixels the right camera sees too (1) or not (0): a left-right occlusion test on the true
// disparities. A pixel is hidden when its right-image column lies outside the image or a left
// pixel of the same row with a larger disparity (by more than 0.75) lands on that column.
inline cv::Mat seenByTheRightCamera(const cv::Mat& disparity) {
  cv::Mat seen(disparity.size(), CV_8UC1, cv::Scalar(1));
  std::vector<float> nearest(static_cast<std::size_t>(disparity.cols));
  for (int y = 0; y < disparity.rows; ++y) {
    std::fill(nearest.begin(), nearest.end(), -1.0f);
    const float* d = disparity.ptr<float>(y);
    std::uint8_t* s = seen.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const int xr = static_cast<int>(std::lround(x - d[x]));
      if (xr < 0 || xr >= disparity.cols) {
        s[x] = 0;
        continue;
      }
      nearest[static_cast<std::size_t>(xr)] = std::max(nearest[static_cast<std::size_t>(xr)], d[x]);
    }
    for (int x = 0; x < disparity.cols; ++x) {
      const int xr = static_cast<int>(std::lround(x - d[x]));
      if (xr >= 0 && xr < disparity.cols && nearest[static_cast<std::size_t>(xr)] > d[x] + 0.75f) s[x] = 0;
    }
  }
  return seen;
}

// Share of object `index`'s visible (left) pixels that the right camera sees too (0 when none is
// visible).
inline double shareSeenByTheRightCamera(const cv::Mat& seen, const cv::Mat& object_id, std::size_t index) {
  const int id = 2 + static_cast<int>(index);
  int visible = 0, both = 0;
  for (int y = 0; y < object_id.rows; ++y)
    for (int x = 0; x < object_id.cols; ++x) {
      if (object_id.at<std::uint16_t>(y, x) != id) continue;
      ++visible;
      both += seen.at<std::uint8_t>(y, x);
    }
  return visible > 0 ? static_cast<double>(both) / visible : 0.0;
}

}  // namespace sg::test
