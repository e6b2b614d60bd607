#pragma once
// ROS 2 sensor messages (idl/ros2/ros2_types.idl, the types rmw_cyclonedds
// puts on the wire) <-> core types, for stereo images coming from a ROS 2
// camera driver and for what stereoguard publishes to ROS 2.
//
//   ROS topic /camera/left/image_rect  ==  DDS topic "rt/camera/left/image_rect"
//
// Reading validates like dds/conversions.hpp: a malformed message throws
// sg::InputError naming the topic, the field and the value.
#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"
#include "dds/dds.hpp"
#include "ros2_types.h"

namespace sg::dds {

template <>
struct TypeSupport<sensor_msgs_msg_dds__Image_> {
  static const dds_topic_descriptor_t* descriptor() { return &sensor_msgs_msg_dds__Image__desc; }
};
template <>
struct TypeSupport<sensor_msgs_msg_dds__CameraInfo_> {
  static const dds_topic_descriptor_t* descriptor() { return &sensor_msgs_msg_dds__CameraInfo__desc; }
};

// "/camera/left/image_rect" or "camera/left/image_rect" -> "rt/camera/left/image_rect";
// a name that already starts with "rt/" is kept. Throws InputError for an empty name.
std::string ros2DdsTopicName(const std::string& ros_topic);

// QoS of a ROS 2 endpoint: VOLATILE (a TRANSIENT_LOCAL reader would not match
// every ROS publisher), KEEP_LAST `history_depth`, RELIABLE or BEST_EFFORT.
QosParams ros2Qos(bool reliable, int history_depth);

// builtin_interfaces/Time -> nanoseconds since the epoch, and back.
std::int64_t ros2StampNs(const builtin_interfaces_msg_dds__Time_& stamp);
void fillRos2Stamp(std::int64_t ns, builtin_interfaces_msg_dds__Time_& out);

// Encodings a stereo source accepts: mono8 as it is, rgb8 / bgr8 converted to
// grey (the same weights as cv::cvtColor). Anything else (mono16, bayer, yuv,
// compressed, ...) is rejected.
bool isSupportedRos2Encoding(const std::string& encoding);

// Copies a sensor_msgs/Image into a continuous CV_8UC1 image. Validates size
// (1..16384), step (>= width x channels), data length (>= step x (height - 1)
// + width x channels) and the encoding; `what` names the topic in messages.
void readRos2ImageMono(const sensor_msgs_msg_dds__Image_& in, cv::Mat& out, const std::string& what);

// What a stereo source needs of a sensor_msgs/CameraInfo.
struct Ros2CameraInfo {
  int width = 0;
  int height = 0;
  std::array<double, 12> p{};  // projection matrix, row-major 3x4
};
Ros2CameraInfo readRos2CameraInfo(const sensor_msgs_msg_dds__CameraInfo_& in, const std::string& what);

// Rectified rig from the projection matrices of a rectified pair (the ROS
// stereo convention: P_left = [f 0 cx 0; 0 f cy 0; 0 0 1 0],
// P_right[0][3] = Tx = -f * B). Both must describe the same size and focal
// length. Throws InputError naming the field.
StereoRig rigFromRos2CameraInfo(const Ros2CameraInfo& left, const Ros2CameraInfo& right, const std::string& what);

// Pairs left and right images by header stamp: exact (tolerance 0) or within
// `tolerance_ns`. Images arrive in stamp order per side (one driver per
// camera, in order); a pair is the oldest left image with a right image close
// enough. Images older than a pair just made can never be paired any more and
// are discarded, as are the oldest when more than `capacity` wait on one side;
// both are counted in unpaired().
class StereoStampPairer {
 public:
  struct Image {
    std::int64_t stamp_ns = 0;
    cv::Mat mono;  // CV_8UC1
  };
  struct Pair {
    Image left;
    Image right;
  };

  StereoStampPairer(std::int64_t tolerance_ns, std::size_t capacity);
  void addLeft(Image image);
  void addRight(Image image);
  // The next pair, when one is complete.
  std::optional<Pair> next();
  std::uint64_t unpaired() const { return unpaired_; }
  std::size_t waitingLeft() const { return left_.size(); }
  std::size_t waitingRight() const { return right_.size(); }

 private:
  void add(std::deque<Image>& side, Image image);

  std::int64_t tolerance_ns_;
  std::size_t capacity_;
  std::deque<Image> left_;
  std::deque<Image> right_;
  std::uint64_t unpaired_ = 0;
};

}  // namespace sg::dds
