// stereoguard record: subscribes to stereo_frame, segmentation and
// human_detections and writes them to a folder (services/cli/recording.hpp):
// the frames as lossless PNG, the results as per-frame JSON lines, each with
// its capture and receive time.
//
//   stereoguard record --out DIR [--frames N] [--duration S] [--domain ID]
//
// Ends after N stereo frames, after S seconds, after the end-of-stream marker
// of the source, or on SIGINT/SIGTERM.
#include <chrono>
#include <cstdio>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "dds/conversions.hpp"
#include "dds/dds.hpp"
#include "dds/qos.hpp"
#include "dds/topics.hpp"
#include "io/result_json.hpp"
#include "recording.hpp"

namespace sg::cli {

namespace {

struct RecordOptions {
  std::string out;
  std::uint64_t frames = 0;    // 0 = no limit
  double duration_s = 0.0;     // 0 = no limit
  double linger_s = 1.0;       // after the last frame: wait this long for its results
  int domain = -1;             // -1: SG_DDS_DOMAIN or 0
  int queue = 64;              // reader history: frames queued while PNGs are written
};

std::string frameName(const dds::FrameInfo& info) {
  if (!info.source.empty()) return info.source;
  char name[32];
  std::snprintf(name, sizeof name, "%06llu", static_cast<unsigned long long>(info.frame_id));
  return name;
}

void writeResultLine(std::ofstream& out, const char* topic, const dds::FrameInfo& info, const FrameRecord& record) {
  const nlohmann::json line{{"topic", topic},
                            {"frame_id", info.frame_id},
                            {"capture_time_ns", info.capture_time_ns},
                            {"receive_time_ns", dds::realtimeNowNs()},
                            {"sample_seq", info.sample_seq},
                            {"result", toJson(record)}};
  out << line.dump() << "\n";
}

void runRecord(const RecordOptions& o) {
  namespace fs = std::filesystem;
  if (o.duration_s < 0.0) throw InputError("--duration must be >= 0");
  dds::requireDdsConfig();
  std::error_code ec;
  fs::create_directories(fs::path(o.out) / kRecordingImageDir, ec);
  if (ec) throw InputError("--out '" + o.out + "': cannot create the folder (" + ec.message() + ")");
  std::ofstream frames_out(fs::path(o.out) / kRecordingFramesFile, std::ios::trunc);
  std::ofstream results_out(fs::path(o.out) / kRecordingResultsFile, std::ios::trunc);
  if (!frames_out || !results_out) throw InputError("--out '" + o.out + "': cannot write the recording files");

  dds::ShutdownSignal signals;  // before the participant: Cyclone's threads inherit the blocked signals
  const dds::TransportParams transport;
  dds::Participant participant(dds::domainId(o.domain >= 0 ? o.domain : transport.domain_id));
  dds::GuardCondition guard(participant);
  signals.bind(guard);
  dds::QosParams image_qos = transport.images;
  image_qos.history_depth = o.queue;  // reader side only: the writer keeps its own depth
  dds::QosParams result_qos = transport.results;
  result_qos.history_depth = o.queue;
  dds::TopicReader<sg_idl_StereoFrame> frame_reader(participant, dds::kStereoFrameTopic, image_qos);
  dds::TopicReader<sg_idl_Segmentation> segmentation_reader(participant, dds::kSegmentationTopic, result_qos);
  dds::TopicReader<sg_idl_HumanDetections> detections_reader(participant, dds::kHumanDetectionsTopic, result_qos);
  dds::WaitSet waitset(participant);
  waitset.attach(guard.handle(), 0);
  waitset.attach(frame_reader.dataAvailable(), 1);
  waitset.attach(segmentation_reader.dataAvailable(), 2);
  waitset.attach(detections_reader.dataAvailable(), 3);

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  std::optional<Clock::time_point> end_at;  // set once the stream ended or the frame limit was reached
  std::uint64_t frames = 0, segmentations = 0, detections = 0;
  dds::StereoFrameData frame;
  dds::SegmentationData segmentation;
  dds::DetectionsData detection;
  std::cerr << "record: waiting for frames on domain " << dds::domainId(o.domain >= 0 ? o.domain : 0) << "\n";

  while (!signals.requested()) {
    const auto now = Clock::now();
    if (o.duration_s > 0.0 && now - start >= std::chrono::duration<double>(o.duration_s)) break;
    if (end_at && now >= *end_at) break;
    waitset.wait(std::chrono::milliseconds(50));

    frame_reader.takeAll([&](const sg_idl_StereoFrame& sample) {
      if (end_at) return;
      dds::readStereoFrame(sample, frame);
      if (frame.info.payload_valid) {
        RecordedFrame rec;
        rec.info = frame.info;
        dds::fillRig(frame.rig, rec.rig);
        rec.width = frame.left.cols;
        rec.height = frame.left.rows;
        rec.receive_time_ns = dds::realtimeNowNs();
        rec.left_file = recordedImageName(frame.info.frame_id, "left");
        rec.right_file = recordedImageName(frame.info.frame_id, "right");
        if (!cv::imwrite((fs::path(o.out) / rec.left_file).string(), frame.left) ||
            !cv::imwrite((fs::path(o.out) / rec.right_file).string(), frame.right)) {
          throw InputError("--out '" + o.out + "': cannot write the PNG files of frame " +
                           std::to_string(frame.info.frame_id));
        }
        frames_out << toJson(rec).dump() << "\n";
        frames_out.flush();
        ++frames;
      }
      const bool limit = o.frames > 0 && frames >= o.frames;
      if (frame.info.end_of_stream || limit) {
        const bool results_expected = segmentation_reader.matchedWriters() + detections_reader.matchedWriters() > 0;
        end_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(results_expected ? o.linger_s : 0.0));
      }
    });
    segmentation_reader.takeAll([&](const sg_idl_Segmentation& sample) {
      dds::readSegmentation(sample, segmentation);
      if (!segmentation.info.payload_valid) return;
      const FrameRecord record =
          makeFrameRecord(frameName(segmentation.info), segmentation.rig.width, segmentation.rig.height,
                          segmentation.result, {}, segmentation.result.timing_ms);
      writeResultLine(results_out, "segmentation", segmentation.info, record);
      ++segmentations;
    });
    detections_reader.takeAll([&](const sg_idl_HumanDetections& sample) {
      dds::readDetections(sample, detection);
      if (!detection.info.payload_valid) return;
      FrameRecord record;
      record.frame = frameName(detection.info);
      record.width = detection.width;
      record.height = detection.height;
      record.humans = detection.detections;
      record.timing_ms = detection.timing_ms;
      writeResultLine(results_out, "human_detections", detection.info, record);
      ++detections;
    });
    results_out.flush();
  }
  signals.unbind();
  if (!frames_out || !results_out) throw InputError("--out '" + o.out + "': writing the recording failed");
  std::cerr << "record: " << frames << " frames, " << segmentations << " segmentations, " << detections
            << " detection sets in " << o.out << "\n";
}

}  // namespace

void addRecordCommand(CLI::App& app) {
  auto opts = std::make_shared<RecordOptions>();
  auto* cmd = app.add_subcommand("record", "record the pipeline's frames (PNG) and results (JSONL) from DDS");
  cmd->add_option("--out", opts->out, "output folder (frames.jsonl, frames/, results.jsonl)")->required();
  cmd->add_option("--frames", opts->frames, "stop after N stereo frames (0 = no limit)");
  cmd->add_option("--duration", opts->duration_s, "stop after S seconds (0 = no limit)");
  cmd->add_option("--linger", opts->linger_s, "after the last frame, wait S seconds for its results")
      ->check(CLI::Range(0.0, 60.0));
  cmd->add_option("--domain", opts->domain, "DDS domain id (default: SG_DDS_DOMAIN or 0)")->check(CLI::Range(0, 230));
  cmd->callback([opts] { runRecord(*opts); });
}

}  // namespace sg::cli
