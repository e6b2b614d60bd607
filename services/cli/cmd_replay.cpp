// stereoguard replay: publishes a recording's stereo frames (stereoguard
// record) on stereoguard/stereo_frame, so the rest of the pipeline runs on
// them as if acquisition read them.
//
//   stereoguard replay DIR [--rate HZ | --recorded-rate] [--frames N] [--original-timestamps]
//
// Frame ids, frame names and the rig are the recorded ones; the capture time
// is the time of publication (pipeline latency stays meaningful) unless
// --original-timestamps. The last frame carries end_of_stream, as from acquisition.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "dds/conversions.hpp"
#include "dds/dds.hpp"
#include "dds/qos.hpp"
#include "dds/topics.hpp"
#include "recording.hpp"

namespace sg::cli {

namespace {

struct ReplayOptions {
  std::string dir;
  double rate_hz = -1.0;          // -1: the recorded rate
  bool recorded_rate = false;
  std::uint64_t frames = 0;       // 0 = every recorded frame
  bool original_timestamps = false;
  int min_readers = 1;
  double match_timeout_s = 10.0;
  int domain = -1;
};

cv::Mat loadImage(const std::string& dir, const std::string& file, int width, int height, const std::string& where) {
  const std::string path = (std::filesystem::path(dir) / file).string();
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw InputError(where + ": cannot read image '" + path + "'");
  if (image.type() != CV_8UC1 || image.cols != width || image.rows != height) {
    throw InputError(where + ": image '" + path + "' is not mono8 " + std::to_string(width) + "x" +
                     std::to_string(height));
  }
  return image;
}

void runReplay(const ReplayOptions& o) {
  if (o.rate_hz >= 0.0 && o.recorded_rate) throw InputError("--rate and --recorded-rate exclude each other");
  if (o.rate_hz > 10000.0) throw InputError("--rate " + std::to_string(o.rate_hz) + " must be within 0..10000");
  std::vector<RecordedFrame> frames = readRecordedFrames(o.dir);
  if (frames.empty()) throw InputError("'" + o.dir + "': the recording holds no frames");
  if (o.frames > 0 && frames.size() > o.frames) frames.resize(o.frames);
  dds::requireDdsConfig();

  dds::ShutdownSignal signals;
  const dds::TransportParams transport;
  dds::Participant participant(dds::domainId(o.domain >= 0 ? o.domain : transport.domain_id));
  dds::TopicWriter<sg_idl_StereoFrame> writer(participant, dds::kStereoFrameTopic, transport.images);
  const auto stop = [&] { return signals.requested(); };
  if (o.min_readers > 0 &&
      !writer.waitForReaders(static_cast<std::uint32_t>(o.min_readers),
                             std::chrono::milliseconds(static_cast<long>(o.match_timeout_s * 1000.0)), stop)) {
    std::cerr << "replay: only " << writer.matchedReaders() << " of " << o.min_readers
              << " reader(s) matched; publishing anyway\n";
  }

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const std::int64_t first_capture = frames.front().info.capture_time_ns;
  dds::StereoFrameData data;
  std::uint64_t published = 0;
  for (std::size_t i = 0; i < frames.size() && !signals.requested(); ++i) {
    const RecordedFrame& f = frames[i];
    const std::string where = o.dir + ": frame " + std::to_string(f.info.frame_id);
    data.left = loadImage(o.dir, f.left_file, f.width, f.height, where);
    data.right = loadImage(o.dir, f.right_file, f.width, f.height, where);
    data.rig = dds::readRig(f.rig, static_cast<std::uint32_t>(f.width), static_cast<std::uint32_t>(f.height), where);
    // Pacing: the recorded capture times, or a fixed rate (0 = as fast as possible).
    Clock::time_point due = start;
    if (o.rate_hz > 0.0) {
      due = start + std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double>(static_cast<double>(i) / o.rate_hz));
    } else if (o.rate_hz < 0.0) {
      due = start + std::chrono::nanoseconds(std::max<std::int64_t>(0, f.info.capture_time_ns - first_capture));
    }
    std::this_thread::sleep_until(due);
    data.info = f.info;
    data.info.sample_seq = i;
    data.info.payload_valid = true;
    data.info.end_of_stream = i + 1 == frames.size();
    if (!o.original_timestamps) data.info.capture_time_ns = dds::realtimeNowNs();
    sg_idl_StereoFrame sample{};
    dds::fillStereoFrame(data, sample);
    writer.write(sample);
    // The first frame reaches every matched reader before the next replaces it in the writer's
    // one-frame history: a reader whose side of the discovery lags gets it retransmitted.
    if (published == 0 && o.min_readers > 0)
      writer.waitForAcks(std::chrono::milliseconds(static_cast<long>(o.match_timeout_s * 1000.0)));
    ++published;
  }
  if (published < frames.size()) {  // stopped by a signal: tell the stages downstream
    dds::FrameInfo marker;
    marker.frame_id = frames[published].info.frame_id;
    marker.capture_time_ns = dds::realtimeNowNs();
    marker.sample_seq = published;
    marker.end_of_stream = true;
    marker.payload_valid = false;
    sg_idl_StereoFrame sample{};
    dds::fillHeader(marker, sample.header);
    writer.write(sample);
  }
  writer.waitForAcks(std::chrono::seconds(5));
  std::cerr << "replay: " << published << " of " << frames.size() << " frames published from " << o.dir << "\n";
}

}  // namespace

void addReplayCommand(CLI::App& app) {
  auto opts = std::make_shared<ReplayOptions>();
  auto* cmd = app.add_subcommand("replay", "publish a recording's stereo frames on DDS (for the pipeline)");
  cmd->add_option("dir", opts->dir, "recording folder written by 'stereoguard record'")->required();
  cmd->add_option("--rate", opts->rate_hz, "frames per second (0 = as fast as possible; default: the recorded rate)");
  cmd->add_flag("--recorded-rate", opts->recorded_rate, "pace frames as they were recorded (the default)");
  cmd->add_option("--frames", opts->frames, "publish only the first N frames");
  cmd->add_flag("--original-timestamps", opts->original_timestamps,
                "publish the recorded capture times instead of the time of publication");
  cmd->add_option("--min-readers", opts->min_readers, "matched readers awaited before the first frame")
      ->check(CLI::Range(0, 64));
  cmd->add_option("--match-timeout", opts->match_timeout_s, "seconds to wait for those readers")
      ->check(CLI::Range(0.0, 600.0));
  cmd->add_option("--domain", opts->domain, "DDS domain id (default: SG_DDS_DOMAIN or 0)")->check(CLI::Range(0, 230));
  cmd->callback([opts] { runReplay(*opts); });
}

}  // namespace sg::cli
