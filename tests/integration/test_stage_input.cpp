// A real stereoguard-features process on loopback DDS, fed by this test: the
// output equals an in-process FeatureExtractor, and a malformed sample
// (declared size disagreeing with its data) is counted, logged and the stage
// keeps serving the next frame.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "dds/conversions.hpp"
#include "dds/dds.hpp"
#include "dds/stage_metrics.hpp"
#include "dds/topics.hpp"
#include "process_util.hpp"
#include "vision/feature_image.hpp"

namespace sg {
namespace {

using namespace std::chrono_literals;
constexpr int kDomain = 181;  // one domain per integration test: they may run in parallel

template <class T, class Pred>
bool waitUntil(std::chrono::milliseconds timeout, Pred pred) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(10ms);
  }
  return false;
}

dds::StereoFrameData frame(std::uint64_t id, bool last) {
  dds::StereoFrameData d;
  d.info.frame_id = id;
  d.info.capture_time_ns = dds::realtimeNowNs();
  d.info.source = "test" + std::to_string(id);
  d.info.sample_seq = id;
  d.info.end_of_stream = last;
  d.rig.focal_px = 500;
  d.rig.cx_px = 80;
  d.rig.cy_px = 60;
  d.rig.baseline_m = 0.3;
  d.rig.width = 160;
  d.rig.height = 120;
  d.left = cv::Mat(120, 160, CV_8UC1);
  d.right = cv::Mat(120, 160, CV_8UC1);
  cv::RNG rng(id + 1);
  rng.fill(d.left, cv::RNG::UNIFORM, 0, 256);
  rng.fill(d.right, cv::RNG::UNIFORM, 0, 256);
  return d;
}

TEST(StageInput, MalformedSampleIsCountedAndTheStageKeepsServing) {
  test::useLoopbackDds();
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/features_malformed.log";
  dds::Participant participant(kDomain);
  dds::TransportParams transport;
  dds::Topic<sg_idl_StereoFrame> in_topic(participant, dds::kStereoFrameTopic);
  dds::Topic<sg_idl_FeatureFrame> out_topic(participant, dds::kFeatureFrameTopic);
  dds::Topic<sg_idl_StageMetrics> metrics_topic(participant, dds::kStageMetricsTopic);
  dds::Writer<sg_idl_StereoFrame> writer(participant, in_topic, transport.images);
  dds::QosParams keep_all_outputs = transport.images;
  keep_all_outputs.history_depth = 8;  // the test reads everything the stage published
  dds::Reader<sg_idl_FeatureFrame> reader(participant, out_topic, keep_all_outputs);
  dds::Reader<sg_idl_StageMetrics> metrics(participant, metrics_topic, transport.metrics);

  test::ChildProcess stage({SG_FEATURES_EXE, "--frames", "3"},
                           {{"SG_DDS_DOMAIN", std::to_string(kDomain)}, {"CYCLONEDDS_URI", test::loopbackUri()}}, log);
  ASSERT_TRUE(writer.waitForReaders(1, 20s, [] { return false; })) << test::tail(log);
  ASSERT_TRUE(waitUntil<int>(20s, [&] { return reader.matchedWriters() >= 1; })) << test::tail(log);

  std::vector<dds::FeatureFrameData> outputs;
  auto collect = [&] {
    auto samples = reader.take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (!samples.valid(i) || !samples[i].header.payload_valid) continue;
      outputs.emplace_back();
      dds::readFeatureFrame(samples[i], outputs.back());
    }
  };
  dds::StageMetricsData last_metrics;
  auto collectMetrics = [&] {
    auto samples = metrics.take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (samples.valid(i)) last_metrics = dds::readStageMetrics(samples[i]);
    }
  };

  // Frame 0: valid.
  const dds::StereoFrameData f0 = frame(0, false);
  sg_idl_StereoFrame msg{};
  dds::fillStereoFrame(f0, msg);
  writer.write(msg);
  ASSERT_TRUE(waitUntil<int>(10s, [&] { collect(); return outputs.size() == 1; })) << test::tail(log);

  // Frame 1: declares 161 columns but carries 160 x 120 bytes.
  const dds::StereoFrameData f1 = frame(1, false);
  dds::fillStereoFrame(f1, msg);
  msg.width = 161;
  writer.write(msg);
  ASSERT_TRUE(waitUntil<int>(10s, [&] {
    collectMetrics();
    return last_metrics.dropped.count("malformed") > 0;
  })) << test::tail(log);

  // Frame 2: valid, the last one.
  const dds::StereoFrameData f2 = frame(2, true);
  dds::fillStereoFrame(f2, msg);
  writer.write(msg);
  ASSERT_TRUE(waitUntil<int>(10s, [&] { collect(); return outputs.size() == 2; })) << test::tail(log);

  const auto status = stage.waitFor(15s);
  ASSERT_TRUE(status.has_value()) << "the stage did not stop after its last frame\n" << test::tail(log);
  EXPECT_EQ(*status, 0) << test::tail(log);
  waitUntil<int>(5s, [&] { collectMetrics(); return last_metrics.final_report; });
  EXPECT_TRUE(last_metrics.final_report);
  EXPECT_EQ(last_metrics.frames_received, 3u);
  EXPECT_EQ(last_metrics.frames_published, 2u);
  EXPECT_EQ(last_metrics.dropped["malformed"], 1u);
  EXPECT_EQ(last_metrics.frames_received, last_metrics.frames_published + last_metrics.droppedTotal());
  EXPECT_NE(test::readFile(log).find("malformed"), std::string::npos) << "the drop was not logged";

  // What came out is the feature image of what went in.
  FeatureExtractor extractor;
  cv::Mat expected;
  ASSERT_EQ(outputs[0].info.frame_id, 0u);
  ASSERT_EQ(outputs[1].info.frame_id, 2u);
  extractor.compute(f0.left, expected);
  EXPECT_EQ(cv::norm(expected, outputs[0].left_features, cv::NORM_INF), 0.0);
  extractor.compute(f2.right, expected);
  EXPECT_EQ(cv::norm(expected, outputs[1].right_features, cv::NORM_INF), 0.0);
  EXPECT_TRUE(outputs[1].info.end_of_stream);
}

TEST(StageInput, ServiceRefusesToStartWithoutDdsConfig) {
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/features_no_uri.log";
  test::ChildProcess stage({SG_FEATURES_EXE, "--frames", "1"}, {{"CYCLONEDDS_URI", ""}}, log);
  const auto status = stage.waitFor(20s);
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(*status, 2);
  EXPECT_NE(test::readFile(log).find("CYCLONEDDS_URI is not set"), std::string::npos) << test::tail(log);
}

}  // namespace
}  // namespace sg
