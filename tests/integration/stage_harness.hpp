#pragma once
// The DDS side of an integration test that drives one real stage process: a
// participant on the stage's domain that reads what the stage publishes and
// its StageMetrics (StageOutputs), optionally writing its input too
// (StageHarness), with the two steps every such test repeats: write a sample
// and wait until the stage has dealt with it, and wait for the stage to exit
// while collecting what is left (with its final StageMetrics).
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "dds/conversions.hpp"
#include "dds/dds.hpp"
#include "dds/stage_metrics.hpp"
#include "dds/topics.hpp"
#include "process_util.hpp"

namespace sg::test {

// Polls `pred` every 10 ms until it holds (true) or `timeout` passed (false).
template <class Pred>
bool waitUntil(std::chrono::milliseconds timeout, Pred pred) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

// QoS of a stage topic as the services use it: images for the frame topics, results for the others.
inline dds::QosParams stageTopicQos(const dds::TransportParams& transport, const std::string& topic) {
  return topic == dds::kStereoFrameTopic || topic == dds::kFeatureFrameTopic ? transport.images : transport.results;
}

// The same, deep enough that a test reads everything the stage published.
inline dds::QosParams keepAll(dds::QosParams q) {
  q.history_depth = 16;
  return q;
}

// A valid StereoFrame sample: frame `id` (and sample_seq `id`) of `rig`, with
// uniform noise images of the rig's size; `last` marks the end of the stream.
inline dds::StereoFrameData noiseFrame(std::uint64_t id, bool last, const StereoRig& rig,
                                       const std::string& source) {
  dds::StereoFrameData d;
  d.info.frame_id = id;
  d.info.capture_time_ns = dds::realtimeNowNs();
  d.info.source = source;
  d.info.sample_seq = id;
  d.info.end_of_stream = last;
  d.rig = rig;
  d.left = cv::Mat(rig.height, rig.width, CV_8UC1);
  d.right = cv::Mat(rig.height, rig.width, CV_8UC1);
  cv::RNG rng(id + 1);
  rng.fill(d.left, cv::RNG::UNIFORM, 0, 256);
  rng.fill(d.right, cv::RNG::UNIFORM, 0, 256);
  return d;
}

// Reads what a stage publishes on `Out` and its StageMetrics.
template <class Out>
class StageOutputs {
 public:
  using SampleFn = std::function<void(const Out&)>;

  StageOutputs(int domain, const char* out_name)
      : participant(domain),
        reader(participant, out_name, keepAll(stageTopicQos(transport, out_name))),
        metrics(participant, dds::kStageMetricsTopic, transport.metrics) {}

  // Takes what arrived: the frame ids of valid payloads into `published`,
  // every valid sample to `on_sample`, and the last StageMetrics (of the
  // stage named `stage`, when set) into `last`.
  void collect(const SampleFn& on_sample = {}) {
    reader.takeAll([&](const Out& sample) {
      if (sample.header.payload_valid) published.insert(sample.header.frame_id);
      if (on_sample) on_sample(sample);
    });
    metrics.takeAll([&](const sg_idl_StageMetrics& sample) {
      dds::StageMetricsData data = dds::readStageMetrics(sample);
      if (stage.empty() || data.stage == stage) last = std::move(data);
    });
  }

  // Waits (collecting meanwhile) until the stage process exits within
  // `timeout`, then up to 5 s more for its final StageMetrics. Success when
  // it exited with status 0.
  ::testing::AssertionResult finish(ChildProcess& process, const std::string& log,
                                    std::chrono::milliseconds timeout = std::chrono::seconds(20),
                                    const SampleFn& on_sample = {}) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    std::optional<int> status;
    for (;;) {
      collect(on_sample);
      status = process.waitFor(std::chrono::milliseconds(0));
      if (status || std::chrono::steady_clock::now() >= deadline) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!status) return ::testing::AssertionFailure() << "the stage did not stop\n" << tail(log);
    waitUntil(std::chrono::seconds(5), [&] {
      collect(on_sample);
      return last.final_report;
    });
    if (*status != 0) return ::testing::AssertionFailure() << "exit status " << *status << "\n" << tail(log);
    return ::testing::AssertionSuccess();
  }

  dds::TransportParams transport;
  dds::Participant participant;
  dds::TopicReader<Out> reader;
  dds::TopicReader<sg_idl_StageMetrics> metrics;
  std::set<std::uint64_t> published;  // frame ids of valid payloads
  dds::StageMetricsData last;         // the last StageMetrics
  std::string stage;                  // when not empty: StageMetrics of other stages are ignored
};

// Writes samples of `In` to a stage and reads what it publishes on `Out`.
template <class In, class Out>
class StageHarness : public StageOutputs<Out> {
 public:
  using typename StageOutputs<Out>::SampleFn;

  StageHarness(int domain, const char* in_name, const char* out_name)
      : StageOutputs<Out>(domain, out_name),
        writer(this->participant, in_name, stageTopicQos(this->transport, in_name)) {}

  // Waits until the stage matched the writer and this reader.
  ::testing::AssertionResult connected(const std::string& log,
                                       std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    if (!writer.waitForReaders(1, timeout, [] { return false; }) ||
        !waitUntil(timeout, [&] { return this->reader.matchedWriters() >= 1; })) {
      return ::testing::AssertionFailure() << "the stage did not match\n" << tail(log);
    }
    return ::testing::AssertionSuccess();
  }

  // Writes `sample` (frame `id`) and waits until the stage has dealt with it:
  // its StageMetrics count it as received, or it published frame `id`.
  ::testing::AssertionResult writeAndWait(const In& sample, std::uint64_t id, const std::string& log,
                                          std::chrono::milliseconds timeout = std::chrono::seconds(10),
                                          const SampleFn& on_sample = {}) {
    writer.write(sample);
    if (waitUntil(timeout, [&] {
          this->collect(on_sample);
          return this->last.frames_received >= id + 1 || this->published.count(id) > 0;
        })) {
      return ::testing::AssertionSuccess();
    }
    return ::testing::AssertionFailure() << "frame " << id << " was not dealt with\n" << tail(log);
  }

  dds::TopicWriter<In> writer;
};

}  // namespace sg::test
