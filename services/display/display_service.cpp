#include "display_service.hpp"

#include <chrono>
#include <cstdio>

#include "config/errors.hpp"
#include "config/yaml_params.hpp"
#include "dds/conversions.hpp"

namespace sg {

namespace {

constexpr dds_attach_t kFrameToken = 1;
constexpr dds_attach_t kSegmentationToken = 2;
constexpr dds_attach_t kDetectionsToken = 3;
constexpr dds_attach_t kMetricsToken = 4;

nlohmann::json detectionsAsResult(const dds::DetectionsData& data) {
  nlohmann::json humans = nlohmann::json::array();
  for (const HumanDetection& d : data.detections) {
    humans.push_back({{"box", {d.box.x, d.box.y, d.box.x + d.box.width, d.box.y + d.box.height}},
                      {"score", d.score},
                      {"distance_m", d.distance_m},
                      {"distance_sigma_m", d.distance_sigma_m},
                      {"position_m", {d.position_m.x(), d.position_m.y(), d.position_m.z()}},
                      {"track_id", d.track_id},
                      {"confirmed", d.confirmed}});
  }
  nlohmann::json timing = nlohmann::json::object();
  for (const auto& [stage, ms] : data.timing_ms) timing[stage] = ms;
  const double latency_ms =
      static_cast<double>(dds::realtimeNowNs() - data.info.capture_time_ns) / 1e6;
  return {{"frame", displayFrameKey(data.info)},
          {"name", displayFrameName(data.info)},
          {"width", data.width},
          {"height", data.height},
          {"humans", humans},
          {"timing_ms", timing},
          {"latency_ms", latency_ms}};
}

nlohmann::json metricsAsJson(const dds::StageMetricsData& m) {
  nlohmann::json reasons = nlohmann::json::object();
  for (const auto& [reason, count] : m.dropped) reasons[reason] = count;
  return {{"stage", m.stage},
          {"pid", m.pid},
          {"fps", m.frames_per_s},
          {"latency_ms", {{"p50", m.latency_ms_p50}, {"p99", m.latency_ms_p99}}},
          {"processing_ms", {{"p50", m.processing_ms_p50}, {"p99", m.processing_ms_p99}}},
          {"frames_in", m.frames_received},
          {"published", m.frames_published},
          {"dropped", m.droppedTotal()},
          {"dropped_by_reason", reasons},
          {"final", m.final_report}};
}

}  // namespace

DisplayConfig loadDisplayConfig(const std::string& path) {
  DisplayConfig config;
  if (!path.empty()) {
    YAML::Node root = loadYamlFile(path);
    if (root && root.IsMap()) {
      if (const YAML::Node bind = root["bind_address"]) {
        if (!bind.IsScalar() || bind.Scalar().empty()) {
          throw ParamError(path + ": key 'bind_address' must be an IPv4 address such as 0.0.0.0 or 127.0.0.1");
        }
        config.bind_address = bind.Scalar();
        root.remove("bind_address");
      }
    }
    loadParams(root, config.params, path);
  }
  config.params.validate();
  return config;
}

std::string displayFrameKey(const dds::FrameInfo& info) {
  char key[32];
  std::snprintf(key, sizeof key, "%012llu", static_cast<unsigned long long>(info.frame_id));
  return key;
}

std::string displayFrameName(const dds::FrameInfo& info) {
  if (!info.source.empty()) return info.source;
  char name[32];
  std::snprintf(name, sizeof name, "%06llu", static_cast<unsigned long long>(info.frame_id));
  return name;
}

DisplayService::DisplayService(dds::ServiceRuntime& runtime, CrewDisplayServer& server,
                               const DisplayServiceParams& params)
    : runtime_(runtime),
      server_(server),
      params_(params),
      frame_reader_(runtime.participant(), dds::kStereoFrameTopic, params.transport.images),
      segmentation_reader_(runtime.participant(), dds::kSegmentationTopic, params.transport.results),
      detections_reader_(runtime.participant(), dds::kHumanDetectionsTopic, params.transport.results),
      metrics_reader_(runtime.participant(), dds::kStageMetricsTopic, params.transport.metrics) {
  runtime_.attach(frame_reader_.dataAvailable(), kFrameToken);
  runtime_.attach(segmentation_reader_.dataAvailable(), kSegmentationToken);
  runtime_.attach(detections_reader_.dataAvailable(), kDetectionsToken);
  runtime_.attach(metrics_reader_.dataAvailable(), kMetricsToken);
}

void DisplayService::run(std::uint64_t frames) {
  using Clock = std::chrono::steady_clock;
  std::optional<Clock::time_point> linger_until;
  while (!runtime_.stopping()) {
    runtime_.wait();
    // Every reader is drained on every wake: cheap when empty, and a busy
    // topic cannot starve the others.
    takeFrames();
    takeSegmentations();
    takeDetections();
    takeMetrics();
    runtime_.watchQos(frame_reader_, "stereo_frame reader");
    runtime_.watchQos(segmentation_reader_, "segmentation reader");
    runtime_.watchQos(detections_reader_, "human_detections reader");
    if (frames > 0 && frames_handed_ >= frames && !linger_until) {
      linger_until = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double>(params_.linger_s));
    }
    if (linger_until && Clock::now() >= *linger_until) break;
  }
  const CrewDisplayStats s = server_.stats();
  runtime_.log().info(
      "display: {} frames handed over, {} shown ({} without detections), {} superseded, {} segmentations, "
      "{} detection samples ({} malformed), {} JPEG encodes ({:.2f} ms avg), {} images served",
      frames_handed_, s.frames_shown, s.shown_without_result, s.dropped_superseded + s.dropped_pending_full,
      segmentations_, detections_, malformed_results_, s.jpeg_encodes, s.jpeg_encode_ms_avg, s.images_served);
}

