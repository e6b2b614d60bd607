// Bad input at the process level: a real stereoguard-acquisition reading a
// pairs: folder whose frames are corrupt, truncated, 16-bit, colour or of
// different left/right sizes; a stage started with a configuration file that
// is out of range or of the wrong type. Each bad frame is logged with the file
// and what was wrong, counted in StageMetrics as source_error, and the next
// frame is served; a bad configuration stops the stage with status 2 and one
// message naming the file, the key and the value.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "stage_harness.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
// One domain per test: ctest runs them side by side.
constexpr int kDomain = 187;
constexpr int kFeaturesDomain = 188;
constexpr int kLocalizationDomain = 189;
constexpr int kConfigDomain = 190;

cv::Mat noise(int width, int height, int type, int seed) {
  cv::Mat image(height, width, type);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  return image;
}

void writeBytes(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

std::string pngBytes(const cv::Mat& image) {
  std::vector<unsigned char> buf;
  cv::imencode(".png", image, buf);
  return std::string(buf.begin(), buf.end());
}

TEST(BadInput, AcquisitionCountsEachBadImageFileAndServesTheNextFrame) {
  test::useLoopbackDds();
  const std::string dir = std::string(SG_TEST_LOG_DIR) + "/bad_input_pairs";
  fs::remove_all(dir);
  fs::create_directories(dir + "/left");
  fs::create_directories(dir + "/right");
  const cv::Mat left = noise(64, 48, CV_8UC1, 1);
  const cv::Mat right = noise(64, 48, CV_8UC1, 2);
  auto pair = [&](const std::string& name, const std::string& l, const std::string& r) {
    writeBytes(dir + "/left/" + name, l);
    writeBytes(dir + "/right/" + name, r);
  };
  const std::string good_l = pngBytes(left);
  const std::string good_r = pngBytes(right);
  // frame, what is wrong with it, and the text its log line must carry
  const std::vector<std::tuple<std::string, std::string, std::string>> bad = {
      {"001.png", "not an image", "not a PNG, JPEG, BMP or PNM image"},
      {"002.png", "truncated PNG", "truncated PNG image"},
      {"003.png", "16-bit left image", "16-bit samples"},
      {"004.png", "left and right sizes differ", "left and right images differ in size"},
      {"005.png", "empty right file", "empty image file"},
      {"008.png", "right file missing", "image file not found"},
  };
  pair("000.png", good_l, good_r);
  pair("001.png", "this is not a PNG file at all", good_r);
  pair("002.png", good_l.substr(0, good_l.size() / 2), good_r);
  pair("003.png", pngBytes(noise(64, 48, CV_16UC1, 3)), good_r);
  pair("004.png", good_l, pngBytes(noise(60, 48, CV_8UC1, 4)));
  pair("005.png", good_l, "");
  pair("006.png", pngBytes(noise(64, 48, CV_8UC3, 5)), good_r);  // colour: converted to grey, accepted
  pair("007.png", good_l, good_r);
  writeBytes(dir + "/left/008.png", good_l);
  pair("009.png", good_l, good_r);

  test::StageOutputs<sg_idl_StereoFrame> out(kDomain, dds::kStereoFrameTopic);
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/bad_input_acquisition.log";
  test::ChildProcess stage({SG_ACQUISITION_EXE, "--source", "pairs:" + dir, "--rate", "20", "--min-readers", "1"},
                           test::loopbackEnv(kDomain), log);
  bool end_seen = false;
  ASSERT_TRUE(out.finish(stage, log, 60s, [&](const sg_idl_StereoFrame& sample) {
    dds::StereoFrameData d;
    dds::readStereoFrame(sample, d);
    if (d.info.end_of_stream) end_seen = true;
    if (d.info.payload_valid) {
      EXPECT_EQ(d.left.size(), cv::Size(64, 48));
    }
  }));
  EXPECT_TRUE(end_seen);
  EXPECT_EQ(out.published, (std::set<std::uint64_t>{0, 6, 7, 9})) << test::tail(log);
  EXPECT_TRUE(out.last.final_report);
  EXPECT_EQ(out.last.frames_received, 10u);
  EXPECT_EQ(out.last.frames_published, 4u);
  EXPECT_EQ(out.last.dropped[dds::kDropSourceError], bad.size());
  EXPECT_EQ(out.last.frames_received, out.last.frames_published + out.last.droppedTotal());
  const std::string text = test::readFile(log);
  for (const auto& [name, what, message] : bad) {
    EXPECT_NE(text.find(name), std::string::npos) << what << ": the file is not named\n" << text;
    EXPECT_NE(text.find(message), std::string::npos) << what << ": '" << message << "' not logged\n" << text;
  }
}

TEST(BadInput, StageWithOutOfRangeOrMistypedConfigurationStopsWithStatus2NamingTheKey) {
  const std::string dir = std::string(SG_TEST_LOG_DIR) + "/bad_input_config";
  fs::create_directories(dir);
  const struct {
    const char* name;
    const char* yaml;
    const char* expected;
  } cases[] = {
      {"range.yaml", "transport:\n  metrics_period_s: -3\n", "'transport.metrics_period_s' = -3 is out of range"},
      {"type.yaml", "transport:\n  images:\n    history_depth: many\n",
       "key 'transport.images.history_depth' must be an int, got 'many'"},
      {"unknown.yaml", "transport:\n  metric_period_s: 1\n", "unknown key 'transport.metric_period_s'"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir + "/" + c.name;
    writeBytes(path, c.yaml);
    const std::string log = dir + "/" + c.name + ".log";
    test::ChildProcess stage({SG_FEATURES_EXE, "--config", path, "--frames", "1"}, test::loopbackEnv(kConfigDomain),
                             log);
    EXPECT_TRUE(test::exitsWith(stage, 2, 30s, log));
    const std::string text = test::readFile(log);
    EXPECT_NE(text.find(path), std::string::npos) << text;
    EXPECT_NE(text.find(c.expected), std::string::npos) << text;
  }
}

StereoRig smallRig() {
  StereoRig rig;
  rig.focal_px = 80;
  rig.cx_px = 32;
  rig.cy_px = 24;
  rig.baseline_m = 0.3;
  rig.width = 64;
  rig.height = 48;
  rig.mounting = Mounting{1.5, 0.0};
  return rig;
}

dds::StereoFrameData smallFrame(std::uint64_t id, bool last) {
  return test::noiseFrame(id, last, smallRig(), "bad" + std::to_string(id));
}

TEST(BadInput, FeaturesDropsNanRigNegativeBaselineAndWrongDepthSamplesAndKeepsServing) {
  test::useLoopbackDds();
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/bad_input_features.log";
  test::StageHarness<sg_idl_StereoFrame, sg_idl_FeatureFrame> h(kFeaturesDomain, dds::kStereoFrameTopic,
                                                                 dds::kFeatureFrameTopic);
  test::ChildProcess stage({SG_FEATURES_EXE, "--frames", "5"}, test::loopbackEnv(kFeaturesDomain), log);
  ASSERT_TRUE(h.connected(log));
  sg_idl_StereoFrame msg{};
  // 0 valid; 1 NaN focal length; 2 negative baseline; 3 a 16-bit image (2 bytes a pixel) declared
  // as mono8 64x48; 4 valid, the last. Each write waits until the stage has dealt with the previous one.
  std::vector<dds::StereoFrameData> frames;
  for (std::uint64_t id = 0; id < 5; ++id) frames.push_back(smallFrame(id, id == 4));
  frames[1].rig.focal_px = std::numeric_limits<double>::quiet_NaN();
  frames[2].rig.baseline_m = -0.3;
  const cv::Mat deep = noise(64, 48, CV_16UC1, 9);
  for (std::uint64_t id = 0; id < 5; ++id) {
    dds::fillStereoFrame(frames[id], msg);
    if (id == 3) {
      msg.left._buffer = const_cast<std::uint8_t*>(deep.ptr<std::uint8_t>());
      msg.left._length = msg.left._maximum = static_cast<std::uint32_t>(deep.total() * deep.elemSize());
    }
    ASSERT_TRUE(h.writeAndWait(msg, id, log));
  }
  ASSERT_TRUE(h.finish(stage, log));
  EXPECT_EQ(h.published, (std::set<std::uint64_t>{0, 4}));
  EXPECT_TRUE(h.last.final_report);
  EXPECT_EQ(h.last.frames_received, 5u);
  EXPECT_EQ(h.last.dropped["malformed"], 3u);
  const std::string text = test::readFile(log);
  EXPECT_NE(text.find("frame 1 rig: field 'focal_px' = nan"), std::string::npos) << text;
  EXPECT_NE(text.find("frame 2 rig: field 'baseline_m' = -0.3"), std::string::npos) << text;
  EXPECT_NE(text.find("field 'left' has 6144 bytes but width*height = 64*48 = 3072"), std::string::npos) << text;
}

TEST(BadInput, LocalizationDropsASegmentationWithAbsurdBoxOrOffsetAndKeepsServing) {
  test::useLoopbackDds();
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/bad_input_localization.log";
  test::StageHarness<sg_idl_Segmentation, sg_idl_HumanDetections> h(kLocalizationDomain, dds::kSegmentationTopic,
                                                                     dds::kHumanDetectionsTopic);
  dds::TopicWriter<sg_idl_StereoFrame> frame_writer(h.participant, dds::kStereoFrameTopic, h.transport.images);
  test::ChildProcess stage({SG_LOCALIZATION_EXE, "--frames", "5"}, test::loopbackEnv(kLocalizationDomain), log);
  ASSERT_TRUE(h.connected(log));
  ASSERT_TRUE(frame_writer.waitForReaders(1, 20s, [] { return false; })) << test::tail(log);
  // 0 valid; 1 an obstacle box beyond the image; 2 an obstacle offset beyond the width; 3 an obstacle box of
  // zero width; 4 valid, the last.
  dds::SegmentationEncoder encoder;
  for (std::uint64_t id = 0; id < 5; ++id) {
    const dds::StereoFrameData frame = smallFrame(id, id == 4);
    sg_idl_StereoFrame frame_msg{};
    dds::fillStereoFrame(frame, frame_msg);
    frame_writer.write(frame_msg);
    dds::SegmentationData seg;
    seg.info = frame.info;
    seg.rig = frame.rig;
    seg.result.ground.offset_per_row.assign(48, std::numeric_limits<float>::quiet_NaN());
    seg.result.ground.horizon_row = -1;
    seg.result.ground.background_offset = std::numeric_limits<float>::quiet_NaN();
    ObstacleCluster o;
    o.offset_px = 6;
    o.min_offset_px = 5;
    o.max_offset_px = 7;
    o.box = cv::Rect(20, 8, 12, 30);
    o.feature_count = 50;
    seg.result.obstacles.push_back(o);
    sg_idl_Segmentation msg{};
    encoder.fill(seg, msg);
    sg_idl_Obstacle bad = msg.obstacles._buffer[0];
    if (id == 1) bad.box.right = 1.0e6f;
    if (id == 2) bad.offset_px = bad.max_offset_px = 5000;
    if (id == 3) bad.box.right = bad.box.left;
    if (id >= 1 && id <= 3) msg.obstacles._buffer = &bad;
    ASSERT_TRUE(h.writeAndWait(msg, id, log));
  }
  ASSERT_TRUE(h.finish(stage, log));
  EXPECT_EQ(h.published, (std::set<std::uint64_t>{0, 4}));
  EXPECT_EQ(h.last.frames_received, 5u);
  EXPECT_EQ(h.last.dropped["malformed"], 3u);
  const std::string text = test::readFile(log);
  EXPECT_NE(text.find("field 'obstacles[0].box' = [20, 8, 1e+06, 38] is not a box inside the 64x48 image"),
            std::string::npos) << text;
  EXPECT_NE(text.find("field 'obstacles[0].offset_px' = 5000"), std::string::npos) << text;
  EXPECT_NE(text.find("field 'obstacles[0].box' = [20, 8, 20, 38] has zero width (left == right)"),
            std::string::npos) << text;
}

}  // namespace
}  // namespace sg
