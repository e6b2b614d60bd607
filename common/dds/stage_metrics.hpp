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
#include "telemetry/metrics.hpp"

namespace sg::dds {

inline constexpr const char* kDropSuperseded = "superseded";
inline constexpr const char* kDropMalformed = "malformed";
inline constexpr const char* kDropProcessingError = "processing_error";
inline constexpr const char* kDropJoinTimeout = "join_timeout";
inline constexpr const char* kDropJoinEvicted = "join_evicted";
inline constexpr const char* kDropSourceError = "source_error";

// A stage's frame accounting and timing as published in StageMetrics
// samples. The counting itself is sg::StageMetrics (telemetry/metrics.hpp);
// this adds the reporting periods (percentiles and the rate cover one period)
// and the one conversion of its snapshot into the DDS sample.
// One per service, used from its main loop.
class StageStats {
 public:
  // Samples kept per period for the percentiles (the most recent when a period has more).
  static constexpr std::size_t kPeriodWindow = 8192;

  explicit StageStats(std::string stage);

  void received(std::uint64_t frames = 1) { metrics_.received(frames); }
  void published(double latency_ms) { metrics_.publishedWithLatency(latency_ms); }
  void dropped(const std::string& reason, std::uint64_t frames = 1) {
    if (frames > 0) metrics_.dropped(reason, frames);
  }
  void processed(double processing_ms) { metrics_.processingTime(processing_ms); }

  const std::string& stage() const { return metrics_.stage(); }
  std::uint64_t framesReceived() const { return metrics_.framesReceived(); }
  std::uint64_t framesPublished() const { return metrics_.framesPublished(); }
  std::uint64_t framesDropped() const { return metrics_.framesDropped(); }
  const StageMetrics& metrics() const { return metrics_; }

  // Fills `out` (borrowing strings from this object until the next call) and
  // starts a new reporting period for the percentiles and the rate.
  void fillMetrics(sg_idl_StageMetrics& out, bool final_report);
  // "received 20, published 19, dropped 1 (superseded 1)".
  std::string summary() const { return metrics_.snapshot().countsSummary(); }

 private:
  StageMetrics metrics_;
  StageMetricsSnapshot reported_;  // what the last sample borrows from
  std::vector<sg_idl_DropCount> drop_scratch_;
  std::uint64_t period_start_published_ = 0;
  std::int64_t period_start_ns_ = 0;
};

// Percentile (0..100) by nearest rank; 0 for an empty set. Reorders `values`.
inline double percentile(std::vector<double>& values, double pct) { return nearestRankPercentile(values, pct); }

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