void DisplayService::takeFrames() {
  frame_reader_.takeAll([this](const sg_idl_StereoFrame& sample, const dds_sample_info_t& info) {
    const auto gap = frame_gaps_.gapBefore(info.publication_handle, sample.header.sample_seq);
    if (gap > 0) runtime_.stats().dropped(dds::kDropSuperseded, gap);
    try {
      dds::readStereoFrame(sample, frame_data_);
    } catch (const InputError& e) {
      runtime_.stats().received();
      runtime_.stats().dropped(dds::kDropMalformed);
      runtime_.log().warn("stereo_frame: {}", e.what());
      return;
    }
    if (!frame_data_.info.payload_valid) {
      if (frame_data_.info.end_of_stream && !end_of_stream_) runtime_.log().info("end of stream");
      end_of_stream_ = end_of_stream_ || frame_data_.info.end_of_stream;
      return;
    }
    runtime_.stats().received();
    server_.publishFrame(displayFrameKey(frame_data_.info), frame_data_.left, cv::Mat(), cv::Mat(),
                         displayFrameName(frame_data_.info));
    runtime_.stats().published(static_cast<double>(dds::realtimeNowNs() - frame_data_.info.capture_time_ns) / 1e6);
    ++frames_handed_;
    if (frame_data_.info.end_of_stream && !end_of_stream_) {
      end_of_stream_ = true;
      runtime_.log().info("end of stream");
    }
  });
}

// Reads one result sample into `data`; false (counted, logged) when it is malformed or carries no payload.
template <class Msg, class Data, class Read>
bool DisplayService::readResult(const Msg& sample, Data& data, Read read, const char* topic) {
  try {
    read(sample, data);
  } catch (const InputError& e) {
    ++malformed_results_;
    runtime_.log().warn("{}: {}", topic, e.what());
    return false;
  }
  return data.info.payload_valid;
}

void DisplayService::takeSegmentations() {
  segmentation_reader_.takeAll([this](const sg_idl_Segmentation& sample) {
    if (!readResult(sample, segmentation_data_, dds::readSegmentation, "segmentation")) return;
    ++segmentations_;
    server_.publishLayers(displayFrameKey(segmentation_data_.info), segmentation_data_.result.labels,
                          segmentation_data_.correlation, segmentation_data_.result.ground.offset_per_row);
  });
}

void DisplayService::takeDetections() {
  detections_reader_.takeAll([this](const sg_idl_HumanDetections& sample) {
    if (!readResult(sample, detections_data_, dds::readDetections, "human_detections")) return;
    ++detections_;
    server_.publishResult(detectionsAsResult(detections_data_));
  });
}

void DisplayService::takeMetrics() {
  metrics_reader_.takeAll([this](const sg_idl_StageMetrics& sample) {
    try {
      server_.publishMetrics(metricsAsJson(dds::readStageMetrics(sample)));
    } catch (const InputError& e) {
      runtime_.log().warn("stage_metrics: {}", e.what());
    }
  });
}

}  // namespace sg
