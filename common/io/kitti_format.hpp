#pragma once
// The KITTI object-benchmark text formats: label_2/<frame>.txt (one object per
// line: type truncated occluded alpha left top right bottom h w l x y z
// rotation_y [score]) and calib/<frame>.txt (P0..P3, R0_rect, Tr_velo_to_cam,
// Tr_imu_to_velo), plus the disparity PNG of the KITTI stereo benchmark
// (uint16, disparity * 256, 0 = unknown).
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"
#include "io/stereo_pair.hpp"

namespace sg {

// Reads a label file. Empty lines are skipped. Throws InputError naming the
// file (and the line number and field) when the file cannot be read or a line
// is malformed.
std::vector<ObjectLabel> readKittiLabels(const std::string& path);
// Parses one label line; `what` names the line in error messages.
ObjectLabel parseKittiLabelLine(const std::string& line, const std::string& what);
// Writes one line per label (score appended when present). Throws InputError
// when the file cannot be written.
void writeKittiLabels(const std::string& path, const std::vector<ObjectLabel>& labels);
std::string formatKittiLabelLine(const ObjectLabel& label);

// Writes the rig as a KITTI object calibration file: P2 = [f 0 cx 0; 0 f cy 0; 0 0 1 0],
// P3 = P2 with P3[0][3] = -f * B (P0/P1 the same as P2/P3), R0_rect = I,
// Tr_velo_to_cam / Tr_imu_to_velo fixed KITTI-like axes swaps.
void writeKittiCalib(const std::string& path, const StereoRig& rig);

// Disparity (CV_32F, pixels, <= 0 or non-finite = unknown) as uint16 PNG, value = round(d * 256).
void writeKittiDisparity(const std::string& path, const cv::Mat& disparity);
// Reads such a PNG back as CV_32F (0 = unknown).
cv::Mat readKittiDisparity(const std::string& path);

// Exports one frame in the KITTI layout under `dir`: image_2/<id>.png (left),
// image_3/<id>.png (right), calib/<id>.txt, label_2/<id>.txt (the pair's
// labels) and, when the pair has ground truth, disp_2/<id>.png. Creates the
// folders. Throws InputError when a file cannot be written.
void writeKittiFrame(const std::string& dir, const StereoPair& pair);

}  // namespace sg
