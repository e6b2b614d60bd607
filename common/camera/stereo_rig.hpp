#pragma once
// Rectified stereo rig: the only camera model the vision core sees.
//
// Coordinates: left camera frame, x right, y down, z forward (metres).
// Offsets are disparities in pixels, offset = f * B / Z.
#include <optional>
#include <string>

#include <Eigen/Core>

namespace sg {

// How the rig is mounted on the vehicle: a prior for the ground line when
// the ground texture is too weak to measure it.
struct Mounting {
  double height_m = 1.65;   // optical centre above the ground plane (metres)
  double pitch_rad = 0.0;   // rotation about x; positive = optical axis tilted down
};

struct StereoRig {
  double focal_px = 0.0;    // focal length of the rectified pair (pixels)
  double cx_px = 0.0;       // principal point, column (pixels)
  double cy_px = 0.0;       // principal point, row (pixels)
  double baseline_m = 0.0;  // distance between the optical centres (metres), > 0
  int width = 0;            // image size of the rectified pair (pixels)
  int height = 0;
  std::optional<Mounting> mounting;

  // Throws InputError naming the field when a value is NaN, non-positive or absurd.
  // `what` prefixes the message (e.g. the calibration file name).
  void validate(const std::string& what = "stereo rig") const;

  double depthFromOffset(double offset_px) const { return focal_px * baseline_m / offset_px; }
  double offsetFromDepth(double depth_m) const { return focal_px * baseline_m / depth_m; }

  // 3-D point (left camera frame) of pixel (u, v) seen at the given offset.
  Eigen::Vector3d pointFromPixel(double u, double v, double offset_px) const;

  // Flat-ground offset at image row v implied by the mounting prior:
  // d(v) = B / h * ((v - cy) cos(pitch) + f sin(pitch)). <= 0 above the horizon.
  // Requires `mounting`.
  double groundOffsetPrior(double row) const;
  // Its inverse: the image row where the flat ground of the mounting prior has `offset_px`
  // (0: the horizon); NaN without a mounting.
  double groundRowPrior(double offset_px) const;
};

}  // namespace sg
