// A real stereoguard-acquisition process reading ROS 2 stereo images: this
// test plays a ROS 2 camera driver with plain Cyclone writers of
// sensor_msgs/msg/Image and CameraInfo on "rt/..." topics (loopback DDS) and
// checks what acquisition publishes on stereoguard/stereo_frame: the pairs
// matched by stamp (one within the tolerance), mono8/rgb8/bgr8 all giving the
// source's grey images bit for bit, the rig from the CameraInfo projection
// matrices, the stamps as frame names, and one image in an unsupported
// encoding rejected, counted (source_error) and logged while the next pair is
// served.
#include <chrono>
#include <cstdio>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "dds/ros2_messages.hpp"
#include "io/frame_source.hpp"
#include "stage_harness.hpp"

namespace sg {
namespace {

using namespace std::chrono_literals;
// One domain per integration test, outside 100..199 where the browser test picks its own.
constexpr int kDomain = 211;
constexpr std::int64_t kStamp0 = 1700000000LL * 1000000000LL;

using test::waitUntil;

std::string stampName(std::int64_t ns) {
  char text[40];
  std::snprintf(text, sizeof text, "%lld.%09lld", static_cast<long long>(ns / 1000000000),
                static_cast<long long>(ns % 1000000000));
  return text;
}

// A camera driver's message: `pixels` in `encoding` (borrowed).
sensor_msgs_msg_dds__Image_ image(const cv::Mat& pixels, const char* encoding, std::int64_t stamp_ns) {
  sensor_msgs_msg_dds__Image_ m{};
  dds::fillRos2Stamp(stamp_ns, m.header.stamp);
  m.header.frame_id = const_cast<char*>("stereo_optical");
  m.height = static_cast<std::uint32_t>(pixels.rows);
  m.width = static_cast<std::uint32_t>(pixels.cols);
  m.encoding = const_cast<char*>(encoding);
  m.step = static_cast<std::uint32_t>(pixels.step[0]);
  m.data._buffer = const_cast<std::uint8_t*>(pixels.ptr<std::uint8_t>());
  m.data._length = m.data._maximum = static_cast<std::uint32_t>(pixels.step[0] * static_cast<std::size_t>(pixels.rows));
  m.data._release = false;
  return m;
}

sensor_msgs_msg_dds__CameraInfo_ cameraInfo(const StereoRig& rig, double tx) {
  sensor_msgs_msg_dds__CameraInfo_ m{};
  dds::fillRos2Stamp(kStamp0, m.header.stamp);
  m.header.frame_id = const_cast<char*>("stereo_optical");
  m.width = static_cast<std::uint32_t>(rig.width);
  m.height = static_cast<std::uint32_t>(rig.height);
  m.distortion_model = const_cast<char*>("plumb_bob");
  const double k[9] = {rig.focal_px, 0, rig.cx_px, 0, rig.focal_px, rig.cy_px, 0, 0, 1};
  const double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double p[12] = {rig.focal_px, 0, rig.cx_px, tx, 0, rig.focal_px, rig.cy_px, 0, 0, 0, 1, 0};
  for (int i = 0; i < 9; ++i) m.k[i] = k[i];
  for (int i = 0; i < 9; ++i) m.r[i] = r[i];
  for (int i = 0; i < 12; ++i) m.p[i] = p[i];
  return m;
}

TEST(Ros2Source, StereoImagesFromRos2TopicsBecomeStereoFrames) {
  test::useLoopbackDds();
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/acquisition_ros2.log";
  const std::string config = std::string(SG_TEST_LOG_DIR) + "/acquisition_ros2.yaml";
  {
    std::ofstream out(config);
    out << "ros2:\n  reliable: true\n  pair_tolerance_ms: 2\n";
  }

  // The scenes the "camera" sends, with their rig.
  auto source = openFrameSource("synthetic:11");
  std::vector<StereoPair> scenes(3);
  for (auto& s : scenes) ASSERT_TRUE(source->next(s));
  const StereoRig rig = scenes[0].rig;

  // What acquisition publishes (frames and its StageMetrics), on the participant that also plays the camera.
  test::StageOutputs<sg_idl_StereoFrame> out(kDomain, dds::kStereoFrameTopic);
  out.stage = "acquisition";
  dds::Participant& participant = out.participant;
  dds::QosParams ros_qos;  // ROS 2 default profile: reliable, volatile
  ros_qos.history_depth = 10;
  dds::TopicWriter<sensor_msgs_msg_dds__Image_> left_writer(participant, "rt/test_cam/left/image_rect", ros_qos);
  dds::TopicWriter<sensor_msgs_msg_dds__Image_> right_writer(participant, "rt/test_cam/right/image_rect", ros_qos);
  dds::TopicWriter<sensor_msgs_msg_dds__CameraInfo_> left_info_writer(participant, "rt/test_cam/left/camera_info",
                                                                      ros_qos);
  dds::TopicWriter<sensor_msgs_msg_dds__CameraInfo_> right_info_writer(participant, "rt/test_cam/right/camera_info",
                                                                       ros_qos);

  test::ChildProcess acquisition(
      {SG_ACQUISITION_EXE, "--source",
       "ros2:/test_cam/left/image_rect,/test_cam/right/image_rect,/test_cam/left/camera_info,"
       "/test_cam/right/camera_info",
       "--frames", "4", "--config", config, "--min-readers", "1"},
      test::loopbackEnv(kDomain), log);
  for (auto* w : {&left_writer, &right_writer}) {
    ASSERT_TRUE(w->waitForReaders(1, 20s, [] { return false; })) << test::tail(log);
  }
  ASSERT_TRUE(left_info_writer.waitForReaders(1, 20s, [] { return false; })) << test::tail(log);
  ASSERT_TRUE(right_info_writer.waitForReaders(1, 20s, [] { return false; })) << test::tail(log);
  ASSERT_TRUE(waitUntil(20s, [&] { return out.reader.matchedWriters() >= 1; })) << test::tail(log);

  std::vector<dds::StereoFrameData> received;
  const auto keep = [&](const sg_idl_StereoFrame& sample) {
    if (!sample.header.payload_valid) return;
    dds::StereoFrameData f;
    dds::readStereoFrame(sample, f);
    if (f.info.source.rfind("1700000000.", 0) != 0) return;  // not this test's camera
    received.push_back(std::move(f));
  };
  auto collect = [&] { out.collect(keep); };

  // Calibration first, as a driver latches it.
  const auto left_info = cameraInfo(rig, 0.0);
  const auto right_info = cameraInfo(rig, -rig.focal_px * rig.baseline_m);
  left_info_writer.write(left_info);
  right_info_writer.write(right_info);

  // Pair A: left mono8, right rgb8 stamped 1 ms later (within the 2 ms tolerance).
  const std::int64_t t_a = kStamp0;
  cv::Mat right_rgb;
  cv::cvtColor(scenes[0].right, right_rgb, cv::COLOR_GRAY2RGB);
  left_writer.write(image(scenes[0].left, "mono8", t_a));
  right_writer.write(image(right_rgb, "rgb8", t_a + 1000000));
  ASSERT_TRUE(waitUntil(20s, [&] { collect(); return received.size() == 1; })) << test::tail(log);

  // Pair B: the left image in an encoding acquisition does not take.
  const std::int64_t t_b = kStamp0 + 100000000;
  left_writer.write(image(scenes[1].left, "yuv422", t_b));
  right_writer.write(image(scenes[1].right, "mono8", t_b));
  // Pair C: left bgr8, right mono8. Pair D: both mono8, the last frame (--frames 4: ids 0..3).
  const std::int64_t t_c = kStamp0 + 200000000;
  const std::int64_t t_d = kStamp0 + 300000000;
  cv::Mat left_bgr;
  cv::cvtColor(scenes[1].left, left_bgr, cv::COLOR_GRAY2BGR);
  left_writer.write(image(left_bgr, "bgr8", t_c));
  right_writer.write(image(scenes[1].right, "mono8", t_c));
  left_writer.write(image(scenes[2].left, "mono8", t_d));
  right_writer.write(image(scenes[2].right, "mono8", t_d));
  ASSERT_TRUE(waitUntil(20s, [&] { collect(); return received.size() == 3; })) << test::tail(log);

  ASSERT_TRUE(out.finish(acquisition, log, 20s, keep)) << "acquisition did not stop cleanly after --frames 4";
  ASSERT_EQ(received.size(), 3u);

  // Frame ids 0, 2, 3: id 1 went to the rejected image.
  const std::uint64_t ids[] = {0, 2, 3};
  const std::int64_t stamps[] = {t_a, t_c, t_d};
  const int scene_of[] = {0, 1, 2};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& f = received[k];
    const auto& scene = scenes[static_cast<std::size_t>(scene_of[k])];
    SCOPED_TRACE("frame " + std::to_string(k));
    EXPECT_EQ(f.info.frame_id, ids[k]);
    EXPECT_EQ(f.info.source, stampName(stamps[k]));
    ASSERT_EQ(f.left.size(), scene.left.size());
    EXPECT_EQ(cv::norm(f.left, scene.left, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(f.right, scene.right, cv::NORM_INF), 0.0);
    EXPECT_NEAR(f.rig.focal_px, rig.focal_px, 1e-9);
    EXPECT_NEAR(f.rig.cx_px, rig.cx_px, 1e-9);
    EXPECT_NEAR(f.rig.cy_px, rig.cy_px, 1e-9);
    EXPECT_NEAR(f.rig.baseline_m, rig.baseline_m, 1e-12);
  }
  EXPECT_TRUE(received[2].info.end_of_stream);

  dds::StageMetricsData last = out.last;
  ASSERT_TRUE(last.final_report) << test::tail(log);
  EXPECT_EQ(last.frames_received, 4u);
  EXPECT_EQ(last.frames_published, 3u);
  EXPECT_EQ(last.dropped["source_error"], 1u);
  EXPECT_NE(test::readFile(log).find("field 'encoding' = 'yuv422' is not supported"), std::string::npos)
      << test::tail(log);
}

TEST(Ros2Source, BadSourceSpecIsABadUsageError) {
  test::useLoopbackDds();
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/acquisition_ros2_bad_spec.log";
  test::ChildProcess acquisition({SG_ACQUISITION_EXE, "--source", "ros2:/only/left", "--frames", "1"},
                                 test::loopbackEnv(kDomain + 1), log);
  EXPECT_TRUE(test::exitsWith(acquisition, 2, 20s, log));
  EXPECT_NE(test::readFile(log).find("expected ros2:LEFT_IMAGE,RIGHT_IMAGE[,LEFT_INFO,RIGHT_INFO] (1 topic name(s) given)"),
            std::string::npos)
      << test::tail(log);
}

}  // namespace
}  // namespace sg
