#pragma once
// pairs:DIR — DIR/left/* and DIR/right/* with the same file names (png, pgm,
// ppm, jpg, bmp), in name order; when DIR/right has no file of the same name,
// "left" -> "right" and "im0" -> "im1" in the name are tried. Calibration, first found:
//   the calib_path given by the caller; DIR/calib.yaml (.yml, .xml, .txt, any
//   format loadCalibration reads); DIR/calib/<stem>.txt per frame, or the only
//   file in DIR/calib/; otherwise the nominal rig (nominalCalibration).
// DIR/camera_height_m gives the mounting prior when the calibration has none.
#include <string>
#include <vector>

#include "io/frame_source.hpp"
#include "io/stereo_file_loader.hpp"

namespace sg {

class PairsSource final : public FrameSource {
 public:
  // Throws InputError when DIR/left is missing or empty, or a given calibration is malformed.
  PairsSource(const std::string& dir, const std::string& calib_path);

  bool next(StereoPair& pair) override;
  std::optional<std::size_t> size() const override { return names_.size(); }
  std::string describe() const override;

 private:
  std::string calibrationFor(const std::string& name) const;
  std::string rightImageFor(const std::string& name) const;

  std::string dir_;
  std::vector<std::string> names_;
  std::string calib_path_;  // one calibration for every frame, or empty
  std::string calib_dir_;   // DIR/calib when calibrations are per frame
  std::size_t position_ = 0;
  StereoFileLoader loader_;
};

}  // namespace sg
