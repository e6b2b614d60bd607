#include "ros2_bridge.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace sg {

namespace {

dds::QosParams rosQos(const Ros2OutputParams& p) { return dds::ros2Qos(p.reliable, p.history_depth); }

}  // namespace

void fillRos2Image(const cv::Mat& image, std::int64_t stamp_ns, const char* frame_id,
                   sensor_msgs_msg_dds__Image_& out) {
  dds::fillRos2Stamp(stamp_ns, out.header.stamp);
  out.header.frame_id = const_cast<char*>(frame_id);
  out.height = static_cast<std::uint32_t>(image.rows);
  out.width = static_cast<std::uint32_t>(image.cols);
  out.encoding = const_cast<char*>(image.channels() == 3 ? "bgr8" : "mono8");
  out.is_bigendian = 0;
  out.step = static_cast<std::uint32_t>(image.step[0]);
  out.data._length = out.data._maximum = static_cast<std::uint32_t>(image.step[0] * static_cast<std::size_t>(image.rows));
  out.data._buffer = const_cast<std::uint8_t*>(image.ptr<std::uint8_t>(0));
  out.data._release = false;
}

void fillRos2CameraInfo(const StereoRig& rig, std::int64_t stamp_ns, const char* frame_id,
                        sensor_msgs_msg_dds__CameraInfo_& out) {
  static double no_distortion[5] = {0, 0, 0, 0, 0};
  dds::fillRos2Stamp(stamp_ns, out.header.stamp);
  out.header.frame_id = const_cast<char*>(frame_id);
  out.height = static_cast<std::uint32_t>(rig.height);
  out.width = static_cast<std::uint32_t>(rig.width);
  out.distortion_model = const_cast<char*>("plumb_bob");
  out.d._length = out.d._maximum = 5;
  out.d._buffer = no_distortion;
  out.d._release = false;
  const double k[9] = {rig.focal_px, 0, rig.cx_px, 0, rig.focal_px, rig.cy_px, 0, 0, 1};
  const double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  // Left camera of a rectified pair: P = [K | 0] (the right camera would carry Tx = -f * B).
  const double p[12] = {rig.focal_px, 0, rig.cx_px, 0, 0, rig.focal_px, rig.cy_px, 0, 0, 0, 1, 0};
  std::copy(std::begin(k), std::end(k), out.k);
  std::copy(std::begin(r), std::end(r), out.r);
  std::copy(std::begin(p), std::end(p), out.p);
  out.binning_x = 0;
  out.binning_y = 0;
  out.roi = {0, 0, 0, 0, false};
}

cv::Mat annotateLeft(const cv::Mat& left, const std::vector<HumanDetection>& detections, bool colour) {
  cv::Mat out;
  if (colour) cv::cvtColor(left, out, cv::COLOR_GRAY2BGR);
  else out = left.clone();
  for (const auto& d : detections) {
    const cv::Rect box(cv::Point(static_cast<int>(std::lround(d.box.x)), static_cast<int>(std::lround(d.box.y))),
                       cv::Point(static_cast<int>(std::lround(d.box.x + d.box.width)),
                                 static_cast<int>(std::lround(d.box.y + d.box.height))));
    const cv::Scalar ink = colour ? (d.distance_m < 10.0f ? cv::Scalar(0, 0, 255) : cv::Scalar(0, 200, 255))
                                  : cv::Scalar(255);
    cv::rectangle(out, box, ink, 2);
  }
  return out;
}

Ros2Bridge::Ros2Bridge(dds::ServiceRuntime& runtime, const Ros2BridgeParams& params)
    : runtime_(runtime),
      params_(params),
      frame_reader_(runtime.participant(), dds::kStereoFrameTopic, params.transport.images),
      detections_reader_(runtime.participant(), dds::kHumanDetectionsTopic, params.transport.results),
      image_writer_(runtime.participant(), dds::kRos2AnnotatedImageTopic, rosQos(params.ros2)),
      info_writer_(runtime.participant(), dds::kRos2CameraInfoTopic, rosQos(params.ros2)) {
  runtime_.attach(frame_reader_.dataAvailable(), 1);
  runtime_.attach(detections_reader_.dataAvailable(), 2);
}

void Ros2Bridge::publish(const dds::StereoFrameData& frame, const std::vector<HumanDetection>* detections) {
  static const std::vector<HumanDetection> none;
  const cv::Mat image = annotateLeft(frame.left, detections ? *detections : none, params_.ros2.colour);
  sensor_msgs_msg_dds__Image_ msg{};
  fillRos2Image(image, frame.info.capture_time_ns, frame_id_.c_str(), msg);
  image_writer_.write(msg);
  sensor_msgs_msg_dds__CameraInfo_ info{};
  fillRos2CameraInfo(frame.rig, frame.info.capture_time_ns, frame_id_.c_str(), info);
  info_writer_.write(info);
  ++published_;
  runtime_.stats().published(static_cast<double>(dds::realtimeNowNs() - frame.info.capture_time_ns) * 1e-6);
}

void Ros2Bridge::run(std::uint64_t frames) {
  using Clock = std::chrono::steady_clock;
  const auto timeout = std::chrono::milliseconds(params_.ros2.join_timeout_ms);
  bool ended = false;
  while (!runtime_.stopping() && !(frames > 0 && published_ >= frames)) {
    if (ended && pending_.empty()) break;
    runtime_.wait(Clock::now() + std::chrono::milliseconds(20));
    frame_reader_.takeAll([&](const sg_idl_StereoFrame& sample) {
      Pending p;
      dds::readStereoFrame(sample, p.frame);
      if (p.frame.info.end_of_stream) ended = true;
      if (!p.frame.info.payload_valid) return;
      runtime_.stats().received(1);
      p.frame.left = p.frame.left.clone();  // own the pixels beyond the loan
      p.arrived = Clock::now();
      pending_.push_back(std::move(p));
      if (pending_.size() > static_cast<std::size_t>(params_.ros2.pending_frames)) {
        publish(pending_.front().frame, nullptr);
        pending_.pop_front();
      }
    });
    detections_reader_.takeAll([&](const sg_idl_HumanDetections& sample) {
      dds::DetectionsData d;
      dds::readDetections(sample, d);
      if (!d.info.payload_valid) return;
      early_detections_.push_back(std::move(d));
      if (early_detections_.size() > 64) early_detections_.pop_front();
    });
    // Join: a frame goes out with its detections, or without them after the timeout.
    const auto now = Clock::now();
    while (!pending_.empty()) {
      const auto& head = pending_.front();
      const auto match = std::find_if(early_detections_.begin(), early_detections_.end(), [&](const auto& d) {
        return d.info.frame_id == head.frame.info.frame_id;
      });
      if (match != early_detections_.end()) {
        publish(head.frame, &match->detections);
        early_detections_.erase(match);
      } else if (now - head.arrived >= timeout) {
        publish(head.frame, nullptr);
      } else {
        break;
      }
      pending_.pop_front();
    }
    runtime_.watchQos(image_writer_, "ros2 image writer");
  }
}

}  // namespace sg
