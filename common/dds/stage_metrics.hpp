#pragma once
// Per-stage frame accounting and timing, published as StageMetrics.
//
// Accounting rule: every frame id that reaches a stage is either published by
// it or counted as dropped with a reason:
//   superseded        a sample the upstream writer published never reached this
//                     reader (KEEP_LAST replaced it): a gap in FrameHeader.sample_seq
//   malformed         the sample failed validation (dds/conversions.hpp)
//   processing_error  the core threw on this frame
//   join_timeout      localization: the matching grey frame never arrived
//   join_evicted      localization: the grey frame left the bounded join buffers
//                     (cache, reader history) before its segmentation came
// A gap in frame_id without a gap in sample_seq is a frame an earlier stage
// dropped and counted itself; it is not counted again.
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "stereoguard.h"

namespace sg::dds {

inline constexpr const char* kDropSuperseded = "superseded";
inline constexpr const char* kDropMalformed = "malformed";
inline constexpr const char* kDropProcessingError = "processing_error";
inline constexpr const char* kDropJoinTimeout = "join_timeout";
inline constexpr const char* kDropJoinEvicted = "join_evicted";
inline constexpr const char* kDropSourceError = "source_error";

// Not thread-safe: one per service, used from its main loop.
class StageStats {
 public:
  explicit StageStats(std::string stage);

  void received(std::uint64_t frames = 1) { received_ += frames; }
  void published(double latency_ms);
  void dropped(const std::string& reason, std::uint64_t frames = 1);
  void processed(double processing_ms) { processing_ms_.push_back(processing_ms); }

  const std::string& stage() const { return stage_; }
  std::uint64_t framesReceived() const { return received_; }
  std::uint64_t framesPublished() const { return published_; }
  std::uint64_t framesDropped() const;
  const std::map<std::string, std::uint64_t>& drops() const { return drops_; }

  // Fills `out` (borrowing strings from this object until the next call) and
  // starts a new reporting period for the percentiles and the rate.
  void fillMetrics(sg_idl_StageMetrics& out, bool final_report);
  // "received 20, published 19, dropped 1 (superseded 1)".
  std::string summary() const;

 private:
  std::string stage_;
  std::uint64_t received_ = 0;
  std::uint64_t published_ = 0;
  std::map<std::string, std::uint64_t> drops_;
  std::vector<double> processing_ms_;  // this period
  std::vector<double> latency_ms_;     // this period
  std::uint64_t period_published_ = 0;
  std::int64_t period_start_ns_ = 0;
  std::vector<sg_idl_DropCount> drop_scratch_;
};

// Percentile (0..100) by nearest rank; 0 for an empty set. Reorders `values`.
double percentile(std::vector<double>& values, double pct);

// Counts samples lost between one writer and this reader from FrameHeader.sample_seq.
class SampleGapCounter {
 public:
  // Number of samples `writer` published before `sample_seq` that were never
  // seen here. A writer that restarted (sequence went back) starts afresh.
  std::uint64_t gapBefore(dds_instance_handle_t writer, std::uint64_t sample_seq);

 private:
  std::unordered_map<dds_instance_handle_t, std::uint64_t> next_;
};

// A StageMetrics sample as read by the launcher, the display and tests.
struct StageMetricsData {
  std::string stage;
  int pid = 0;
  std::int64_t time_ns = 0;
  std::uint64_t frames_received = 0;
  std::uint64_t frames_published = 0;
  std::map<std::string, std::uint64_t> dropped;
  double processing_ms_p50 = 0.0;
  double processing_ms_p99 = 0.0;
  double latency_ms_p50 = 0.0;
  double latency_ms_p99 = 0.0;
  double frames_per_s = 0.0;
  bool final_report = false;

  std::uint64_t droppedTotal() const;
};
StageMetricsData readStageMetrics(const sg_idl_StageMetrics& in);

}  // namespace sg::dds
