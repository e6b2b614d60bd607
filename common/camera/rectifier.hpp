#pragma once
// Rectification of raw stereo pairs: undistorts both images and rotates them so
// that epipolar lines become image rows (the vision core correlates rows).
// The remap tables are computed once, at construction; rectify() only remaps.
// A calibration that is already rectified passes the images through unchanged
// (no copy).
#include <opencv2/core.hpp>

#include "camera/calibration.hpp"
#include "camera/stereo_rig.hpp"

namespace sg {

class Rectifier {
 public:
  // `calib` must know its image size when it needs rectification (see
  // setImageSize); throws InputError otherwise.
  explicit Rectifier(StereoCalibration calib);

  // left/right: raw images of the calibration's size (any depth/channels
  // cv::remap accepts). The outputs may alias nothing but their own buffers;
  // pass-through assigns the input headers. Throws InputError on a size mismatch.
  void rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat& left_out, cv::Mat& right_out) const;

  const StereoRig& rig() const { return calib_.rig; }
  const StereoCalibration& calibration() const { return calib_; }
  bool passThrough() const { return !calib_.needs_rectification; }

 private:
  StereoCalibration calib_;
  // Fixed-point remap tables (CV_16SC2 + CV_16UC1) per camera.
  cv::Mat left_map1_, left_map2_, right_map1_, right_map2_;
};

}  // namespace sg
