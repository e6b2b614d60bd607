// StageMetrics: frame accounting, nearest-rank percentiles over a bounded
// window, and consistency under a writer thread plus a reporting thread.
#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "telemetry/metrics.hpp"

namespace sg {
namespace {

TEST(SampleWindow, NearestRankPercentiles) {
  SampleWindow w(1000);
  for (int i = 100; i >= 1; --i) w.add(i);  // order must not matter
  EXPECT_EQ(w.size(), 100u);
  EXPECT_DOUBLE_EQ(w.percentile(50.0), 50.0);
  EXPECT_DOUBLE_EQ(w.percentile(99.0), 99.0);
  EXPECT_DOUBLE_EQ(w.percentile(100.0), 100.0);
  EXPECT_DOUBLE_EQ(w.percentile(0.0), 1.0);
  EXPECT_DOUBLE_EQ(w.max(), 100.0);
}

TEST(SampleWindow, EmptyWindowGivesZero) {
  const SampleWindow w(8);
  EXPECT_EQ(w.size(), 0u);
  EXPECT_DOUBLE_EQ(w.percentile(50.0), 0.0);
  EXPECT_DOUBLE_EQ(w.max(), 0.0);
}

TEST(SampleWindow, KeepsOnlyTheLastSamples) {
  SampleWindow w(100);
  for (int i = 0; i < 1000; ++i) w.add(i < 900 ? 1000.0 : static_cast<double>(i - 900));  // last 100: 0..99
  EXPECT_EQ(w.size(), 100u);
  EXPECT_EQ(w.total(), 1000u);
  EXPECT_DOUBLE_EQ(w.percentile(50.0), 49.0);
  EXPECT_DOUBLE_EQ(w.max(), 99.0);
}

TEST(SampleWindow, SingleSample) {
  SampleWindow w(4);
  w.add(7.5);
  EXPECT_DOUBLE_EQ(w.percentile(1.0), 7.5);
  EXPECT_DOUBLE_EQ(w.percentile(99.0), 7.5);
}

TEST(StageMetrics, CountsAndDropReasons) {
  StageMetrics m("features", 64);
  m.received(10);
  m.published(6);
  m.dropped("superseded", 2);
  m.dropped("malformed");
  m.dropped("superseded");
  for (int i = 1; i <= 6; ++i) m.processingTime(i);
  m.latency(12.0);
  const StageMetricsSnapshot s = m.snapshot();
  EXPECT_EQ(s.stage, "features");
  EXPECT_EQ(s.frames_received, 10u);
  EXPECT_EQ(s.frames_published, 6u);
  EXPECT_EQ(s.frames_dropped, 4u);
  EXPECT_EQ(s.dropped_by_reason.at("superseded"), 3u);
  EXPECT_EQ(s.dropped_by_reason.at("malformed"), 1u);
  EXPECT_EQ(s.unaccounted(), 0);
  EXPECT_EQ(s.processing_ms.samples, 6u);
  EXPECT_DOUBLE_EQ(s.processing_ms.p50, 3.0);
  EXPECT_DOUBLE_EQ(s.processing_ms.p99, 6.0);
  EXPECT_DOUBLE_EQ(s.latency_ms.p50, 12.0);
  const std::string text = s.summary();
  EXPECT_NE(text.find("dropped 4 (malformed 1, superseded 3)"), std::string::npos) << text;
}

TEST(StageMetrics, InFlightFramesAreUnaccounted) {
  StageMetrics m("segmentation");
  m.received(3);
  m.publishedWithLatency(5.0);
  EXPECT_EQ(m.snapshot().unaccounted(), 2);
}

TEST(StageMetrics, EmptyReasonIsNamedUnspecified) {
  StageMetrics m("x");
  m.dropped("");
  EXPECT_EQ(m.snapshot().dropped_by_reason.count("unspecified"), 1u);
}

TEST(StageMetrics, TakePeriodRestartsThePercentilesButNotTheCounts) {
  StageMetrics m("features", 64);
  m.received(2);
  m.publishedWithLatency(10.0);
  m.processingTime(4.0);
  const StageMetricsSnapshot first = m.takePeriod();
  EXPECT_DOUBLE_EQ(first.latency_ms.p50, 10.0);
  EXPECT_EQ(first.processing_ms.samples, 1u);
  m.publishedWithLatency(20.0);
  const StageMetricsSnapshot second = m.takePeriod();
  EXPECT_EQ(second.frames_received, 2u);
  EXPECT_EQ(second.frames_published, 2u);
  EXPECT_EQ(second.latency_ms.samples, 1u);
  EXPECT_DOUBLE_EQ(second.latency_ms.p50, 20.0);
  EXPECT_EQ(second.processing_ms.samples, 0u);
  EXPECT_EQ(m.framesReceived(), 2u);
  EXPECT_EQ(m.framesPublished(), 2u);
  EXPECT_EQ(m.framesDropped(), 0u);
  EXPECT_EQ(second.countsSummary(), "received 2, published 2, dropped 0");
}

TEST(StageMetrics, ServiceThreadAndReportingThreadAgree) {
  StageMetrics m("localization", 256);
  constexpr int kFrames = 20000;
  std::atomic<bool> done{false};
  std::thread service([&] {
    for (int i = 0; i < kFrames; ++i) {
      m.received();
      if (i % 10 == 0) {
        m.dropped("join_timeout");
      } else {
        m.processingTime(1.0);
        m.publishedWithLatency(2.0);
      }
    }
    done = true;
  });
  int reports = 0;
  do {
    const StageMetricsSnapshot s = m.snapshot();
    // Counters only grow and never overtake what was received.
    EXPECT_LE(s.frames_published + s.frames_dropped, s.frames_received);
    ++reports;
    std::this_thread::yield();
  } while (!done);
  service.join();
  const StageMetricsSnapshot s = m.snapshot();
  EXPECT_EQ(s.frames_received, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(s.frames_dropped, static_cast<std::uint64_t>(kFrames / 10));
  EXPECT_EQ(s.unaccounted(), 0);
  EXPECT_EQ(s.latency_ms.samples, 256u);
  EXPECT_DOUBLE_EQ(s.latency_ms.p99, 2.0);
  EXPECT_GT(reports, 0);
}

TEST(StopWatch, MeasuresForward) {
  StopWatch w;
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  EXPECT_GE(w.elapsedMs(), 1.0);
}

}  // namespace
}  // namespace sg
