#include "acquisition_service.hpp"

#include <chrono>
#include <thread>

#include "config/errors.hpp"

namespace sg {

namespace {

cv::Mat continuousMono(const cv::Mat& image) { return image.isContinuous() ? image : image.clone(); }

}  // namespace

AcquisitionService::AcquisitionService(dds::ShutdownSignal& signals, const AcquisitionParams& params,
                                       const std::string& source_spec, const std::string& calib_path,
                                       std::uint64_t frame_limit)
    : params_(params),
      frame_limit_(frame_limit),
      runtime_(signals, "acquisition", params.transport),
      source_(openSource(source_spec, calib_path)),
      writer_(runtime_.participant(), dds::kStereoFrameTopic, params.transport.images),
      answers_reader_(runtime_.participant(), dds::kHumanDetectionsTopic, params.transport.results) {
  // Flow control only where nothing else paces the frames (a camera paces itself).
  flow_control_ = params_.rate_hz <= 0.0 && params_.max_in_flight > 0 && !isRos2SourceSpec(source_spec);
  if (flow_control_) runtime_.attach(answers_reader_.dataAvailable(), 1);
  runtime_.log().info("source {}{}, rate {} Hz{}, frames {}", source_->describe(),
                      params_.sequence ? " (one sequence)" : "", params_.rate_hz,
                      flow_control_ ? " (at most " + std::to_string(params_.max_in_flight) +
                                          " frames ahead of human_detections)"
                                    : std::string(),
                      frame_limit_ == 0 ? std::string("unbounded") : std::to_string(frame_limit_));
  for (int i = 0; i < params_.preload_frames; ++i) {
    StereoPair pair;
    if (!source_->next(pair)) break;
    preloaded_.push_back(std::move(pair));
  }
  if (params_.preload_frames > 0 && preloaded_.empty()) throw InputError("source " + source_spec + " has no frames");
}

std::unique_ptr<FrameSource> AcquisitionService::openSource(const std::string& spec, const std::string& calib_path) {
  if (!isRos2SourceSpec(spec)) return openFrameSource(spec, calib_path);
  if (params_.rate_hz > 0.0) {
    runtime_.log().info("ros2 source: frames are paced by the camera (rate_hz {} ignored)", params_.rate_hz);
    params_.rate_hz = 0.0;
  }
  return std::make_unique<Ros2StereoSource>(runtime_, parseRos2SourceSpec(spec), params_.ros2, calib_path);
}

bool AcquisitionService::nextPair(StereoPair& pair) {
  if (!preloaded_.empty()) {
    const bool first = preload_next_ == 0;  // the loop starts over: back in time
    pair = preloaded_[preload_next_];
    preload_next_ = (preload_next_ + 1) % preloaded_.size();
    if (params_.sequence) pair.scene_start = first;
    return true;
  }
  if (!source_->next(pair)) return false;
  if (params_.sequence) pair.scene_start = !started_;
  started_ = true;
  return true;
}

void AcquisitionService::publish(const StereoPair& pair, bool last) {
  data_.info.frame_id = next_frame_id_;
  data_.info.capture_time_ns = dds::realtimeNowNs();
  data_.info.source = pair.id;
  data_.info.sample_seq = next_seq_++;
  data_.info.end_of_stream = last;
  data_.info.payload_valid = true;
  data_.info.scene_start = pair.scene_start;
  data_.rig = pair.rig;
  data_.rig.width = pair.left.cols;
  data_.rig.height = pair.left.rows;
  data_.left = continuousMono(pair.left);
  data_.right = continuousMono(pair.right);
  sg_idl_StereoFrame sample{};
  dds::fillStereoFrame(data_, sample);
  writer_.write(sample);
  runtime_.stats().published(static_cast<double>(dds::realtimeNowNs() - data_.info.capture_time_ns) * 1e-6);
}

void AcquisitionService::takeAnswers() {
  answers_reader_.takeAll([this](const sg_idl_HumanDetections& answer) {
    // Frames go through the pipeline in order: an answer for id X settles every frame up to X.
    const std::uint64_t id = answer.header.frame_id;
    while (!in_flight_.empty() && in_flight_.front().first <= id) in_flight_.pop_front();
  });
}

void AcquisitionService::waitForRoom() {
  using Clock = std::chrono::steady_clock;
  const auto limit = static_cast<std::size_t>(params_.max_in_flight);
  const auto timeout = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double, std::milli>(params_.in_flight_timeout_ms));
  for (;;) {
    takeAnswers();
    // Only with a localization stage to answer (acquisition alone, or with a recorder, runs open loop).
    if (!flow_control_ || limit == 0 || answers_reader_.matchedWriters() == 0) {
      in_flight_.clear();
      return;
    }
    const auto now = Clock::now();
    while (!in_flight_.empty() && now - in_flight_.front().second > timeout) {
      in_flight_.pop_front();
      ++given_up_;
    }
    if (in_flight_.size() < limit || runtime_.stopping()) return;
    runtime_.wait(in_flight_.front().second + timeout);
  }
}

