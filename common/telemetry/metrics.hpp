#pragma once
// Per-stage metrics without any transport: frames received, published and
// dropped by reason, processing time and pipeline latency percentiles over a
// bounded window of recent samples. Services fill one StageMetrics from their
// processing thread and read snapshots from a reporting thread (or the same
// thread); every member function takes one mutex, held for O(1) except
// snapshot() (O(window) to sort the samples).
//
// Accounting: every frame a stage receives is either published or dropped with
// a reason, so received == published + dropped once the stage is idle;
// StageMetricsSnapshot::unaccounted() reports the difference.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace sg {

// Nearest-rank percentile (pct clamped to [0, 100]) of `values`; 0 for an
// empty set. Reorders `values`.
double nearestRankPercentile(std::vector<double>& values, double pct);

// The last `capacity` samples in a ring, with nearest-rank percentiles.
// Not thread-safe on its own (StageMetrics guards it).
class SampleWindow {
 public:
  explicit SampleWindow(std::size_t capacity = 1024);

  void add(double value);
  void clear();
  std::size_t size() const { return count_ < ring_.size() ? static_cast<std::size_t>(count_) : ring_.size(); }
  std::size_t capacity() const { return ring_.size(); }
  std::uint64_t total() const { return count_; }  // samples ever added

  // Nearest-rank percentile (pct in [0, 100]) of the samples in the window; 0 when empty.
  // Uses `scratch` so that the caller can reuse its buffer.
  double percentile(double pct, std::vector<double>& scratch) const;
  double percentile(double pct) const;
  double max() const;

 private:
  std::vector<double> ring_;
  std::size_t next_ = 0;
  std::uint64_t count_ = 0;
};

struct Percentiles {
  double p50 = 0.0;
  double p99 = 0.0;
  double max = 0.0;
  std::size_t samples = 0;  // samples in the window the figures come from
};

struct StageMetricsSnapshot {
  std::string stage;
  double uptime_s = 0.0;  // since the metrics were created (steady clock)
  std::uint64_t frames_received = 0;
  std::uint64_t frames_published = 0;
  std::uint64_t frames_dropped = 0;                      // sum over reasons
  std::map<std::string, std::uint64_t> dropped_by_reason;
  Percentiles processing_ms;  // time the stage spent on a frame (milliseconds)
  Percentiles latency_ms;     // publication time minus the frame's capture time (milliseconds)

  // Received frames neither published nor dropped (in flight, or lost by a bug).
  std::int64_t unaccounted() const {
    return static_cast<std::int64_t>(frames_received) - static_cast<std::int64_t>(frames_published) -
           static_cast<std::int64_t>(frames_dropped);
  }
  // "features: received 20, published 19, dropped 1 (superseded 1), processing p50 0.8 ms p99 1.2 ms, ..."
  std::string summary() const;
  // The counts alone: "received 20, published 19, dropped 1 (superseded 1)".
  std::string countsSummary() const;
};

class StageMetrics {
 public:
  explicit StageMetrics(std::string stage, std::size_t window = 1024);
  StageMetrics(const StageMetrics&) = delete;
  StageMetrics& operator=(const StageMetrics&) = delete;

  void received(std::uint64_t frames = 1);
  void published(std::uint64_t frames = 1);
  // Counts dropped frames under `reason` (e.g. "superseded", "malformed", "processing_error").
  void dropped(const std::string& reason, std::uint64_t frames = 1);
  void processingTime(double ms);
  void latency(double ms);
  // Both in one lock: a published frame with its latency.
  void publishedWithLatency(double latency_ms);

  StageMetricsSnapshot snapshot() const;
  // A snapshot that ends a reporting period: the sample windows start empty
  // again, so the next snapshot's percentiles cover only what came after.
  StageMetricsSnapshot takePeriod();
  const std::string& stage() const { return stage_; }
  // The counts alone (no percentiles), for checks on every frame.
  std::uint64_t framesReceived() const;
  std::uint64_t framesPublished() const;
  std::uint64_t framesDropped() const;

 private:
  const std::string stage_;
  const std::chrono::steady_clock::time_point start_;
  mutable std::mutex mutex_;
  std::uint64_t received_ = 0;
  std::uint64_t published_ = 0;
  std::map<std::string, std::uint64_t> drops_;
  SampleWindow processing_ms_;
  SampleWindow latency_ms_;
  mutable std::vector<double> scratch_;

  StageMetricsSnapshot snapshotLocked() const;  // with mutex_ held
};

// Milliseconds on the steady clock since construction or the last restart().
class StopWatch {
 public:
  StopWatch() : start_(std::chrono::steady_clock::now()) {}
  void restart() { start_ = std::chrono::steady_clock::now(); }
  double elapsedMs() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace sg
