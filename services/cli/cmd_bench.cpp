// stereoguard bench: per-stage timings of the Section III segmentation and of
// the detection (segmentation + human localization) over many frames of a
// source, and OpenCV StereoBM (128 disparities, block 15, one thread) on the same
// pairs in the same run, for a side-by-side ratio. With more than 5 obstacles
// allowed, the frames are measured a second time as the speed targets count them
// (up to 5 obstacles). Every frame is measured --rounds times, its measurements
// following each other frame by frame; each figure keeps its fastest per frame.
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "commands.hpp"
#include "detector_config.hpp"
#include "config/errors.hpp"
#include "io/frame_source.hpp"
#include "pipeline_bench.hpp"
#include "vision/detector.hpp"
#include "vision/simd_match.hpp"

namespace sg::cli {

namespace {

struct BenchOptions {
  std::string source = "synthetic";
  std::string calib;
  std::string config;
  std::string json;
  int frames = 30;
  int rounds = 3;   // every frame is measured this many times; each figure keeps its fastest
  int threads = 0;  // 0 = TBB default
  bool pipeline = false;  // also the multi-process DDS pipeline (pipeline_bench.hpp)
  double rate_hz = 5.0;   // --pipeline: acquisition rate (frames/s); 0 = as fast as the stages take them
};

struct Stats {
  double median = 0.0;
  double min = 0.0;
};

Stats stats(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  const std::size_t n = v.size();
  s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  return s;
}

nlohmann::json toJson(const Stats& s) { return {{"median", s.median}, {"min", s.min}}; }

// The processor as the kernel names it (Linux: /proc/cpuinfo's model name, family and model),
// "unknown" elsewhere: timings and the StereoBM ratio differ between processor generations.
std::string processorName() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, name, family, model;
  auto value = [](const std::string& l) {
    const auto colon = l.find(':');
    return colon == std::string::npos ? std::string() : l.substr(l.find_first_not_of(" \t", colon + 1));
  };
  while (std::getline(in, line) && line.find_first_not_of(" \t") != std::string::npos) {
    if (line.rfind("model name", 0) == 0) name = value(line);
    else if (line.rfind("cpu family", 0) == 0) family = value(line);
    else if (line.rfind("model", 0) == 0 && line.find(':') != std::string::npos) model = value(line);
  }
  if (name.empty()) return "unknown";
  if (!family.empty() && !model.empty()) name += " (family " + family + ", model " + model + ")";
  return name;
}

// "<prefix>X ms, detection Y ms (frame i of N)\n" for the frame whose segmentation took longest:
// the medians say what a frame usually costs, this what the worst one did.
std::string slowestFrame(const std::string& prefix, const std::vector<double>& segmentation_ms,
                         const std::vector<double>& detection_ms) {
  if (segmentation_ms.empty()) return "";
  const auto it = std::max_element(segmentation_ms.begin(), segmentation_ms.end());
  const auto i = static_cast<std::size_t>(it - segmentation_ms.begin());
  std::ostringstream out;
  out << std::fixed << std::setprecision(3) << prefix << *it << " ms";
  if (i < detection_ms.size()) out << ", detection " << detection_ms[i] << " ms";
  out << " (frame " << i + 1 << " of " << segmentation_ms.size() << ")\n";
  return out.str();
}

using Clock = std::chrono::steady_clock;

// What one pass over the frames measured (per frame, milliseconds).
struct PassFigures {
  std::map<std::string, std::vector<double>> stage_ms;  // the segmentation's stages
  std::vector<double> segmentation_ms, preprocessing_ms, localization_ms, detection_ms;
  std::size_t obstacles = 0, people = 0;
  long hog_calls = 0;
};

// One frame through a detector's segmentation and localization, its figures appended to `f`.
void measureFrame(Detector& detector, const StereoPair& pair, DetectionResult& result, PassFigures& f) {
  detector.reset();  // every frame stands alone (frames of a synthetic source are unrelated)
  detector.compute(pair.left, pair.right, pair.rig, 0.0, result);
  const auto& seg = result.segmentation.timing_ms;
  for (const auto& [stage, ms] : seg) f.stage_ms[stage].push_back(ms);
  f.segmentation_ms.push_back(seg.at("total"));
  // Features, correlation, ground and removal (with the correlation after it): all
  // of Section III but the obstacle loop.
  double pre = 0.0;
  for (const char* stage : {"features", "correlation", "ground", "removal"}) {
    const auto it = seg.find(stage);
    if (it != seg.end()) pre += it->second;
  }
  f.preprocessing_ms.push_back(pre);
  const double localization = result.timing_ms.at("localization");
  f.localization_ms.push_back(localization);
  f.detection_ms.push_back(seg.at("total") + localization);
  f.obstacles += result.segmentation.obstacles.size();
  f.people += result.humans.size();
}

DetectorParams untracked(DetectorParams params) {
  params.tracking = false;
  return params;
}

// A detector measured over the rounds (no tracking: the frames of a source are measured one
// by one, each standing alone), warmed up once.
struct MeasuredDetector {
  MeasuredDetector(const DetectorParams& params, const StereoPair& warm_up) : detector(untracked(params)) {
    detector.compute(warm_up.left, warm_up.right, warm_up.rig, 0.0, result);
    hog_before = detector.hogDetectCalls();
  }
  Detector detector;
  DetectionResult result;
  long hog_before = 0;
  std::vector<PassFigures> rounds;
};

// OpenCV StereoBM, 128 disparities, block 15, one thread (the caller sets the threads).
struct MeasuredStereoBm {
  explicit MeasuredStereoBm(const StereoPair& warm_up) : bm(cv::StereoBM::create(128, 15)) {
    bm->compute(warm_up.left, warm_up.right, disparity);
  }
  double frameMs(const StereoPair& pair) {
    const auto t0 = Clock::now();
    bm->compute(pair.left, pair.right, disparity);
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  }
  cv::Ptr<cv::StereoBM> bm;
  cv::Mat disparity;
};

// into[i] = min(into[i], other[i]) frame by frame.
void keepMin(std::vector<double>& into, const std::vector<double>& other) {
  for (std::size_t i = 0; i < into.size() && i < other.size(); ++i) into[i] = std::min(into[i], other[i]);
}

// Per frame, the fastest of the rounds for every figure (another process sharing the core
// only ever slows a run down); counts are the same in every round and come from the first.
PassFigures fastestOf(const std::vector<PassFigures>& rounds) {
  PassFigures f = rounds.front();
  for (std::size_t r = 1; r < rounds.size(); ++r) {
    const PassFigures& o = rounds[r];
    for (auto& [stage, ms] : f.stage_ms) {
      const auto it = o.stage_ms.find(stage);
      if (it != o.stage_ms.end()) keepMin(ms, it->second);
    }
    keepMin(f.segmentation_ms, o.segmentation_ms);
    keepMin(f.preprocessing_ms, o.preprocessing_ms);
    keepMin(f.localization_ms, o.localization_ms);
    keepMin(f.detection_ms, o.detection_ms);
  }
  return f;
}

// The speed targets count up to this many obstacles per frame.
constexpr int kTargetObstacles = 5;

void runBench(const BenchOptions& opt) {
  if (opt.frames < 1) throw InputError("--frames must be at least 1, got " + std::to_string(opt.frames));
  if (opt.threads < 0) throw InputError("--threads must be 0 (default) or positive, got " + std::to_string(opt.threads));
  if (opt.rounds < 1) throw InputError("--rounds must be at least 1, got " + std::to_string(opt.rounds));
  const DetectorParams params = loadDetectorConfig(opt.config).detector;
  std::optional<tbb::global_control> limit;
  if (opt.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(opt.threads));
  const int threads = static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));

  // Load the frames first: reading and rendering are not part of the measurement.
  std::unique_ptr<FrameSource> source = openFrameSource(opt.source, opt.calib);
  std::vector<StereoPair> pairs;
  while (static_cast<int>(pairs.size()) < opt.frames) {
    StereoPair pair;
    if (!source->next(pair)) break;
    pairs.push_back(std::move(pair));
  }
  if (pairs.empty()) throw InputError("source '" + opt.source + "' yielded no frames");
  const cv::Size size = pairs.front().left.size();
  const int offsets = params.segmenter.correlation.offsets;
  const int max_obstacles = params.segmenter.obstacles.max_obstacles;

  const std::string processor = processorName();
  std::cout << "stereoguard bench\n"
            << "  source      " << source->describe() << "\n"
            << "  frames      " << pairs.size() << " (+1 warm-up run, not counted), " << opt.rounds
            << (opt.rounds == 1 ? " round" : " rounds, each figure the fastest of them per frame") << "\n"
            << "  size        " << size.width << "x" << size.height << "\n"
            << "  offsets     " << offsets << "\n"
            << "  threads     " << threads << " (TBB row bands" << (params.segmenter.parallel ? "" : ", disabled")
            << ")\n"
            << "  hardware    " << tbb::info::default_concurrency() << " hardware threads, " << processor
            << ", " << simd::kernelName() << " kernels\n"
            << "  StereoBM    128 disparities, block 15, cv::setNumThreads(1)\n"
            << "  clock       steady_clock; figures are per frame (left + right), milliseconds\n"
            << "  detection   segmentation + human localization (no tracking)\n" << std::flush;

  // The speed targets' own definition: the same frames with at most kTargetObstacles obstacles.
  DetectorParams capped_params = params;
  capped_params.segmenter.obstacles.max_obstacles = kTargetObstacles;
  const bool measure_capped = max_obstacles > kTargetObstacles;
  // Frame by frame, the three measurements follow each other (the detector as configured, the
  // detector as the targets count, StereoBM), so that a busy spell of the machine falls on
  // all of them alike; the rounds repeat that over the frames.
  MeasuredDetector as_configured(params, pairs.front());
  std::optional<MeasuredDetector> as_targets;
  if (measure_capped) as_targets.emplace(capped_params, pairs.front());
  const int previous_cv_threads = cv::getNumThreads();
  cv::setNumThreads(1);
  MeasuredStereoBm stereobm(pairs.front());
  std::vector<std::vector<double>> stereobm_rounds;
  for (int r = 0; r < opt.rounds; ++r) {
    as_configured.rounds.emplace_back();
    if (as_targets) as_targets->rounds.emplace_back();
    stereobm_rounds.emplace_back();
    for (const StereoPair& pair : pairs) {
      measureFrame(as_configured.detector, pair, as_configured.result, as_configured.rounds.back());
      if (as_targets) measureFrame(as_targets->detector, pair, as_targets->result, as_targets->rounds.back());
      stereobm_rounds.back().push_back(stereobm.frameMs(pair));
    }
  }
  cv::setNumThreads(previous_cv_threads);
  // HOG calls are counted over every round: per frame, per round.
  auto hogCalls = [&](const MeasuredDetector& m) {
    return (m.detector.hogDetectCalls() - m.hog_before) / std::max(1, opt.rounds);
  };
  PassFigures f = fastestOf(as_configured.rounds);
  f.hog_calls = hogCalls(as_configured);
  std::optional<PassFigures> capped;
  if (as_targets) {
    capped = fastestOf(as_targets->rounds);
    capped->hog_calls = hogCalls(*as_targets);
  }
  std::vector<double> stereobm_ms = stereobm_rounds.front();
  for (const auto& round : stereobm_rounds) keepMin(stereobm_ms, round);

  const double frames = static_cast<double>(pairs.size());
  const Stats seg = stats(f.segmentation_ms);
  const Stats sbm = stats(stereobm_ms);
  const double ratio = seg.median > 0 ? sbm.median / seg.median : 0.0;
  const Stats pre = stats(f.preprocessing_ms);
  const double pre_ratio = pre.median > 0 ? sbm.median / pre.median : 0.0;
  const Stats loc = stats(f.localization_ms);
  const Stats det = stats(f.detection_ms);
  std::cout << std::fixed << std::setprecision(3) << "\n  stage            median      min\n";
  nlohmann::json stages;
  auto line = [](const std::string& name, const Stats& s) {
    std::cout << "  " << std::left << std::setw(14) << name << std::right << std::setw(9) << s.median << std::setw(9)
              << s.min << "\n";
  };
  for (const char* stage : {"features", "correlation", "ground", "removal", "obstacles", "standing", "total"}) {
    const auto it = f.stage_ms.find(stage);
    if (it == f.stage_ms.end()) continue;
    const Stats s = stats(it->second);
    line(stage, s);
    stages[stage] = toJson(s);
  }
  line("localization", loc);
  line("detection", det);
  line("StereoBM", sbm);
  std::cout << "\n  segmentation median " << seg.median << " ms, StereoBM median " << sbm.median
            << " ms: StereoBM / segmentation = " << std::setprecision(2) << ratio << "\n"
            << std::setprecision(3) << "  without the obstacle loop (features, correlation, ground, removal) median "
            << pre.median << " ms, min " << pre.min << " ms: StereoBM / that = " << std::setprecision(2)
            << pre_ratio << "\n"
            << std::setprecision(3) << "  detection (segmentation + localization) median " << det.median << " ms, min "
            << det.min << " ms\n"
            << std::setprecision(2) << "  per frame: obstacles " << static_cast<double>(f.obstacles) / frames
            << ", people " << static_cast<double>(f.people) / frames << ", boxes shape-validated (HOG calls) "
            << static_cast<double>(f.hog_calls) / frames << "\n";

  // The targets: segmentation <= 5 ms and >= 5x StereoBM, detection <= 10 ms, with up to
  // kTargetObstacles obstacles (the loop stops after that many).
  const PassFigures& t = capped ? *capped : f;
  const Stats t_seg = stats(t.segmentation_ms);
  const Stats t_det = stats(t.detection_ms);
  const double t_ratio = t_seg.median > 0 ? sbm.median / t_seg.median : 0.0;
  std::cout << std::setprecision(3) << "\n  as the speed targets count it (up to " << kTargetObstacles << " obstacles"
            << (capped ? ", the loop stopping after them; measured again" : ": max_obstacles is already within")
            << "):\n"
            << "    segmentation median " << t_seg.median << " ms (target <= 5), StereoBM / segmentation "
            << std::setprecision(2) << t_ratio << " (target >= 5)\n"
            << std::setprecision(3) << "    detection median " << t_det.median << " ms (target <= 10)\n"
            << slowestFrame("    slowest frame: segmentation ", t.segmentation_ms, t.detection_ms)
            << std::setprecision(2) << "    per frame: obstacles " << static_cast<double>(t.obstacles) / frames
            << ", people " << static_cast<double>(t.people) / frames << "\n";

  // --pipeline (the multi-process DDS pipeline's frames/s and latency) adds its
  // figures to this same JSON object under "pipeline".
  std::optional<nlohmann::json> pipeline_json;
  if (opt.pipeline) {
    PipelineBenchOptions pb;
    pb.source = opt.source;
    pb.calib = opt.calib;
    pb.frames = static_cast<std::uint64_t>(std::max(opt.frames, 1)) * 4;
    pb.rate_hz = opt.rate_hz;
    const PipelineBenchResult r = runPipelineBench(pb);
    std::cout << "\n" << formatPipelineBench(r);
    pipeline_json = pipelineBenchJson(r);
  }
  if (!opt.json.empty()) {
    nlohmann::json j;
    j["source"] = opt.source;
    j["size"] = {size.width, size.height};
    j["offsets"] = offsets;
    j["frames"] = pairs.size();
    j["rounds"] = opt.rounds;
    j["threads"] = threads;
    j["processor"] = processor;
    j["kernels"] = simd::kernelName();
    j["stages_ms"] = stages;
    j["segmentation_ms"] = toJson(seg);
    j["stereobm_ms"] = toJson(sbm);
    j["ratio_vs_stereobm"] = ratio;
    j["without_obstacles_ms"] = toJson(pre);
    j["ratio_without_obstacles_vs_stereobm"] = pre_ratio;
    j["localization_ms"] = toJson(loc);
    j["detection_ms"] = toJson(det);
    j["per_frame"] = {{"obstacles", static_cast<double>(f.obstacles) / frames},
                      {"people", static_cast<double>(f.people) / frames},
                      {"hog_calls", static_cast<double>(f.hog_calls) / frames}};
    // Frame by frame (in the source's order), the fastest round: where the medians come from.
    j["per_frame_ms"] = {{"segmentation", f.segmentation_ms},
                         {"detection", f.detection_ms},
                         {"stereobm", stereobm_ms},
                         {"target_segmentation", t.segmentation_ms},
                         {"target_detection", t.detection_ms}};
    j["target_definition"] = {
        {"max_obstacles", std::min(max_obstacles, kTargetObstacles)},
        {"segmentation_ms", toJson(t_seg)},
        {"detection_ms", toJson(t_det)},
        {"ratio_vs_stereobm", t_ratio},
        {"obstacles_per_frame", static_cast<double>(t.obstacles) / frames},
        {"people_per_frame", static_cast<double>(t.people) / frames}};
    if (pipeline_json) j["pipeline"] = *pipeline_json;
    std::ofstream out(opt.json);
    out << j.dump(2) << "\n";
    if (!out) throw InputError("--json '" + opt.json + "': cannot write the file");
    std::cout << "  wrote " << opt.json << "\n";
  }
}

}  // namespace

