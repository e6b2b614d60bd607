#pragma once
// What a frame source yields: a rectified mono8 stereo pair, its rig and,
// when known, ground truth (synthetic scenes) or labels (KITTI label_2).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"

namespace sg {

// One object in the KITTI object label format (label_2/<frame>.txt):
// type truncated occluded alpha left top right bottom h w l x y z rotation_y [score].
struct ObjectLabel {
  std::string type = "DontCare";          // Pedestrian, Cyclist, Person_sitting, Car, Misc, DontCare, ...
  double truncation = 0.0;                // 0 (fully visible) .. 1 (leaving the image)
  int occlusion = 0;                      // 0 visible, 1 partly, 2 largely occluded, 3 unknown
  double alpha = 0.0;                     // observation angle (radians)
  std::array<double, 4> box{};            // left, top, right, bottom (pixels, left image)
  std::array<double, 3> dimensions_m{};   // height, width, length (metres)
  std::array<double, 3> location_m{};     // bottom centre in the left camera frame (metres)
  double rotation_y = 0.0;                // yaw about the camera y axis (radians)
  std::optional<double> score;            // present in detection files only
};

// Ground truth of a synthetic frame, everything in the left image.
struct SceneTruth {
  cv::Mat disparity;        // CV_32F, true offset per pixel (pixels); 0 where at infinity
  cv::Mat object_id;        // CV_16U: 0 ground, 1 background, 2 + index into `objects`
  std::vector<float> ground_offset_per_row;  // true ground offset per row; NaN where no ground is visible
  float background_offset = 0.0f;           // offset of the background above the horizon (pixels)
  int horizon_row = 0;                      // first row (from the top) that shows ground
  std::vector<ObjectLabel> objects;         // class, 3-D position, image box of every object
  std::vector<int> object_visible_px;       // visible pixel count per object (same order)
};

struct StereoPair {
  std::string id;           // frame name, e.g. "000042" or the file stem
  std::int64_t index = 0;   // position in the source, from 0
  // The frame does not continue the one before it (unrelated scenes: synthetic, KITTI object
  // frames; the first frame of a sequence): no ground line or track may carry over.
  bool scene_start = true;
  cv::Mat left;             // CV_8UC1, rectified
  cv::Mat right;            // CV_8UC1, rectified, same size as left
  StereoRig rig;
  std::optional<SceneTruth> truth;    // synthetic scenes
  std::vector<ObjectLabel> labels;    // KITTI label_2 when present, else the truth objects
};

}  // namespace sg
