#include "pipeline_bench.hpp"

#include <chrono>
#include <cstdlib>
#include <iomanip>
#include <sstream>
#include <vector>

#include "config/errors.hpp"
#include "dds/dds.hpp"
#include "dds/stage_metrics.hpp"
#include "io/frame_source.hpp"
#include "supervisor.hpp"
#include "vision/detector.hpp"

namespace sg::cli {

namespace {

void inProcess(const PipelineBenchOptions& options, PipelineBenchResult& result) {
  auto source = openFrameSource(options.source, options.calib);
  std::vector<StereoPair> pairs;
  for (int i = 0; i < std::max(1, options.preload); ++i) {
    StereoPair pair;
    if (!source->next(pair)) break;
    pairs.push_back(std::move(pair));
  }
  if (pairs.empty()) throw InputError("source " + options.source + " has no frames");
  result.width = pairs.front().left.cols;
  result.height = pairs.front().left.rows;
  Detector detector(DetectorParams{});
  DetectionResult out;
  std::vector<double> ms;
  const std::uint64_t n = std::max<std::uint64_t>(options.frames / 4, pairs.size() * 2);
  detector.compute(pairs[0].left, pairs[0].right, pairs[0].rig, 0.0, out);  // warm-up, not timed
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t i = 0; i < n; ++i) {
    const StereoPair& p = pairs[i % pairs.size()];
    const auto t0 = std::chrono::steady_clock::now();
    detector.compute(p.left, p.right, p.rig, 0.1 * static_cast<double>(i + 1), out);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.in_process_fps = static_cast<double>(n) / total_s;
  result.in_process_ms_p50 = dds::percentile(ms, 50.0);
  result.in_process_ms_p99 = dds::percentile(ms, 99.0);
}

}  // namespace

PipelineBenchResult runPipelineBench(const PipelineBenchOptions& options) {
  dds::ShutdownSignal signals;
  PipelineOptions pipeline;
  pipeline.params.rate_hz = options.rate_hz;
  pipeline.params.display = false;
  pipeline.params.domain_id = options.domain_id >= 0 ? options.domain_id : static_cast<int>(dds::domainId(0));
  pipeline.source = options.source;
  pipeline.calib = options.calib;
  pipeline.frames = options.frames;
  pipeline.preload = options.preload;
  pipeline.table = false;
  pipeline.quiet_children = true;
  const PipelineSummary summary = runPipeline(pipeline, signals);
  if (summary.interrupted) throw InputError("pipeline benchmark interrupted");

  PipelineBenchResult result;
  result.frames_in = summary.frames_in;
  result.delivered = summary.delivered;
  result.dropped = summary.dropped;
  result.unaccounted = summary.unaccounted;
  result.fps = summary.observed_fps;
  std::vector<double> lat = summary.latency_ms;
  result.latency_ms_p50 = dds::percentile(lat, 50.0);
  result.latency_ms_p99 = dds::percentile(lat, 99.0);
  if (options.in_process) inProcess(options, result);
  return result;
}

nlohmann::json pipelineBenchJson(const PipelineBenchResult& r) {
  return {{"size", {r.width, r.height}},
          {"fps", r.fps},
          {"latency_ms", {{"p50", r.latency_ms_p50}, {"p99", r.latency_ms_p99}}},
          {"frames_in", r.frames_in},
          {"delivered", r.delivered},
          {"dropped", r.dropped},
          {"unaccounted", r.unaccounted},
          {"in_process", {{"fps", r.in_process_fps}, {"ms", {{"p50", r.in_process_ms_p50}, {"p99", r.in_process_ms_p99}}}}}};
}

std::string formatPipelineBench(const PipelineBenchResult& r) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1);
  out << "pipeline (" << r.width << "x" << r.height << ", one process per stage, loopback DDS): " << r.fps
      << " frames/s, latency p50 " << r.latency_ms_p50 << " ms, p99 " << r.latency_ms_p99 << " ms; frames in "
      << r.frames_in << ", delivered " << r.delivered << ", dropped " << r.dropped << ", unaccounted "
      << r.unaccounted << "\n";
  out << "in one process (same frames, one Detector): " << r.in_process_fps << " frames/s, p50 "
      << r.in_process_ms_p50 << " ms, p99 " << r.in_process_ms_p99 << " ms per frame\n";
  return out.str();
}

}  // namespace sg::cli
