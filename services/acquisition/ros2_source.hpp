#pragma once
// Stereo images from a ROS 2 camera driver as a frame source:
//
//   ros2:LEFT_IMAGE,RIGHT_IMAGE[,LEFT_INFO,RIGHT_INFO]
//   e.g. ros2:/stereo/left/image_rect,/stereo/right/image_rect,/stereo/left/camera_info,/stereo/right/camera_info
//
// Subscribes to the DDS topics "rt/<ROS topic>" with the ROS 2 message types
// (sensor_msgs/msg/Image, CameraInfo; dds/ros2_messages.hpp) on the stage's
// own participant, so no ROS installation is needed: a driver running with
// rmw_cyclonedds_cpp on the same DDS domain is read directly. Left and right
// images are paired by header stamp (ros2.pair_tolerance_ms; 0 = identical
// stamps); mono8 is taken as it is, rgb8 and bgr8 are converted to grey,
// other encodings are rejected (an InputError per image, which acquisition
// counts as source_error). The images must be rectified (image_rect). The rig
// comes from the CameraInfo projection matrices when the info topics are
// given, else from --calib, else the nominal rig (with a warning).
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>

#include "config/params.hpp"
#include "dds/ros2_messages.hpp"
#include "dds/service.hpp"
#include "io/frame_source.hpp"

namespace sg {

struct Ros2SourceParams {
  double pair_tolerance_ms = 0.0;  // largest left/right stamp difference of a pair; 0 = identical stamps
  int pending_images = 8;          // unpaired images kept per side
  bool reliable = false;           // false: BEST_EFFORT reader (matches every ROS publisher, sensor-data profile)
  int history_depth = 5;           // KEEP_LAST depth of the image and info readers
  double camera_height_m = 0.0;    // mounting prior for the ground line; 0 = unknown
  double camera_pitch_rad = 0.0;   // with camera_height_m: optical axis tilt, positive down

  template <class V>
  void visit(V& v) {
    v.field("pair_tolerance_ms", pair_tolerance_ms, 0.0, 1000.0, "milliseconds",
            "largest left/right header stamp difference of a stereo pair (0 = identical stamps)");
    v.field("pending_images", pending_images, 1, 256, "images", "unpaired images kept per side");
    v.field("reliable", reliable, 0, 1, "",
            "RELIABLE readers (need a reliable publisher) instead of BEST_EFFORT (match any publisher)");
    v.field("history_depth", history_depth, 1, 100, "samples", "KEEP_LAST depth of the ROS 2 readers");
    v.field("camera_height_m", camera_height_m, 0.0, 100.0, "m",
            "camera height above the ground (mounting prior; 0 = unknown)");
    v.field("camera_pitch_rad", camera_pitch_rad, -1.5, 1.5, "rad", "camera pitch, positive = tilted down");
  }
};

// The four ROS topic names of a "ros2:" source spec (info topics may be empty).
struct Ros2SourceSpec {
  std::string left_image;
  std::string right_image;
  std::string left_info;
  std::string right_info;
};
// isRos2SourceSpec(): io/frame_source.hpp.
// Throws InputError naming what is wrong (not 2 or 4 names, an empty name).
Ros2SourceSpec parseRos2SourceSpec(const std::string& spec);

class Ros2StereoSource : public FrameSource {
 public:
  // `wait(until)` blocks until data may be available, a signal, or `until`
  // (the stage runtime's wait, which also keeps the metrics going);
  // `stopping()` ends next() with false. `calib_path` (optional) overrides
  // the CameraInfo rig.
  Ros2StereoSource(dds::ServiceRuntime& runtime, const Ros2SourceSpec& spec, const Ros2SourceParams& params,
                   const std::string& calib_path);

  // Blocks until a pair is complete (true), or the stage stops (false).
  // Throws InputError for one rejected image (bad encoding, size, data).
  bool next(StereoPair& pair) override;
  std::optional<std::size_t> size() const override { return std::nullopt; }
  std::string describe() const override;

  std::uint64_t unpairedImages() const { return pairer_.unpaired(); }

 private:
  void takeInfos();
  void takeImages(dds::Reader<sensor_msgs_msg_dds__Image_>& reader, bool left);
  using ImageReader = dds::TopicReader<sensor_msgs_msg_dds__Image_>;
  using InfoReader = dds::TopicReader<sensor_msgs_msg_dds__CameraInfo_>;
  // The rig for images of `size`: CameraInfo, --calib or nominal. Empty while CameraInfo is awaited.
  std::optional<StereoRig> rigFor(cv::Size size);

  dds::ServiceRuntime& runtime_;
  Ros2SourceSpec spec_;
  Ros2SourceParams params_;
  std::string calib_path_;
  ImageReader left_reader_;
  ImageReader right_reader_;
  std::optional<InfoReader> left_info_reader_;  // with the info topics of the spec
  std::optional<InfoReader> right_info_reader_;
  std::optional<dds::Ros2CameraInfo> left_info_;
  std::optional<dds::Ros2CameraInfo> right_info_;
  std::optional<StereoRig> fixed_rig_;  // from --calib or nominal, per image size
  cv::Size fixed_rig_size_;
  dds::StereoStampPairer pairer_;
  std::deque<std::string> errors_;      // rejected images, reported one per next()
  std::int64_t index_ = 0;
  bool warned_no_info_ = false;
};

}  // namespace sg
