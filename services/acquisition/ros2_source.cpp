#include "ros2_source.hpp"

#include <chrono>
#include <cstdio>

#include "camera/calibration.hpp"
#include "config/errors.hpp"

namespace sg {

namespace {

constexpr dds_attach_t kLeftToken = 10;
constexpr dds_attach_t kRightToken = 11;
constexpr dds_attach_t kLeftInfoToken = 12;
constexpr dds_attach_t kRightInfoToken = 13;

dds::QosParams readerQos(const Ros2SourceParams& p) { return dds::ros2Qos(p.reliable, p.history_depth); }

std::string trim(const std::string& text) {
  const auto begin = text.find_first_not_of(" \t");
  if (begin == std::string::npos) return "";
  const auto end = text.find_last_not_of(" \t");
  return text.substr(begin, end - begin + 1);
}

// "1700000000.000000123": the stamp as the frame's name.
std::string stampName(std::int64_t ns) {
  char text[40];
  const long long sec = static_cast<long long>(ns / 1000000000);
  const long long rest = static_cast<long long>(ns % 1000000000);
  std::snprintf(text, sizeof text, "%lld.%09lld", sec, rest < 0 ? -rest : rest);
  return text;
}

}  // namespace

Ros2SourceSpec parseRos2SourceSpec(const std::string& spec) {
  if (!isRos2SourceSpec(spec)) throw InputError("frame source '" + spec + "' is not a ros2: source");
  std::vector<std::string> names;
  std::string rest = spec.substr(5);
  std::size_t start = 0;
  for (;;) {
    const auto comma = rest.find(',', start);
    names.push_back(trim(rest.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (names.size() != 2 && names.size() != 4) {
    throw InputError("frame source '" + spec + "': expected " + kRos2SourceForm + " (" +
                     std::to_string(names.size()) + " topic name(s) given)");
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i].empty() || names[i] == "/") {
      throw InputError("frame source '" + spec + "': topic name " + std::to_string(i + 1) + " is empty");
    }
  }
  Ros2SourceSpec out;
  out.left_image = names[0];
  out.right_image = names[1];
  if (names.size() == 4) {
    out.left_info = names[2];
    out.right_info = names[3];
  }
  return out;
}

Ros2StereoSource::Ros2StereoSource(dds::ServiceRuntime& runtime, const Ros2SourceSpec& spec,
                                   const Ros2SourceParams& params, const std::string& calib_path)
    : runtime_(runtime),
      spec_(spec),
      params_(params),
      calib_path_(calib_path),
      left_reader_(runtime.participant(), dds::ros2DdsTopicName(spec.left_image), readerQos(params)),
      right_reader_(runtime.participant(), dds::ros2DdsTopicName(spec.right_image), readerQos(params)),
      pairer_(static_cast<std::int64_t>(params.pair_tolerance_ms * 1e6),
              static_cast<std::size_t>(params.pending_images)) {
  if (dds::ros2DdsTopicName(spec.left_image) == dds::ros2DdsTopicName(spec.right_image)) {
    throw InputError("ros2 source: the left and right image topics are the same (" + spec.left_image + ")");
  }
  runtime_.attach(left_reader_.dataAvailable(), kLeftToken);
  runtime_.attach(right_reader_.dataAvailable(), kRightToken);
  if (!spec.left_info.empty()) {
    // Depth 1 would do for calibration; KEEP_LAST history_depth costs nothing here.
    left_info_reader_.emplace(runtime.participant(), dds::ros2DdsTopicName(spec.left_info), readerQos(params));
    right_info_reader_.emplace(runtime.participant(), dds::ros2DdsTopicName(spec.right_info), readerQos(params));
    runtime_.attach(left_info_reader_->dataAvailable(), kLeftInfoToken);
    runtime_.attach(right_info_reader_->dataAvailable(), kRightInfoToken);
  }
}

std::string Ros2StereoSource::describe() const {
  std::string text = "ros2 stereo images " + dds::ros2DdsTopicName(spec_.left_image) + ", " +
                     dds::ros2DdsTopicName(spec_.right_image);
  if (!spec_.left_info.empty()) {
    text += ", rig from " + dds::ros2DdsTopicName(spec_.left_info) + ", " + dds::ros2DdsTopicName(spec_.right_info);
  } else {
    text += calib_path_.empty() ? ", nominal rig" : ", rig from " + calib_path_;
  }
  char tolerance[64];
  std::snprintf(tolerance, sizeof tolerance, ", pairs within %.3f ms", params_.pair_tolerance_ms);
  return text + tolerance;
}

void Ros2StereoSource::takeInfos() {
  if (!left_info_reader_) return;
  const auto take = [this](dds::Reader<sensor_msgs_msg_dds__CameraInfo_>& reader, const std::string& topic,
                           std::optional<dds::Ros2CameraInfo>& into) {
    reader.takeAll([&](const sensor_msgs_msg_dds__CameraInfo_& sample) {
      try {
        into = dds::readRos2CameraInfo(sample, "CameraInfo on " + topic);
      } catch (const InputError& e) {
        errors_.push_back(e.what());
      }
    });
  };
  take(*left_info_reader_, dds::ros2DdsTopicName(spec_.left_info), left_info_);
  take(*right_info_reader_, dds::ros2DdsTopicName(spec_.right_info), right_info_);
}

void Ros2StereoSource::takeImages(dds::Reader<sensor_msgs_msg_dds__Image_>& reader, bool left) {
  const std::string topic = dds::ros2DdsTopicName(left ? spec_.left_image : spec_.right_image);
  reader.takeAll([&](const sensor_msgs_msg_dds__Image_& sample) {
    dds::StereoStampPairer::Image image;
    image.stamp_ns = dds::ros2StampNs(sample.header.stamp);
    try {
      dds::readRos2ImageMono(sample, image.mono, "Image " + stampName(image.stamp_ns) + " on " + topic);
    } catch (const InputError& e) {
      errors_.push_back(e.what());
      return;
    }
    if (left) pairer_.addLeft(std::move(image));
    else pairer_.addRight(std::move(image));
  });
}

std::optional<StereoRig> Ros2StereoSource::rigFor(cv::Size size) {
  std::optional<StereoRig> rig;
  if (left_info_reader_) {
    if (!left_info_ || !right_info_) return std::nullopt;
    rig = dds::rigFromRos2CameraInfo(*left_info_, *right_info_,
                                     "CameraInfo on " + dds::ros2DdsTopicName(spec_.left_info) + " / " +
                                         dds::ros2DdsTopicName(spec_.right_info));
    if (!calib_path_.empty()) rig.reset();  // --calib overrides, as for every source
  }
  if (!rig) {
    if (!fixed_rig_ || fixed_rig_size_ != size) {
      StereoCalibration calib = calib_path_.empty() ? nominalCalibration(size) : loadCalibration(calib_path_, size);
      if (calib_path_.empty() && !warned_no_info_) {
        warned_no_info_ = true;
        runtime_.log().warn("ros2 source: no CameraInfo topics and no --calib: using the nominal rig (metric "
                            "distances are only as right as that guess)");
      }
      if (calib.needs_rectification) {
        throw InputError("ros2 source: " + calib_path_ +
                         " describes a raw (unrectified) pair; subscribe to rectified images (image_rect) and give "
                         "their rectified calibration");
      }
      setImageSize(calib, size, "ros2 images");
      fixed_rig_ = calib.rig;
      fixed_rig_size_ = size;
    }
    rig = fixed_rig_;
  }
  if (params_.camera_height_m > 0.0) rig->mounting = Mounting{params_.camera_height_m, params_.camera_pitch_rad};
  return rig;
}

bool Ros2StereoSource::next(StereoPair& pair) {
  auto last_warning = std::chrono::steady_clock::now();
  for (;;) {
    if (runtime_.stopping()) return false;
    takeInfos();
    takeImages(left_reader_, true);
    takeImages(right_reader_, false);
    if (!errors_.empty()) {
      const std::string error = std::move(errors_.front());
      errors_.pop_front();
      throw InputError(error);
    }
    const bool have_rig = !left_info_reader_ || (left_info_ && right_info_);
    if (have_rig) {
      if (auto next = pairer_.next()) {
        const cv::Size size = next->left.mono.size();
        if (next->right.mono.size() != size) {
          throw InputError("ros2 stereo pair " + stampName(next->left.stamp_ns) + ": left image " +
                           std::to_string(size.width) + "x" + std::to_string(size.height) + ", right image " +
                           std::to_string(next->right.mono.cols) + "x" + std::to_string(next->right.mono.rows));
        }
        const std::optional<StereoRig> rig = rigFor(size);
        if (rig->width != size.width || rig->height != size.height) {
          throw InputError("ros2 stereo pair " + stampName(next->left.stamp_ns) + ": images are " +
                           std::to_string(size.width) + "x" + std::to_string(size.height) + " but CameraInfo says " +
                           std::to_string(rig->width) + "x" + std::to_string(rig->height));
        }
        pair = StereoPair{};
        pair.id = stampName(next->left.stamp_ns);
        pair.scene_start = index_ == 0;  // camera topics are one sequence
        pair.index = index_++;
        pair.left = std::move(next->left.mono);
        pair.right = std::move(next->right.mono);
        pair.rig = *rig;
        return true;
      }
    } else if (std::chrono::steady_clock::now() - last_warning > std::chrono::seconds(5)) {
      last_warning = std::chrono::steady_clock::now();
      runtime_.log().warn("ros2 source: waiting for CameraInfo on {} and {} ({} left, {} right image(s) waiting)",
                          dds::ros2DdsTopicName(spec_.left_info), dds::ros2DdsTopicName(spec_.right_info),
                          pairer_.waitingLeft(), pairer_.waitingRight());
    }
    runtime_.wait(std::chrono::steady_clock::now() + std::chrono::milliseconds(100));
  }
}

}  // namespace sg
