#pragma once
// kitti:DIR — the KITTI object layout: DIR/image_2/<id>.png (left),
// DIR/image_3/<id>.png (right), DIR/calib/<id>.txt (per frame, P2/P3),
// optional DIR/label_2/<id>.txt (object labels; when the folder exists every
// frame must have its file), optional DIR/camera_height_m (mounting prior).
// Frames in id order.
#include <string>
#include <vector>

#include "io/frame_source.hpp"
#include "io/stereo_file_loader.hpp"

namespace sg {

class KittiSource final : public FrameSource {
 public:
  // Throws InputError when DIR/image_2 is missing or empty, DIR/camera_height_m
  // or a given calibration is malformed.
  KittiSource(const std::string& dir, const std::string& calib_path);

  bool next(StereoPair& pair) override;
  std::optional<std::size_t> size() const override { return names_.size(); }
  std::string describe() const override;

 private:
  std::string dir_;
  std::vector<std::string> names_;  // file names in image_2
  std::string calib_path_;          // override for every frame, or empty
  bool has_labels_ = false;
  std::size_t position_ = 0;
  StereoFileLoader loader_;
};

}  // namespace sg
