#include "dds/stage_metrics.hpp"

#include <unistd.h>

#include <cstdlib>

#include "dds/conversions.hpp"

namespace sg::dds {

StageStats::StageStats(std::string stage)
    : metrics_(std::move(stage), kPeriodWindow), period_start_ns_(realtimeNowNs()) {}

void StageStats::fillMetrics(sg_idl_StageMetrics& out, bool final_report) {
  const std::int64_t now = realtimeNowNs();
  reported_ = metrics_.takePeriod();
  out.stage = const_cast<char*>(reported_.stage.c_str());
  out.pid = static_cast<std::int32_t>(getpid());
  out.time_ns = now;
  out.frames_received = reported_.frames_received;
  out.frames_published = reported_.frames_published;
  drop_scratch_.clear();
  for (const auto& [reason, count] : reported_.dropped_by_reason) {
    drop_scratch_.push_back(sg_idl_DropCount{const_cast<char*>(reason.c_str()), count});
  }
  out.dropped._maximum = static_cast<std::uint32_t>(drop_scratch_.size());
  out.dropped._length = static_cast<std::uint32_t>(drop_scratch_.size());
  out.dropped._buffer = drop_scratch_.empty() ? nullptr : drop_scratch_.data();
  out.dropped._release = false;
  out.processing_ms_p50 = reported_.processing_ms.p50;
  out.processing_ms_p99 = reported_.processing_ms.p99;
  out.latency_ms_p50 = reported_.latency_ms.p50;
  out.latency_ms_p99 = reported_.latency_ms.p99;
  const double period_s = static_cast<double>(now - period_start_ns_) * 1e-9;
  const auto period_published = static_cast<double>(reported_.frames_published - period_start_published_);
  out.frames_per_s = period_s > 0.0 ? period_published / period_s : 0.0;
  out.final_report = final_report;
  period_start_published_ = reported_.frames_published;
  period_start_ns_ = now;
}

namespace {
// A stage the launcher restarted after a crash (SG_RESTART_COUNT > 0): the
// samples its writers published before this process existed belong to the
// crashed process's accounting (or to the launcher's count of frames lost in
// the restart), not to this one's.
bool restartedProcess() {
  static const bool restarted = [] {
    const char* env = std::getenv("SG_RESTART_COUNT");
    return env != nullptr && std::atoi(env) > 0;
  }();
  return restarted;
}
}  // namespace

std::uint64_t SampleGapCounter::gapBefore(dds_instance_handle_t writer, std::uint64_t sample_seq) {
  auto [it, inserted] = next_.try_emplace(writer, sample_seq + 1);
  // Samples 0..seq-1 of a writer first seen now never arrived here.
  if (inserted) return restartedProcess() ? 0 : sample_seq;
  const std::uint64_t expected = it->second;
  it->second = sample_seq + 1;
  if (sample_seq < expected) return 0;  // same writer restarted its count (should not happen)
  return sample_seq - expected;
}

std::uint64_t StageMetricsData::droppedTotal() const {
  std::uint64_t total = 0;
  for (const auto& [reason, count] : dropped) total += count;
  return total;
}

StageMetricsData readStageMetrics(const sg_idl_StageMetrics& in) {
  StageMetricsData m;
  m.stage = in.stage != nullptr ? in.stage : "";
  m.pid = in.pid;
  m.time_ns = in.time_ns;
  m.frames_received = in.frames_received;
  m.frames_published = in.frames_published;
  for (std::uint32_t i = 0; i < in.dropped._length; ++i) {
    const sg_idl_DropCount& d = in.dropped._buffer[i];
    m.dropped[d.reason != nullptr ? d.reason : "unknown"] += d.count;
  }
  m.processing_ms_p50 = in.processing_ms_p50;
  m.processing_ms_p99 = in.processing_ms_p99;
  m.latency_ms_p50 = in.latency_ms_p50;
  m.latency_ms_p99 = in.latency_ms_p99;
  m.frames_per_s = in.frames_per_s;
  m.final_report = in.final_report;
  return m;
}

}  // namespace sg::dds
