#pragma once
// ROS 2 topics stereoguard can publish (idl/ros2/ros2_types.idl): DDS topic
// names are "rt/" + the ROS topic name, type names package::msg::dds_::Type_.
//
//   ROS topic                             DDS topic                                 type
//   /stereoguard/left/image_annotated     rt/stereoguard/left/image_annotated       sensor_msgs/msg/Image
//   /stereoguard/left/camera_info         rt/stereoguard/left/camera_info           sensor_msgs/msg/CameraInfo
#include "dds/dds.hpp"
#include "ros2_types.h"

namespace sg::dds {

inline constexpr const char* kRos2AnnotatedImageTopic = "rt/stereoguard/left/image_annotated";
inline constexpr const char* kRos2CameraInfoTopic = "rt/stereoguard/left/camera_info";

template <>
struct TypeSupport<sensor_msgs_msg_dds__Image_> {
  static const dds_topic_descriptor_t* descriptor() { return &sensor_msgs_msg_dds__Image__desc; }
};
template <>
struct TypeSupport<sensor_msgs_msg_dds__CameraInfo_> {
  static const dds_topic_descriptor_t* descriptor() { return &sensor_msgs_msg_dds__CameraInfo__desc; }
};

}  // namespace sg::dds
