#pragma once
// ROS 2 topics stereoguard can publish (idl/ros2/ros2_types.idl): DDS topic
// names are "rt/" + the ROS topic name, type names package::msg::dds_::Type_.
//
//   ROS topic                             DDS topic                                 type
//   /stereoguard/left/image_annotated     rt/stereoguard/left/image_annotated       sensor_msgs/msg/Image
//   /stereoguard/left/camera_info         rt/stereoguard/left/camera_info           sensor_msgs/msg/CameraInfo
#include "dds/dds.hpp"
#include "dds/ros2_messages.hpp"
#include "ros2_types.h"

namespace sg::dds {

inline constexpr const char* kRos2AnnotatedImageTopic = "rt/stereoguard/left/image_annotated";
inline constexpr const char* kRos2CameraInfoTopic = "rt/stereoguard/left/camera_info";

// TypeSupport of Image_ and CameraInfo_: dds/ros2_messages.hpp.

}  // namespace sg::dds
