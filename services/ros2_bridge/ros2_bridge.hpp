#pragma once
// stereoguard-ros2-bridge: republishes the pipeline for ROS 2 nodes (no ROS
// installation needed): the left image with the detected people drawn on it
// as sensor_msgs/Image and the rectified rig as sensor_msgs/CameraInfo
// (ros2_topics.hpp). Subscribes to stereo_frame and human_detections and
// joins them by frame id; a frame whose detections do not come within
// join_timeout_ms is published without boxes.
#include <chrono>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dds/conversions.hpp"
#include "dds/service.hpp"
#include "ros2_topics.hpp"

namespace sg {

struct Ros2OutputParams {
  bool publish = false;        // the switch: nothing is published to ROS 2 unless true
  bool colour = true;          // bgr8 with coloured boxes; false: mono8 with white boxes
  int join_timeout_ms = 500;   // wait this long for a frame's detections
  int pending_frames = 16;     // frames waiting for their detections
  bool reliable = false;       // ROS "sensor data" profile: best effort, depth 5
  int history_depth = 5;

  template <class V>
  void visit(V& v) {
    v.field("publish", publish, 0, 1, "", "publish the annotated left image and CameraInfo to ROS 2 topics");
    v.field("colour", colour, 0, 1, "", "bgr8 with coloured boxes (true) or mono8 with white boxes (false)");
    v.field("join_timeout_ms", join_timeout_ms, 0, 10000, "milliseconds",
            "how long a frame waits for its detections before it is published without boxes");
    v.field("pending_frames", pending_frames, 1, 256, "frames", "frames waiting for their detections");
    v.field("reliable", reliable, 0, 1, "",
            "RELIABLE writers (ROS default profile) instead of BEST_EFFORT (ROS sensor-data profile)");
    v.field("history_depth", history_depth, 1, 100, "samples", "KEEP_LAST depth of the ROS 2 writers");
  }
};

struct Ros2BridgeParams {
  dds::TransportParams transport;
  Ros2OutputParams ros2;

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("ros2", ros2);
  }
  void validate() const {
    transport.validate();
    validateParams(*this, "ros2_bridge");
  }
};

// ROS 2 messages from the core types (exposed for tests). `image` is CV_8UC1
// or CV_8UC3 (bgr8); the message borrows `image` and `frame_id`.
void fillRos2Image(const cv::Mat& image, std::int64_t stamp_ns, const char* frame_id,
                   sensor_msgs_msg_dds__Image_& out);
// Rectified left camera: K from focal/principal point, R identity, P = [K | 0], no distortion.
void fillRos2CameraInfo(const StereoRig& rig, std::int64_t stamp_ns, const char* frame_id,
                        sensor_msgs_msg_dds__CameraInfo_& out);
// Left image with the detections drawn on it (bgr8 when `colour`, else mono8).
cv::Mat annotateLeft(const cv::Mat& left, const std::vector<HumanDetection>& detections, bool colour);

class Ros2Bridge {
 public:
  Ros2Bridge(dds::ServiceRuntime& runtime, const Ros2BridgeParams& params);
  // Until a signal, the end of the stream, or `frames` published images (0 = no limit).
  void run(std::uint64_t frames);

 private:
  struct Pending {
    dds::StereoFrameData frame;
    std::chrono::steady_clock::time_point arrived;
  };
  void publish(const dds::StereoFrameData& frame, const std::vector<HumanDetection>* detections);

  dds::ServiceRuntime& runtime_;
  Ros2BridgeParams params_;
  dds::TopicReader<sg_idl_StereoFrame> frame_reader_;
  dds::TopicReader<sg_idl_HumanDetections> detections_reader_;
  dds::TopicWriter<sensor_msgs_msg_dds__Image_> image_writer_;
  dds::TopicWriter<sensor_msgs_msg_dds__CameraInfo_> info_writer_;
  std::deque<Pending> pending_;
  std::deque<dds::DetectionsData> early_detections_;  // detections that came before their frame
  std::uint64_t published_ = 0;
  std::string frame_id_ = "stereoguard_left";
};

}  // namespace sg
