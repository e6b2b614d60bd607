#include "camera/rectifier.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"

namespace sg {

Rectifier::Rectifier(StereoCalibration calib) : calib_(std::move(calib)) {
  if (!calib_.needs_rectification) return;
  if (calib_.image_size.empty()) {
    throw InputError(calib_.source + ": the image size is needed to rectify (image_width/image_height)");
  }
  if (calib_.P1.empty()) setImageSize(calib_, calib_.image_size, calib_.source);
  cv::initUndistortRectifyMap(calib_.M1, calib_.D1, calib_.R1, calib_.P1, calib_.image_size, CV_16SC2, left_map1_,
                              left_map2_);
  cv::initUndistortRectifyMap(calib_.M2, calib_.D2, calib_.R2, calib_.P2, calib_.image_size, CV_16SC2, right_map1_,
                              right_map2_);
}

void Rectifier::rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat& left_out, cv::Mat& right_out) const {
  if (left.size() != right.size()) {
    throw InputError("rectify: left image is " + sizeText(left.size()) + ", right image is " +
                     sizeText(right.size()));
  }
  if (!calib_.image_size.empty() && left.size() != calib_.image_size) {
    throw InputError("rectify: images are " + sizeText(left.size()) + ", the calibration (" + calib_.source +
                     ") is for " + sizeText(calib_.image_size));
  }
  if (passThrough()) {
    left_out = left;
    right_out = right;
    return;
  }
  cv::remap(left, left_out, left_map1_, left_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::remap(right, right_out, right_map1_, right_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
}

}  // namespace sg
