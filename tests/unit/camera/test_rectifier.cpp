// Rectifier: a real rectified KITTI pair is turned into a raw pair with known
// camera matrices, distortion and small rotations; rectifying it again must
// bring corresponding points back onto the same image row.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/calibration.hpp"
#include "camera/rectifier.hpp"
#include "config/errors.hpp"
#include "temp_dir.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;

const std::string kData = SG_SHARED_DATA_DIR;

// The rectified pair and its rig (data/real/PROVENANCE.md).
constexpr double kFocal = 721.5377;
constexpr double kCx = 609.5593;
constexpr double kCy = 172.8540;
constexpr double kBaseline = 0.5327;

struct RawPair {
  cv::Mat left, right;
  cv::Mat k1, d1, k2, d2;  // raw cameras
  cv::Mat r1, r2;          // raw -> rectified rotations
  cv::Mat k_rect;
};

cv::Mat rectifiedCameraMatrix() { return (cv::Mat_<double>(3, 3) << kFocal, 0, kCx, 0, kFocal, kCy, 0, 0, 1); }

// Renders the raw view of a rectified image: each raw pixel looks up the
// rectified pixel it becomes (undistort, rotate, project).
cv::Mat toRaw(const cv::Mat& rectified, const cv::Mat& k, const cv::Mat& d, const cv::Mat& r, const cv::Mat& k_rect) {
  std::vector<cv::Point2f> raw_px;
  raw_px.reserve(rectified.total());
  for (int v = 0; v < rectified.rows; ++v) {
    for (int u = 0; u < rectified.cols; ++u) raw_px.emplace_back(static_cast<float>(u), static_cast<float>(v));
  }
  std::vector<cv::Point2f> rect_px;
  cv::undistortPoints(raw_px, rect_px, k, d, r, k_rect);
  cv::Mat map(rectified.size(), CV_32FC2, rect_px.data());
  cv::Mat raw;
  cv::remap(rectified, raw, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return raw;
}

RawPair makeRawPair() {
  RawPair p;
  const cv::Mat left = cv::imread(kData + "/kitti/kitti_rig/image_2/rcnn_demo.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(kData + "/kitti/kitti_rig/image_3/rcnn_demo.png", cv::IMREAD_GRAYSCALE);
  EXPECT_FALSE(left.empty());
  p.k_rect = rectifiedCameraMatrix();
  p.k1 = (cv::Mat_<double>(3, 3) << 700.0, 0, 615.0, 0, 703.0, 180.0, 0, 0, 1);
  p.k2 = (cv::Mat_<double>(3, 3) << 710.0, 0, 605.0, 0, 708.0, 168.0, 0, 0, 1);
  p.d1 = (cv::Mat_<double>(1, 5) << -0.06, 0.02, 0, 0, 0);
  p.d2 = (cv::Mat_<double>(1, 5) << -0.05, 0.015, 0, 0, 0);
  cv::Rodrigues(cv::Vec3d(0.010, -0.015, 0.008), p.r1);
  cv::Rodrigues(cv::Vec3d(-0.012, 0.010, -0.006), p.r2);
  p.left = toRaw(left, p.k1, p.d1, p.r1, p.k_rect);
  p.right = toRaw(right, p.k2, p.d2, p.r2, p.k_rect);
  return p;
}

struct RowAlignment {
  int matches = 0;
  double median_abs_dy = 0.0;
  double share_within_1px = 0.0;
};

// Matches textured left patches in the right image over +-25 rows and a
// disparity range; reports how far off the same row the matches are.
RowAlignment measureRowAlignment(const cv::Mat& left, const cv::Mat& right) {
  constexpr int kHalf = 10;
  constexpr int kRows = 25;
  constexpr int kMaxDisparity = 130;
  std::vector<double> dys;
  for (int v = 60; v + 60 < left.rows; v += 25) {
    for (int u = 200; u + 60 < left.cols; u += 40) {
      const cv::Rect patch(u - kHalf, v - kHalf, 2 * kHalf + 1, 2 * kHalf + 1);
      cv::Scalar mean;
      cv::Scalar stddev;
      cv::meanStdDev(left(patch), mean, stddev);
      if (stddev[0] < 20.0) continue;
      const cv::Rect search(u - kHalf - kMaxDisparity, v - kHalf - kRows, 2 * kHalf + 1 + kMaxDisparity + 4,
                            2 * kHalf + 1 + 2 * kRows);
      if ((search & cv::Rect(0, 0, right.cols, right.rows)) != search) continue;
      cv::Mat score;
      cv::matchTemplate(right(search), left(patch), score, cv::TM_CCOEFF_NORMED);
      double best = 0.0;
      cv::Point at;
      cv::minMaxLoc(score, nullptr, &best, nullptr, &at);
      if (best < 0.9) continue;
      dys.push_back(std::abs(at.y - kRows));
    }
  }
  RowAlignment out;
  out.matches = static_cast<int>(dys.size());
  if (dys.empty()) return out;
  std::sort(dys.begin(), dys.end());
  out.median_abs_dy = dys[dys.size() / 2];
  out.share_within_1px =
      static_cast<double>(std::count_if(dys.begin(), dys.end(), [](double dy) { return dy <= 1.0; })) /
      static_cast<double>(dys.size());
  return out;
}

class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("sg_rectifier") {}
};

std::string rosMatrix(const char* key, const cv::Mat& m) {
  std::ostringstream out;
  out.precision(17);
  out << key << ":\n  rows: " << m.rows << "\n  cols: " << m.cols << "\n  data: [";
  for (int i = 0; i < static_cast<int>(m.total()); ++i) out << (i ? ", " : "") << m.at<double>(i);
  out << "]\n";
  return out.str();
}

std::string rosCameraInfo(cv::Size size, const cv::Mat& k, const cv::Mat& d, const cv::Mat& r, const cv::Mat& p) {
  return "image_width: " + std::to_string(size.width) + "\nimage_height: " + std::to_string(size.height) +
         "\ndistortion_model: plumb_bob\n" + rosMatrix("camera_matrix", k) + rosMatrix("distortion_coefficients", d) +
         rosMatrix("rectification_matrix", r) + rosMatrix("projection_matrix", p);
}

TEST(Rectifier, RawPairIsMisalignedBeforeRectification) {
  const RawPair raw = makeRawPair();
  const RowAlignment before = measureRowAlignment(raw.left, raw.right);
  // Guards the measurement itself: it must see the misalignment it is meant to catch.
  EXPECT_TRUE(before.matches < 20 || before.median_abs_dy >= 3.0)
      << before.matches << " matches, median |dy| " << before.median_abs_dy;
  const cv::Mat left = cv::imread(kData + "/kitti/kitti_rig/image_2/rcnn_demo.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(kData + "/kitti/kitti_rig/image_3/rcnn_demo.png", cv::IMREAD_GRAYSCALE);
  const RowAlignment original = measureRowAlignment(left, right);
  EXPECT_GE(original.matches, 30);
  EXPECT_LE(original.median_abs_dy, 0.0);
  EXPECT_GE(original.share_within_1px, 0.8);
}

TEST(Rectifier, OpenCvRawCalibrationRestoresRowAlignment) {
  const RawPair raw = makeRawPair();
  // OpenCV convention: X_right = R X_left + T.
  const cv::Mat r = raw.r2.t() * raw.r1;
  const cv::Mat t = -raw.r2.t() * (cv::Mat_<double>(3, 1) << kBaseline, 0.0, 0.0);
  TempDir dir;
  const std::string path = dir.file("stereo.yaml");
  {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    fs << "image_width" << raw.left.cols << "image_height" << raw.left.rows;
    fs << "M1" << raw.k1 << "D1" << raw.d1 << "M2" << raw.k2 << "D2" << raw.d2 << "R" << r << "T" << t;
  }
  const StereoCalibration calib = loadCalibration(path);
  ASSERT_TRUE(calib.needs_rectification);
  EXPECT_NEAR(calib.rig.baseline_m, kBaseline, 1e-9);
  const Rectifier rectifier(calib);
  EXPECT_FALSE(rectifier.passThrough());
  cv::Mat left_out;
  cv::Mat right_out;
  rectifier.rectify(raw.left, raw.right, left_out, right_out);
  ASSERT_EQ(left_out.size(), raw.left.size());
  EXPECT_EQ(left_out.type(), CV_8UC1);
  const RowAlignment after = measureRowAlignment(left_out, right_out);
  EXPECT_GE(after.matches, 30);
  EXPECT_LE(after.median_abs_dy, 0.0);
  // The original rectified pair scores about 0.88 here: the rest are false
  // matches on repeated texture and occlusions, not row offsets.
  EXPECT_GE(after.share_within_1px, 0.8);
}

TEST(Rectifier, RosCameraInfoReproducesTheRectifiedImages) {
  const RawPair raw = makeRawPair();
  cv::Mat p1 = cv::Mat::zeros(3, 4, CV_64F);
  raw.k_rect.copyTo(p1.colRange(0, 3));
  cv::Mat p2 = p1.clone();
  p2.at<double>(0, 3) = -kFocal * kBaseline;
  TempDir dir;
  const std::string left_yaml = dir.file("left.yaml");
  const std::string right_yaml = dir.file("right.yaml");
  std::ofstream(left_yaml) << rosCameraInfo(raw.left.size(), raw.k1, raw.d1, raw.r1, p1);
  std::ofstream(right_yaml) << rosCameraInfo(raw.left.size(), raw.k2, raw.d2, raw.r2, p2);
  const StereoCalibration calib = loadCalibration(left_yaml + "," + right_yaml);
  ASSERT_TRUE(calib.needs_rectification);
  EXPECT_NEAR(calib.rig.focal_px, kFocal, 1e-9);
  EXPECT_NEAR(calib.rig.baseline_m, kBaseline, 1e-9);
  const Rectifier rectifier(calib);
  cv::Mat left_out;
  cv::Mat right_out;
  rectifier.rectify(raw.left, raw.right, left_out, right_out);
  const cv::Mat original = cv::imread(kData + "/kitti/kitti_rig/image_2/rcnn_demo.png", cv::IMREAD_GRAYSCALE);
  // Interior only: the raw view does not cover the rectified image's borders.
  const cv::Rect interior(80, 40, original.cols - 160, original.rows - 80);
  cv::Mat diff;
  cv::absdiff(left_out(interior), original(interior), diff);
  EXPECT_LT(cv::mean(diff)[0], 4.0);  // two bilinear resamplings
  const RowAlignment after = measureRowAlignment(left_out, right_out);
  EXPECT_GE(after.matches, 30);
  EXPECT_LE(after.median_abs_dy, 0.0);
  EXPECT_GE(after.share_within_1px, 0.8);
}

TEST(Rectifier, RectifiedCalibrationPassesImagesThroughWithoutCopy) {
  StereoCalibration calib = loadCalibration(kData + "/kitti/kitti_rig/calib/rcnn_demo.txt", {1242, 375});
  const Rectifier rectifier(calib);
  EXPECT_TRUE(rectifier.passThrough());
  const cv::Mat left(375, 1242, CV_8UC1, cv::Scalar(3));
  const cv::Mat right(375, 1242, CV_8UC1, cv::Scalar(4));
  cv::Mat left_out;
  cv::Mat right_out;
  rectifier.rectify(left, right, left_out, right_out);
  EXPECT_EQ(left_out.data, left.data);
  EXPECT_EQ(right_out.data, right.data);
  EXPECT_DOUBLE_EQ(rectifier.rig().focal_px, kFocal);
}

TEST(Rectifier, ImagesOfAnotherSizeRejected) {
  StereoCalibration calib = loadCalibration(kData + "/kitti/kitti_rig/calib/rcnn_demo.txt", {1242, 375});
  const Rectifier rectifier(calib);
  const cv::Mat small(100, 200, CV_8UC1, cv::Scalar(0));
  const cv::Mat other(100, 201, CV_8UC1, cv::Scalar(0));
  cv::Mat a;
  cv::Mat b;
  EXPECT_THROW(rectifier.rectify(small, small, a, b), InputError);
  EXPECT_THROW(rectifier.rectify(small, other, a, b), InputError);
}

TEST(Rectifier, RawCalibrationWithoutImageSizeRejected) {
  StereoCalibration calib;
  calib.needs_rectification = true;
  calib.source = "stereo.yaml";
  EXPECT_THROW(Rectifier{calib}, InputError);
}

}  // namespace
}  // namespace sg
