#include "dds/ros2_messages.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"

namespace sg::dds {

namespace {

constexpr std::uint32_t kMaxImageSide = 16384;

template <class T>
std::string str(const T& value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

[[noreturn]] void fail(const std::string& what, const std::string& field, const std::string& problem) {
  throw InputError(what + ": field '" + field + "' " + problem);
}

int channelsOf(const std::string& encoding) { return encoding == "mono8" ? 1 : 3; }

}  // namespace

std::string ros2DdsTopicName(const std::string& ros_topic) {
  std::string name = ros_topic;
  while (!name.empty() && name.front() == '/') name.erase(name.begin());
  if (name.empty()) throw InputError("ROS 2 topic name '" + ros_topic + "' is empty");
  if (name.rfind("rt/", 0) == 0) return name;
  return "rt/" + name;
}

QosParams ros2Qos(bool reliable, int history_depth) {
  QosParams q;
  q.reliable = reliable;
  q.history_depth = history_depth;
  q.transient_local = false;
  return q;
}

std::int64_t ros2StampNs(const builtin_interfaces_msg_dds__Time_& stamp) {
  return static_cast<std::int64_t>(stamp.sec) * 1000000000 + static_cast<std::int64_t>(stamp.nanosec);
}

void fillRos2Stamp(std::int64_t ns, builtin_interfaces_msg_dds__Time_& out) {
  std::int64_t sec = ns / 1000000000;
  std::int64_t rest = ns % 1000000000;
  if (rest < 0) {
    rest += 1000000000;
    --sec;
  }
  out.sec = static_cast<std::int32_t>(sec);
  out.nanosec = static_cast<std::uint32_t>(rest);
}

bool isSupportedRos2Encoding(const std::string& encoding) {
  return encoding == "mono8" || encoding == "rgb8" || encoding == "bgr8";
}

void readRos2ImageMono(const sensor_msgs_msg_dds__Image_& in, cv::Mat& out, const std::string& what) {
  const std::string encoding = in.encoding != nullptr ? in.encoding : "";
  if (!isSupportedRos2Encoding(encoding)) {
    fail(what, "encoding", "= '" + encoding + "' is not supported (mono8, rgb8 or bgr8)");
  }
  if (in.width == 0 || in.width > kMaxImageSide) fail(what, "width", "= " + str(in.width) + " is not within 1..16384");
  if (in.height == 0 || in.height > kMaxImageSide) {
    fail(what, "height", "= " + str(in.height) + " is not within 1..16384");
  }
  const int channels = channelsOf(encoding);
  const std::uint64_t row_bytes = std::uint64_t{in.width} * static_cast<std::uint64_t>(channels);
  if (in.step < row_bytes) {
    fail(what, "step", "= " + str(in.step) + " is less than width x channels = " + str(row_bytes) + " (" + encoding +
                           ")");
  }
  const std::uint64_t needed = std::uint64_t{in.step} * (in.height - 1) + row_bytes;
  if (in.data._length < needed || in.data._buffer == nullptr) {
    fail(what, "data", "has " + str(in.data._length) + " bytes but step x height = " + str(in.step) + " x " +
                           str(in.height) + " needs " + str(needed));
  }
  const cv::Mat view(static_cast<int>(in.height), static_cast<int>(in.width), channels == 1 ? CV_8UC1 : CV_8UC3,
                     in.data._buffer, in.step);
  if (channels == 1) {
    view.copyTo(out);
  } else {
    cv::cvtColor(view, out, encoding == "rgb8" ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY);
  }
}

Ros2CameraInfo readRos2CameraInfo(const sensor_msgs_msg_dds__CameraInfo_& in, const std::string& what) {
  if (in.width == 0 || in.width > kMaxImageSide) fail(what, "width", "= " + str(in.width) + " is not within 1..16384");
  if (in.height == 0 || in.height > kMaxImageSide) {
    fail(what, "height", "= " + str(in.height) + " is not within 1..16384");
  }
  Ros2CameraInfo info;
  info.width = static_cast<int>(in.width);
  info.height = static_cast<int>(in.height);
  for (int i = 0; i < 12; ++i) {
    if (!std::isfinite(in.p[i])) fail(what, "p[" + str(i) + "]", "= " + str(in.p[i]) + " is not a finite number");
    info.p[static_cast<std::size_t>(i)] = in.p[i];
  }
  return info;
}

StereoRig rigFromRos2CameraInfo(const Ros2CameraInfo& left, const Ros2CameraInfo& right, const std::string& what) {
  if (left.width != right.width || left.height != right.height) {
    fail(what, "width/height", "differ: left " + str(left.width) + "x" + str(left.height) + ", right " +
                                   str(right.width) + "x" + str(right.height));
  }
  const double f = left.p[0];
  if (!(f > 0.0)) fail(what, "left p[0] (focal length)", "= " + str(f) + " is not positive");
  if (std::abs(right.p[0] - f) > 1e-6 * f || std::abs(right.p[5] - left.p[5]) > 1e-6 * f) {
    fail(what, "right p[0]", "= " + str(right.p[0]) + " differs from the left focal length " + str(f) +
                                 " (not a rectified pair)");
  }
  if (std::abs(right.p[6] - left.p[6]) > 1e-6 * f) {
    fail(what, "right p[6]", "= " + str(right.p[6]) + " differs from the left cy " + str(left.p[6]) +
                                 " (rows of a rectified pair must align)");
  }
  const double tx = right.p[3] - left.p[3];  // -f * B
  if (!(tx < 0.0)) {
    fail(what, "right p[3]", "= " + str(right.p[3]) + " must be -f x baseline < 0 (left p[3] = " + str(left.p[3]) +
                                 ")");
  }
  StereoRig rig;
  rig.focal_px = f;
  rig.cx_px = left.p[2];
  rig.cy_px = left.p[6];
  rig.baseline_m = -tx / f;
  rig.width = left.width;
  rig.height = left.height;
  rig.validate(what);
  return rig;
}

StereoStampPairer::StereoStampPairer(std::int64_t tolerance_ns, std::size_t capacity)
    : tolerance_ns_(std::max<std::int64_t>(tolerance_ns, 0)), capacity_(std::max<std::size_t>(capacity, 1)) {}

void StereoStampPairer::add(std::deque<Image>& side, Image image) {
  // In stamp order (a driver publishes in order; a late one is placed where it belongs).
  const auto at = std::upper_bound(side.begin(), side.end(), image.stamp_ns,
                                   [](std::int64_t stamp, const Image& i) { return stamp < i.stamp_ns; });
  side.insert(at, std::move(image));
  while (side.size() > capacity_) {
    side.pop_front();
    ++unpaired_;
  }
}

void StereoStampPairer::addLeft(Image image) { add(left_, std::move(image)); }
void StereoStampPairer::addRight(Image image) { add(right_, std::move(image)); }

std::optional<StereoStampPairer::Pair> StereoStampPairer::next() {
  while (!left_.empty() && !right_.empty()) {
    const std::int64_t l = left_.front().stamp_ns;
    // The right image closest to the oldest left one.
    std::size_t best = right_.size();
    std::int64_t best_diff = 0;
    for (std::size_t i = 0; i < right_.size(); ++i) {
      const std::int64_t diff = std::llabs(right_[i].stamp_ns - l);
      if (diff <= tolerance_ns_ && (best == right_.size() || diff < best_diff)) {
        best = i;
        best_diff = diff;
      }
      if (right_[i].stamp_ns > l + tolerance_ns_) break;
    }
    if (best < right_.size()) {
      Pair pair{std::move(left_.front()), std::move(right_[best])};
      left_.pop_front();
      // Right images before the partner are older than a pair just made: never paired.
      unpaired_ += best;
      right_.erase(right_.begin(), right_.begin() + static_cast<std::ptrdiff_t>(best) + 1);
      return pair;
    }
    if (right_.front().stamp_ns > l + tolerance_ns_) {
      // Every right image (now and later) is newer: this left image has no partner.
      left_.pop_front();
      ++unpaired_;
    } else {
      // The oldest right image is too old for this and every later left image.
      right_.pop_front();
      ++unpaired_;
    }
  }
  return std::nullopt;
}

}  // namespace sg::dds
