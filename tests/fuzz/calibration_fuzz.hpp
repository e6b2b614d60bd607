#pragma once
// What every calibration fuzz target does with a file it wrote: load it the
// way the sources do, and when that succeeds check what the rest of the
// pipeline relies on. Bad input must end in sg::InputError; any other
// exception escapes and libFuzzer reports it as a crash.
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "camera/calibration.hpp"
#include "camera/rectifier.hpp"
#include "config/errors.hpp"

namespace sg::fuzz {

[[noreturn]] inline void broken(const std::string& what) {
  std::fprintf(stderr, "invariant violated: %s\n", what.c_str());
  std::abort();
}

// `image_size` empty: the file alone, then a 64x48 image size as a frame source would set it.
inline void exerciseCalibration(const std::string& path, cv::Size image_size) {
  std::optional<StereoCalibration> calib;
  try {
    calib = loadCalibration(path, image_size);
    if (calib->image_size.empty()) setImageSize(*calib, cv::Size(64, 48), "fuzz image");
  } catch (const InputError&) {
    return;  // rejected with a message: the expected outcome for bad input
  }
  // Accepted: the rig must be usable by the vision core.
  try {
    calib->rig.validate("accepted calibration");
  } catch (const InputError& e) {
    broken(std::string("loadCalibration accepted an invalid rig: ") + e.what());
  }
  if (calib->rig.width != calib->image_size.width || calib->rig.height != calib->image_size.height) {
    broken("rig size differs from the calibration's image size");
  }
  // Remap tables cost 12 bytes per pixel: only rectify small images here.
  if (static_cast<double>(calib->image_size.area()) > 512.0 * 512.0) return;
  try {
    const Rectifier rectifier(*calib);
    const cv::Mat left(calib->image_size, CV_8UC1, cv::Scalar(100));
    const cv::Mat right(calib->image_size, CV_8UC1, cv::Scalar(50));
    cv::Mat left_out;
    cv::Mat right_out;
    rectifier.rectify(left, right, left_out, right_out);
    if (left_out.size() != cv::Size(rectifier.rig().width, rectifier.rig().height) || left_out.type() != CV_8UC1) {
      broken("rectified image does not have the rig's size");
    }
  } catch (const InputError&) {
    // A Rectifier may still refuse (named error); not a crash.
  }
}

// Image size hint from one byte: bit 7 set = a small size the file must match.
inline cv::Size sizeHint(std::uint8_t b) {
  if ((b & 0x80) == 0) return {};
  return {16 * (1 + (b & 0x0f)), 16 * (1 + ((b >> 4) & 0x07))};
}

}  // namespace sg::fuzz
