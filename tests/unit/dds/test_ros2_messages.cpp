// ROS 2 sensor messages as a stereo input: encodings (mono8 kept, rgb8/bgr8
// to grey, the rest rejected by name), size/step/data checks, the rig from
// CameraInfo projection matrices, and pairing by header stamp.
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"
#include "dds/ros2_messages.hpp"

namespace sg::dds {
namespace {

sensor_msgs_msg_dds__Image_ imageMessage(cv::Mat& pixels, const char* encoding) {
  sensor_msgs_msg_dds__Image_ m{};
  m.header.stamp.sec = 1700000000;
  m.header.stamp.nanosec = 5;
  m.header.frame_id = const_cast<char*>("cam");
  m.height = static_cast<std::uint32_t>(pixels.rows);
  m.width = static_cast<std::uint32_t>(pixels.cols);
  m.encoding = const_cast<char*>(encoding);
  m.step = static_cast<std::uint32_t>(pixels.step[0]);
  m.data._buffer = pixels.data;
  m.data._length = m.data._maximum = static_cast<std::uint32_t>(pixels.step[0] * static_cast<std::size_t>(pixels.rows));
  m.data._release = false;
  return m;
}

std::string errorOf(const sensor_msgs_msg_dds__Image_& m) {
  cv::Mat out;
  try {
    readRos2ImageMono(m, out, "Image on rt/left");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Ros2Image, Mono8IsCopiedAndColourBecomesGrey) {
  cv::Mat grey(7, 9, CV_8UC1);
  cv::RNG rng(1);
  rng.fill(grey, cv::RNG::UNIFORM, 0, 256);
  cv::Mat out;
  auto m = imageMessage(grey, "mono8");
  readRos2ImageMono(m, out, "t");
  EXPECT_EQ(cv::countNonZero(out != grey), 0);

  // A grey picture sent in colour comes back unchanged (equal channels).
  cv::Mat rgb;
  cv::cvtColor(grey, rgb, cv::COLOR_GRAY2RGB);
  m = imageMessage(rgb, "rgb8");
  readRos2ImageMono(m, out, "t");
  EXPECT_EQ(cv::countNonZero(out != grey), 0);

  // Real colour: rgb8 and bgr8 read the channels in their own order (0.299 R + 0.587 G + 0.114 B).
  cv::Mat red(1, 1, CV_8UC3, cv::Scalar(255, 0, 0));  // bytes 255,0,0
  m = imageMessage(red, "rgb8");
  readRos2ImageMono(m, out, "t");
  EXPECT_EQ(out.at<std::uint8_t>(0, 0), 76);  // 0.299 * 255
  m = imageMessage(red, "bgr8");
  readRos2ImageMono(m, out, "t");
  EXPECT_EQ(out.at<std::uint8_t>(0, 0), 29);  // 0.114 * 255
}

TEST(Ros2Image, RowPaddingIsSkipped) {
  cv::Mat padded(4, 8, CV_8UC1, cv::Scalar(9));
  padded.colRange(0, 5).setTo(3);
  cv::Mat view = padded.colRange(0, 5);  // step 8, width 5
  auto m = imageMessage(padded, "mono8");
  m.width = 5;
  m.data._length = 8 * 3 + 5;  // the last row needs no padding
  cv::Mat out;
  readRos2ImageMono(m, out, "t");
  ASSERT_EQ(out.size(), cv::Size(5, 4));
  EXPECT_EQ(cv::countNonZero(out != view), 0);
  EXPECT_TRUE(out.isContinuous());
}

TEST(Ros2Image, UnsupportedOrInconsistentMessagesAreRejectedByName) {
  cv::Mat grey(4, 6, CV_8UC1, cv::Scalar(1));
  auto m = imageMessage(grey, "yuv422");
  EXPECT_NE(errorOf(m).find("Image on rt/left: field 'encoding' = 'yuv422' is not supported (mono8, rgb8 or bgr8)"),
            std::string::npos)
      << errorOf(m);
  m = imageMessage(grey, "mono16");
  EXPECT_NE(errorOf(m).find("'mono16' is not supported"), std::string::npos);
  m = imageMessage(grey, "mono8");
  m.encoding = nullptr;
  EXPECT_NE(errorOf(m).find("field 'encoding' = ''"), std::string::npos);

  m = imageMessage(grey, "rgb8");  // 6 bytes per row cannot hold 6 rgb pixels
  EXPECT_NE(errorOf(m).find("field 'step' = 6 is less than width x channels = 18 (rgb8)"), std::string::npos)
      << errorOf(m);
  m = imageMessage(grey, "mono8");
  m.data._length = 23;
  EXPECT_NE(errorOf(m).find("field 'data' has 23 bytes but step x height = 6 x 4 needs 24"), std::string::npos)
      << errorOf(m);
  m = imageMessage(grey, "mono8");
  m.width = 0;
  EXPECT_NE(errorOf(m).find("field 'width' = 0"), std::string::npos);
}

sensor_msgs_msg_dds__CameraInfo_ infoMessage(double tx) {
  sensor_msgs_msg_dds__CameraInfo_ m{};
  m.width = 640;
  m.height = 480;
  const double p[12] = {700.0, 0, 320.5, tx, 0, 700.0, 240.25, 0, 0, 0, 1, 0};
  for (int i = 0; i < 12; ++i) m.p[i] = p[i];
  return m;
}

TEST(Ros2CameraInfo, RigFromProjectionMatrices) {
  const Ros2CameraInfo left = readRos2CameraInfo(infoMessage(0.0), "left");
  const Ros2CameraInfo right = readRos2CameraInfo(infoMessage(-700.0 * 0.12), "right");
  const StereoRig rig = rigFromRos2CameraInfo(left, right, "pair");
  EXPECT_DOUBLE_EQ(rig.focal_px, 700.0);
  EXPECT_DOUBLE_EQ(rig.cx_px, 320.5);
  EXPECT_DOUBLE_EQ(rig.cy_px, 240.25);
  EXPECT_NEAR(rig.baseline_m, 0.12, 1e-12);
  EXPECT_EQ(rig.width, 640);
  EXPECT_EQ(rig.height, 480);
  EXPECT_FALSE(rig.mounting.has_value());
}

TEST(Ros2CameraInfo, InconsistentPairsAreRejected) {
  const Ros2CameraInfo left = readRos2CameraInfo(infoMessage(0.0), "left");
  // Left and right swapped: Tx of the "right" camera is positive.
  Ros2CameraInfo right = readRos2CameraInfo(infoMessage(84.0), "right");
  EXPECT_THROW(rigFromRos2CameraInfo(left, right, "pair"), InputError);
  right = readRos2CameraInfo(infoMessage(-84.0), "right");
  right.p[0] = 710.0;  // another focal length: not a rectified pair
  EXPECT_THROW(rigFromRos2CameraInfo(left, right, "pair"), InputError);
  right = readRos2CameraInfo(infoMessage(-84.0), "right");
  right.height = 479;
  EXPECT_THROW(rigFromRos2CameraInfo(left, right, "pair"), InputError);
  auto m = infoMessage(0.0);
  m.p[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(readRos2CameraInfo(m, "left"), InputError);
}

TEST(Ros2Names, TopicsAndStamps) {
  EXPECT_EQ(ros2DdsTopicName("/stereo/left/image_rect"), "rt/stereo/left/image_rect");
  EXPECT_EQ(ros2DdsTopicName("stereo/left/image_rect"), "rt/stereo/left/image_rect");
  EXPECT_EQ(ros2DdsTopicName("rt/x"), "rt/x");
  EXPECT_THROW(ros2DdsTopicName("/"), InputError);
  builtin_interfaces_msg_dds__Time_ t{};
  fillRos2Stamp(1700000000123456789LL, t);
  EXPECT_EQ(t.sec, 1700000000);
  EXPECT_EQ(t.nanosec, 123456789u);
  EXPECT_EQ(ros2StampNs(t), 1700000000123456789LL);
}

StereoStampPairer::Image at(std::int64_t ms) { return {ms * 1000000, cv::Mat(1, 1, CV_8UC1, cv::Scalar(0))}; }

TEST(StereoStampPairer, ExactStampsPairAndStrayImagesAreCounted) {
  StereoStampPairer pairer(0, 8);
  pairer.addLeft(at(0));
  EXPECT_FALSE(pairer.next().has_value());  // waits for its right image
  pairer.addRight(at(0));
  auto p = pairer.next();
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->left.stamp_ns, 0);
  EXPECT_EQ(p->right.stamp_ns, 0);
  // Left 33 lost; right 33 has no partner and goes once left 66 is paired.
  pairer.addRight(at(33));
  pairer.addLeft(at(66));
  pairer.addRight(at(66));
  p = pairer.next();
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->left.stamp_ns, 66000000);
  EXPECT_EQ(p->right.stamp_ns, 66000000);
  EXPECT_EQ(pairer.unpaired(), 1u);
  EXPECT_FALSE(pairer.next().has_value());
}

TEST(StereoStampPairer, ToleranceTakesTheClosestPartner) {
  StereoStampPairer pairer(5000000, 8);  // 5 ms
  pairer.addLeft(at(100));
  pairer.addRight(at(96));   // 4 ms off
  pairer.addRight(at(102));  // 2 ms off: the partner
  auto p = pairer.next();
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->right.stamp_ns, 102000000);
  EXPECT_EQ(pairer.unpaired(), 1u);  // 96 is older than a pair just made
  pairer.addLeft(at(133));
  pairer.addRight(at(140));  // 7 ms: too far, and every later right image is later still
  EXPECT_FALSE(pairer.next().has_value());
  EXPECT_EQ(pairer.unpaired(), 2u);  // left 133 given up
  EXPECT_EQ(pairer.waitingRight(), 1u);
}

TEST(StereoStampPairer, CapacityBoundsTheWaitingImages) {
  StereoStampPairer pairer(0, 3);
  for (int i = 0; i < 5; ++i) pairer.addLeft(at(i * 10));
  EXPECT_EQ(pairer.waitingLeft(), 3u);
  EXPECT_EQ(pairer.unpaired(), 2u);
  pairer.addRight(at(30));
  auto p = pairer.next();
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->left.stamp_ns, 30000000);
  EXPECT_EQ(pairer.unpaired(), 3u);  // left 20 had no partner
}

}  // namespace
}  // namespace sg::dds
