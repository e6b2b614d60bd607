#pragma once
// Stereo calibration readers. One entry point, loadCalibration(), detects the
// format and yields the rectified rig the vision core works with, plus what a
// Rectifier needs when the images still have to be rectified.
//
// Formats:
//   KITTI text       "P2: 12 numbers" / "P3: ..." (object and odometry calib.txt),
//                    "P_rect_02:" / "P_rect_03:" (raw-data calib_cam_to_cam.txt),
//                    "P1:" / "P2:" without P0/P3 (Karlsruhe sequences). Already rectified:
//                    f = P[0][0], cx = P[0][2], cy = P[1][2], B = (Pl[0][3] - Pr[0][3]) / f.
//   OpenCV YAML/XML  (cv::FileStorage, "%YAML:1.0" or XML): M1 D1 M2 D2 R T (raw pair,
//                    rectified here with cv::stereoRectify, alpha 0 = only valid pixels) and/or
//                    P1 P2 (already rectified projections, P2[0][3] = -f B).
//                    Optional image_width, image_height, camera_height_m, camera_pitch_rad.
//   ROS camera_info  two files given as "left.yaml,right.yaml" (image_width, image_height,
//                    camera_matrix, distortion_coefficients, rectification_matrix,
//                    projection_matrix); rig from the projection matrices, right P[0][3] = -f B.
// Mounting prior: a file `camera_height_m` (one number, metres) beside the calibration
// file (for a KITTI layout's DIR/calib/NNNNNN.txt, also in DIR), or the YAML keys
// camera_height_m / camera_pitch_rad.
//
// Every malformed file throws InputError naming the file and the field.
#include <string>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"

namespace sg {

struct StereoCalibration {
  // The rectified rig. width/height are 0 while the image size is unknown
  // (KITTI text files do not carry it); setImageSize() fills them in.
  StereoRig rig;
  // True when the images must go through a Rectifier first (raw OpenCV or
  // ROS calibration with distortion or a rectifying rotation).
  bool needs_rectification = false;
  // Raw calibration (CV_64F) when known: camera matrices, distortion,
  // rotation and translation (metres) from the left to the right camera.
  cv::Mat M1, D1, M2, D2, R, T;
  // Rectification (CV_64F) when needs_rectification: rotations R1/R2 (3x3) and
  // new projections P1/P2 (3x4) for cv::initUndistortRectifyMap.
  cv::Mat R1, R2, P1, P2;
  // Size of the (raw) images this calibration belongs to; empty when unknown.
  cv::Size image_size;
  // Where the calibration came from (file path(s), or "nominal").
  std::string source;
};

// Reads a calibration in any supported format. `image_size`, when not empty,
// is the size of the images it will be used with (needed to rectify raw
// calibrations whose file carries no size; must agree with the file otherwise).
StereoCalibration loadCalibration(const std::string& path, cv::Size image_size = {});

// Sets the image size once the first image is known: fills rig.width/height and
// validates the rig. Throws InputError when the calibration was made for a
// different size, or when a raw calibration cannot be rectified. `what` names
// the image in messages.
void setImageSize(StereoCalibration& calib, cv::Size image_size, const std::string& what);

// A stand-in rig for image pairs without calibration, the same as the default
// rig of `stereoguard segment`: the KITTI car's focal length 721.5 px and
// baseline 0.54 m, principal point at the image centre, camera 1.65 m above
// the ground, no pitch. Offsets and features are right; metric distances are
// only as right as the guess.
StereoCalibration nominalCalibration(cv::Size image_size);

// Reads a one-number file such as `camera_height_m`. Throws InputError naming
// the file when it does not hold exactly one finite number.
double readNumberFile(const std::string& path);

// An image size as error messages print it: "WxH".
std::string sizeText(cv::Size size);

}  // namespace sg
