// A real stereoguard-features process on loopback DDS, fed by this test: the
// output equals an in-process FeatureExtractor, and a malformed sample
// (declared size disagreeing with its data) is counted, logged and the stage
// keeps serving the next frame.
#include <chrono>

#include <gtest/gtest.h>

#include "stage_harness.hpp"
#include "vision/feature_image.hpp"

namespace sg {
namespace {

using namespace std::chrono_literals;
constexpr int kDomain = 181;  // one domain per integration test: they may run in parallel

dds::StereoFrameData frame(std::uint64_t id, bool last) {
  StereoRig rig;
  rig.focal_px = 500;
  rig.cx_px = 80;
  rig.cy_px = 60;
  rig.baseline_m = 0.3;
  rig.width = 160;
  rig.height = 120;
  return test::noiseFrame(id, last, rig, "test" + std::to_string(id));
}

TEST(StageInput, MalformedSampleIsCountedAndTheStageKeepsServing) {
  test::useLoopbackDds();
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/features_malformed.log";
  test::StageHarness<sg_idl_StereoFrame, sg_idl_FeatureFrame> h(kDomain, dds::kStereoFrameTopic,
                                                                 dds::kFeatureFrameTopic);
  test::ChildProcess stage({SG_FEATURES_EXE, "--frames", "3"}, test::loopbackEnv(kDomain), log);
  ASSERT_TRUE(h.connected(log));

  std::vector<dds::FeatureFrameData> outputs;
  const auto keep = [&](const sg_idl_FeatureFrame& sample) {
    if (!sample.header.payload_valid) return;
    outputs.emplace_back();
    dds::readFeatureFrame(sample, outputs.back());
  };

  // Frame 0: valid.
  const dds::StereoFrameData f0 = frame(0, false);
  sg_idl_StereoFrame msg{};
  dds::fillStereoFrame(f0, msg);
  ASSERT_TRUE(h.writeAndWait(msg, 0, log, 10s, keep));

  // Frame 1: declares 161 columns but carries 160 x 120 bytes.
  const dds::StereoFrameData f1 = frame(1, false);
  dds::fillStereoFrame(f1, msg);
  msg.width = 161;
  ASSERT_TRUE(h.writeAndWait(msg, 1, log, 10s, keep));

  // Frame 2: valid, the last one.
  const dds::StereoFrameData f2 = frame(2, true);
  dds::fillStereoFrame(f2, msg);
  ASSERT_TRUE(h.writeAndWait(msg, 2, log, 10s, keep));

  ASSERT_TRUE(h.finish(stage, log, 15s, keep));
  dds::StageMetricsData last_metrics = h.last;
  EXPECT_TRUE(last_metrics.final_report);
  EXPECT_EQ(last_metrics.frames_received, 3u);
  EXPECT_EQ(last_metrics.frames_published, 2u);
  EXPECT_EQ(last_metrics.dropped["malformed"], 1u);
  EXPECT_EQ(last_metrics.frames_received, last_metrics.frames_published + last_metrics.droppedTotal());
  EXPECT_NE(test::readFile(log).find("malformed"), std::string::npos) << "the drop was not logged";

  // What came out is the feature image of what went in.
  FeatureExtractor extractor;
  cv::Mat expected;
  ASSERT_EQ(outputs.size(), 2u);
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
  EXPECT_TRUE(test::exitsWith(stage, 2, 20s, log));
  EXPECT_NE(test::readFile(log).find("CYCLONEDDS_URI is not set"), std::string::npos) << test::tail(log);
}

}  // namespace
}  // namespace sg