void AcquisitionService::publishEndMarker() {
  dds::FrameInfo marker;
  marker.frame_id = next_frame_id_;
  marker.capture_time_ns = dds::realtimeNowNs();
  marker.sample_seq = next_seq_++;
  marker.end_of_stream = true;
  marker.payload_valid = false;
  sg_idl_StereoFrame sample{};
  dds::fillHeader(marker, sample.header);
  writer_.write(sample);
}

void AcquisitionService::run() {
  auto& log = runtime_.log();
  const auto match_timeout =
      std::chrono::milliseconds(static_cast<long>(params_.transport.match_timeout_s * 1000.0));
  if (params_.min_readers > 0) {
    const auto count = static_cast<std::uint32_t>(params_.min_readers);
    if (writer_.waitForReaders(count, match_timeout, [this] { return runtime_.stopping(); })) {
      log.info("{} reader(s) matched", writer_.matchedReaders());
    } else if (!runtime_.stopping()) {
      log.warn("only {} of {} reader(s) matched within {} s; publishing anyway", writer_.matchedReaders(), count,
               params_.transport.match_timeout_s);
    }
  }
  using Clock = std::chrono::steady_clock;
  const auto period = params_.rate_hz > 0.0
                          ? std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / params_.rate_hz))
                          : Clock::duration::zero();
  auto next_tick = Clock::now();
  bool ended = false;
  StereoPair pair;
  while (!runtime_.stopping()) {
    // Pace: wait (for signals and the metrics tick) until the frame is due.
    while (!runtime_.stopping() && Clock::now() < next_tick) runtime_.wait(next_tick);
    if (runtime_.stopping()) break;
    if (Clock::now() >= next_tick) runtime_.wait(Clock::now());  // keeps metrics going at full speed
    next_tick += period;
    if (next_tick < Clock::now() - period) next_tick = Clock::now();  // do not burst after a stall

    bool have = false;
    const auto start = Clock::now();
    try {
      have = nextPair(pair);
    } catch (const InputError& e) {
      runtime_.stats().received(1);
      runtime_.stats().dropped(dds::kDropSourceError);
      log.warn("frame {} dropped (source error): {}", next_frame_id_, e.what());
      ++next_frame_id_;
      continue;
    }
    if (!have) {
      log.info("source ended after {} frames", next_frame_id_);
      publishEndMarker();
      ended = true;
      break;
    }
    runtime_.stats().received(1);
    const bool last = frame_limit_ > 0 && next_frame_id_ + 1 >= frame_limit_;
    if (flow_control_) waitForRoom();
    try {
      publish(pair, last);
      // The first frame reaches every matched reader before the next replaces it in the writer's
      // one-frame history: a reader whose side of the discovery lags gets it retransmitted.
      if (params_.min_readers > 0 && !first_published_) writer_.waitForAcks(match_timeout);
      first_published_ = true;
      if (flow_control_) in_flight_.emplace_back(next_frame_id_, Clock::now());
    } catch (const InputError& e) {
      runtime_.stats().dropped(dds::kDropMalformed);
      log.warn("frame {} dropped (malformed): {}", next_frame_id_, e.what());
      if (last) publishEndMarker();
    }
    runtime_.stats().processed(dds::msBetween(start, Clock::now()));
    ++next_frame_id_;
    if (last) {
      ended = true;
      break;
    }
  }
  if (given_up_ > 0) {
    log.info("{} frame(s) got no answer on human_detections within {} ms (dropped downstream)", given_up_,
             params_.in_flight_timeout_ms);
  }
  if (!ended) publishEndMarker();  // stopped by a signal: tell the stages downstream
  writer_.waitForAcks(std::chrono::seconds(5));
  runtime_.finish();
}

}  // namespace sg
