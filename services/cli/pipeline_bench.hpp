#pragma once
// `stereoguard bench --pipeline`: the multi-process DDS pipeline's sustained
// frames/s and end-to-end latency, next to the same frames in one process.
//
// For cmd_bench.cpp: call runPipelineBench() when --pipeline is given and put
// pipelineBenchJson(result) under "pipeline" in the --json output. Construct
// nothing that starts threads before it (it blocks SIGINT/SIGTERM first so
// Ctrl-C stops the child processes cleanly).
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace sg::cli {

struct PipelineBenchOptions {
  std::string source = "synthetic";  // frame source SPEC
  std::string calib;
  std::uint64_t frames = 200;        // frames published by acquisition
  int preload = 10;                  // distinct frames, read once and repeated (the source's own cost excluded)
  double rate_hz = 5.0;              // acquisition rate (frames/s); 0 = as fast as the stages take them
  int domain_id = -1;                // -1: SG_DDS_DOMAIN, else 0
  bool in_process = true;            // also run the same frames through one Detector in this process
};

struct PipelineBenchResult {
  int width = 0;
  int height = 0;
  std::uint64_t frames_in = 0;
  std::uint64_t delivered = 0;
  std::uint64_t dropped = 0;
  std::int64_t unaccounted = 0;
  double fps = 0.0;                  // detections received per second (sustained, launcher side)
  double latency_ms_p50 = 0.0;       // capture -> detections received, one frame
  double latency_ms_p99 = 0.0;
  double in_process_fps = 0.0;       // one Detector, same frames, serial loop
  double in_process_ms_p50 = 0.0;
  double in_process_ms_p99 = 0.0;
};

PipelineBenchResult runPipelineBench(const PipelineBenchOptions& options);

// {"fps": .., "latency_ms": {"p50": .., "p99": ..}, "frames_in": .., "delivered": .., "dropped": ..,
//  "unaccounted": .., "in_process": {"fps": .., "ms": {"p50": .., "p99": ..}}}
nlohmann::json pipelineBenchJson(const PipelineBenchResult& result);
std::string formatPipelineBench(const PipelineBenchResult& result);

}  // namespace sg::cli
