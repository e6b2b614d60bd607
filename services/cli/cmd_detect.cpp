// stereoguard detect: the whole per-frame method (features, segmentation,
// localization, tracking) over a frame source, one JSON object per frame.
#include <chrono>
#include <fstream>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "detector_config.hpp"
#include "io/frame_source.hpp"
#include "io/result_json.hpp"
#include "vision/detector.hpp"

namespace sg::cli {

namespace {

struct DetectOptions {
  std::string source = "synthetic";
  std::string calib;
  std::string config;
  std::string out;
  long long frames = 0;
  bool sequence = false;  // frames are consecutive whatever the source says
};

void runDetect(const DetectOptions& o) {
  DetectorConfig config = loadDetectorConfig(o.config);
  auto source = openFrameSource(o.source, o.calib);
  const std::size_t limit = o.frames > 0 ? static_cast<std::size_t>(o.frames)
                                         : source->size().value_or(kDefaultEndlessFrames);
  std::ofstream out(o.out);
  if (!out) throw InputError(o.out + ": cannot write the detections file");
  Detector detector(config.detector);
  StereoPair pair;
  DetectionResult result;
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  std::size_t done = 0;
  std::size_t bad = 0;
  while (done + bad < limit) {
    try {
      if (!source->next(pair)) break;
    } catch (const InputError& e) {
      std::cerr << "stereoguard detect: skipped a frame: " << e.what() << "\n";
      ++bad;
      continue;
    }
    // A frame of another scene (synthetic seeds, KITTI object frames) takes no ground line or
    // track from the one before.
    if (pair.scene_start && !o.sequence) detector.reset();
    detector.compute(pair.left, pair.right, pair.rig, static_cast<double>(pair.index) * config.frame_period_s, result);
    out << toJsonLine(makeFrameRecord(pair.id, pair.left.cols, pair.left.rows, result.segmentation, result.humans,
                                      result.timing_ms))
        << "\n";
    ++done;
    const auto now = std::chrono::steady_clock::now();
    if (limit > 1 && (now - last_report > std::chrono::seconds(2) || done + bad == limit)) {
      const double s = std::chrono::duration<double>(now - start).count();
      std::cerr << "frame " << done + bad << "/" << limit << ", " << (s > 0.0 ? done / s : 0.0) << " fps\n";
      last_report = now;
    }
  }
  out.flush();
  if (!out) throw InputError(o.out + ": write failed");
  if (bad > 0) throw InputError(std::to_string(bad) + " frame(s) of '" + o.source + "' could not be read (see above)");
}

}  // namespace

void addDetectCommand(CLI::App& app) {
  auto opts = std::make_shared<DetectOptions>();
  auto* cmd = app.add_subcommand("detect", "find people in every frame of a source; one JSON object per frame");
  addSourceOption(*cmd, opts->source);
  cmd->add_option("--calib", opts->calib, "calibration file overriding the source's");
  cmd->add_option("--config", opts->config,
                  "YAML with any of: features, segmentation, localizer, tracker, tracking, frame_period_s "
                  "(e.g. config/localization.yaml)");
  cmd->add_option("--frames", opts->frames, "stop after N frames (endless sources: default 10)");
  cmd->add_option("--out", opts->out, "output .jsonl file")->required();
  addSequenceFlag(*cmd, opts->sequence);
  cmd->callback([opts] { runDetect(*opts); });
}

}  // namespace sg::cli