void addBenchCommand(CLI::App& app) {
  auto opt = std::make_shared<BenchOptions>();
  auto* cmd = app.add_subcommand("bench", "per-stage timings of the segmentation and the detection, and OpenCV StereoBM on the same pairs");
  addSourceOption(*cmd, opt->source);
  cmd->add_option("--calib", opt->calib, "calibration file overriding the source's own");
  cmd->add_option("--config", opt->config,
                  "YAML with 'features', 'segmentation' and 'localizer' parameters (as detect's --config)");
  cmd->add_option("--frames", opt->frames, "frames measured")->capture_default_str();
  cmd->add_option("--rounds", opt->rounds,
                  "times every frame is measured; each figure keeps its fastest per frame (a shared machine only slows "
                  "runs down), then the median over the frames")
      ->capture_default_str();
  cmd->add_option("--threads", opt->threads, "TBB threads (0 = all hardware threads)")->capture_default_str();
  cmd->add_option("--json", opt->json, "write the figures to this JSON file");
  cmd->add_flag("--pipeline", opt->pipeline,
                "also the multi-process DDS pipeline on loopback: sustained frames/s and latency (4 x --frames)");
  cmd->add_option("--rate", opt->rate_hz, "with --pipeline: acquisition rate in frames/s (0 = as fast as possible)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10000.0));
  cmd->callback([opt] { runBench(*opt); });
}

}  // namespace sg::cli
