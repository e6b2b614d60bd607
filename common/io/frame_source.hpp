#pragma once
// Frame sources behind one interface, selected by a SPEC string:
//   synthetic[:SEED]   built-in scene generator with ground truth (the default input)
//   pairs:DIR          DIR/left/*, DIR/right/* (same file names), optional DIR/calib.yaml
//   kitti:DIR          DIR/image_2, DIR/image_3, DIR/calib/<frame>.txt, optional DIR/label_2
#include <memory>
#include <optional>
#include <string>

#include "io/stereo_pair.hpp"

namespace sg {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Fills `pair` with the next frame; false at the end of the source.
  // A bad frame (corrupt image, size mismatch) throws InputError naming the
  // file; the source stays usable and the next call moves on.
  virtual bool next(StereoPair& pair) = 0;
  // Number of frames, when finite and known.
  virtual std::optional<std::size_t> size() const = 0;
  virtual std::string describe() const = 0;
};

// Opens a source from its SPEC. `calib_path`, when not empty, overrides the
// calibration the source would find itself. Throws InputError on a bad spec.
std::unique_ptr<FrameSource> openFrameSource(const std::string& spec, const std::string& calib_path = "");

}  // namespace sg
