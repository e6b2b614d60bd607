#pragma once
// Frame sources behind one interface, selected by a SPEC string:
//   synthetic[:SEED]   built-in scene generator with ground truth (the default input)
//   pairs:DIR          DIR/left/*, DIR/right/* (same file names), optional DIR/calib.yaml
//   kitti:DIR          DIR/image_2, DIR/image_3, DIR/calib/<frame>.txt, optional DIR/label_2
//   ros2:LEFT_IMAGE,RIGHT_IMAGE[,LEFT_INFO,RIGHT_INFO]
//                      ROS 2 camera topics; read by the acquisition stage only
//                      (services/acquisition/ros2_source.hpp), not by openFrameSource
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

// The form of a ros2: SPEC.
inline constexpr const char* kRos2SourceForm = "ros2:LEFT_IMAGE,RIGHT_IMAGE[,LEFT_INFO,RIGHT_INFO]";
// Every source kind, as help texts and errors list them.
inline constexpr const char* kFrameSourceKinds =
    "synthetic[:SEED], pairs:DIR, kitti:DIR or ros2:LEFT_IMAGE,RIGHT_IMAGE[,LEFT_INFO,RIGHT_INFO]";
// The help text of every --source option.
inline constexpr const char* kFrameSourceHelp =
    "frame source: synthetic[:SEED] (built-in scenes, the default), pairs:DIR (DIR/left, DIR/right, optional "
    "DIR/calib.yaml), kitti:DIR (image_2, image_3, calib) or ros2:LEFT_IMAGE,RIGHT_IMAGE[,LEFT_INFO,RIGHT_INFO] "
    "(ROS 2 camera topics; only where the acquisition stage reads the source: run, stereoguard-acquisition)";

inline constexpr const char* kSequenceHelp =
    "the frames are consecutive (a drive in KITTI layout): keep the previous frame's ground line and the tracks "
    "(default: synthetic scenes and KITTI object frames each stand alone; pairs:DIR and ros2: are one sequence)";

// True when `spec` starts with "ros2:".
bool isRos2SourceSpec(const std::string& spec);
// Throws InputError, listing every valid kind, when the kind of `spec` is none of them.
void checkFrameSourceKind(const std::string& spec);

// Opens a source from its SPEC. `calib_path`, when not empty, overrides the
// calibration the source would find itself. Throws InputError on a bad spec
// (an unknown kind, a missing directory, or a ros2: spec, which only the
// acquisition stage reads).
std::unique_ptr<FrameSource> openFrameSource(const std::string& spec, const std::string& calib_path = "");

}  // namespace sg
