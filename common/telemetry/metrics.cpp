#include "telemetry/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace sg {

SampleWindow::SampleWindow(std::size_t capacity) : ring_(capacity == 0 ? 1 : capacity, 0.0) {}

void SampleWindow::add(double value) {
  ring_[next_] = value;
  next_ = (next_ + 1) % ring_.size();
  ++count_;
}

void SampleWindow::clear() {
  next_ = 0;
  count_ = 0;
}

double nearestRankPercentile(std::vector<double>& values, double pct) {
  const std::size_t n = values.size();
  if (n == 0) return 0.0;
  const double clamped = std::clamp(pct, 0.0, 100.0);
  // Nearest rank: the smallest value with at least pct % of the samples at or below it.
  const auto rank = static_cast<std::size_t>(std::ceil(clamped / 100.0 * static_cast<double>(n)));
  const std::size_t index = rank == 0 ? 0 : rank - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(index), values.end());
  return values[index];
}

double SampleWindow::percentile(double pct, std::vector<double>& scratch) const {
  scratch.assign(ring_.begin(), ring_.begin() + static_cast<std::ptrdiff_t>(size()));
  return nearestRankPercentile(scratch, pct);
}

double SampleWindow::percentile(double pct) const {
  std::vector<double> scratch;
  return percentile(pct, scratch);
}

double SampleWindow::max() const {
  const std::size_t n = size();
  if (n == 0) return 0.0;
  return *std::max_element(ring_.begin(), ring_.begin() + static_cast<std::ptrdiff_t>(n));
}

namespace {

Percentiles percentilesOf(const SampleWindow& window, std::vector<double>& scratch) {
  Percentiles p;
  p.samples = window.size();
  p.p50 = window.percentile(50.0, scratch);
  p.p99 = window.percentile(99.0, scratch);
  p.max = window.max();
  return p;
}

}  // namespace

StageMetrics::StageMetrics(std::string stage, std::size_t window)
    : stage_(std::move(stage)),
      start_(std::chrono::steady_clock::now()),
      processing_ms_(window),
      latency_ms_(window) {}

void StageMetrics::received(std::uint64_t frames) {
  const std::lock_guard lock(mutex_);
  received_ += frames;
}

void StageMetrics::published(std::uint64_t frames) {
  const std::lock_guard lock(mutex_);
  published_ += frames;
}

void StageMetrics::dropped(const std::string& reason, std::uint64_t frames) {
  const std::lock_guard lock(mutex_);
  drops_[reason.empty() ? std::string("unspecified") : reason] += frames;
}

void StageMetrics::processingTime(double ms) {
  const std::lock_guard lock(mutex_);
  processing_ms_.add(ms);
}

void StageMetrics::latency(double ms) {
  const std::lock_guard lock(mutex_);
  latency_ms_.add(ms);
}

void StageMetrics::publishedWithLatency(double latency_ms) {
  const std::lock_guard lock(mutex_);
  ++published_;
  latency_ms_.add(latency_ms);
}

StageMetricsSnapshot StageMetrics::snapshot() const {
  const std::lock_guard lock(mutex_);
  return snapshotLocked();
}

StageMetricsSnapshot StageMetrics::takePeriod() {
  const std::lock_guard lock(mutex_);
  StageMetricsSnapshot s = snapshotLocked();
  processing_ms_.clear();
  latency_ms_.clear();
  return s;
}

StageMetricsSnapshot StageMetrics::snapshotLocked() const {
  StageMetricsSnapshot s;
  s.stage = stage_;
  s.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  s.frames_received = received_;
  s.frames_published = published_;
  s.dropped_by_reason = drops_;
  for (const auto& [reason, count] : drops_) s.frames_dropped += count;
  s.processing_ms = percentilesOf(processing_ms_, scratch_);
  s.latency_ms = percentilesOf(latency_ms_, scratch_);
  return s;
}

std::uint64_t StageMetrics::framesReceived() const {
  const std::lock_guard lock(mutex_);
  return received_;
}

std::uint64_t StageMetrics::framesPublished() const {
  const std::lock_guard lock(mutex_);
  return published_;
}

std::uint64_t StageMetrics::framesDropped() const {
  const std::lock_guard lock(mutex_);
  std::uint64_t total = 0;
  for (const auto& [reason, count] : drops_) total += count;
  return total;
}

std::string StageMetricsSnapshot::countsSummary() const {
  std::ostringstream out;
  out << "received " << frames_received << ", published " << frames_published << ", dropped " << frames_dropped;
  if (!dropped_by_reason.empty()) {
    out << " (";
    bool first = true;
    for (const auto& [reason, count] : dropped_by_reason) {
      out << (first ? "" : ", ") << reason << " " << count;
      first = false;
    }
    out << ")";
  }
  return out.str();
}

std::string StageMetricsSnapshot::summary() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1);
  out << stage << ": " << countsSummary();
  if (processing_ms.samples > 0) {
    out << ", processing p50 " << processing_ms.p50 << " ms p99 " << processing_ms.p99 << " ms";
  }
  if (latency_ms.samples > 0) out << ", latency p50 " << latency_ms.p50 << " ms p99 " << latency_ms.p99 << " ms";
  return out.str();
}

}  // namespace sg
