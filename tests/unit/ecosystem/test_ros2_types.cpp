// The ROS 2 types of idl/ros2/ros2_types.idl: DDS type names as ROS 2
// (rmw_cyclonedds) expects them, and the serialized bytes of small samples
// compared with hand-computed XCDR1 little-endian sequences following the
// field order of the ROS 2 .msg definitions. The bytes come from Cyclone's own
// serializer: write on a loopback participant, take the serialized sample
// back with dds_takecdr.
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>

#include <cstdlib>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dds/dds.hpp"
#include "ros2_bridge.hpp"
#include "ros2_topics.hpp"

namespace sg {
namespace {

constexpr int kDomain = 203;  // one domain per DDS test

// Loopback only, whatever the caller's environment says.
const bool kLoopback = [] {
  return ::setenv("CYCLONEDDS_URI", "file://" SG_SOURCE_DIR "/config/dds/loopback.xml", 1) == 0;
}();

std::string typeName(dds_entity_t topic) {
  char name[256] = {};
  EXPECT_GE(dds_get_type_name(topic, name, sizeof name), 0);  // returns the length on success
  return name;
}

// Little-endian byte sequence written field by field, with the padding made explicit.
struct Bytes {
  std::vector<std::uint8_t> v;
  void u8(std::uint8_t x) { v.push_back(x); }
  void u32(std::uint32_t x) {
    for (int i = 0; i < 4; ++i) v.push_back(static_cast<std::uint8_t>(x >> (8 * i)));
  }
  void f64(double d) {
    std::uint64_t x = 0;
    std::memcpy(&x, &d, sizeof x);
    for (int i = 0; i < 8; ++i) v.push_back(static_cast<std::uint8_t>(x >> (8 * i)));
  }
  void str(const std::string& s) {  // length including the terminating NUL, then the characters and the NUL
    u32(static_cast<std::uint32_t>(s.size() + 1));
    for (const char c : s) v.push_back(static_cast<std::uint8_t>(c));
    v.push_back(0);
  }
  void pad(std::size_t n) { v.insert(v.end(), n, 0); }
};

// Writes `sample` on `topic_name` and returns its serialized form (encapsulation header + payload).
template <class T>
std::vector<std::uint8_t> serialize(dds::Participant& participant, const char* topic_name, const T& sample) {
  dds::Topic<T> topic(participant, topic_name);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t reader = dds_create_reader(participant.handle(), topic.handle(), qos, nullptr);
  const dds_entity_t writer = dds_create_writer(participant.handle(), topic.handle(), qos, nullptr);
  dds_delete_qos(qos);
  EXPECT_GT(reader, 0);
  EXPECT_GT(writer, 0);
  EXPECT_EQ(dds_write(writer, &sample), DDS_RETCODE_OK);
  std::vector<std::uint8_t> bytes;
  for (int attempt = 0; attempt < 200 && bytes.empty(); ++attempt) {
    struct ddsi_serdata* serdata = nullptr;
    dds_sample_info_t info;
    if (dds_takecdr(reader, &serdata, 1, &info, DDS_ANY_STATE) == 1) {
      bytes.resize(ddsi_serdata_size(serdata));
      ddsi_serdata_to_ser(serdata, 0, bytes.size(), bytes.data());
      ddsi_serdata_unref(serdata);
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  dds_delete(writer);
  dds_delete(reader);
  return bytes;
}

std::string hex(const std::vector<std::uint8_t>& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i > 0) out += (i % 16 == 0) ? '\n' : ' ';
    out += digits[bytes[i] >> 4];
    out += digits[bytes[i] & 15];
  }
  return out;
}

TEST(Ros2Types, TopicTypeNamesAreTheRos2MangledNames) {
  ASSERT_TRUE(kLoopback);
  dds::Participant participant(kDomain);
  dds::Topic<sensor_msgs_msg_dds__Image_> image(participant, dds::kRos2AnnotatedImageTopic);
  dds::Topic<sensor_msgs_msg_dds__CameraInfo_> info(participant, dds::kRos2CameraInfoTopic);
  EXPECT_EQ(typeName(image.handle()), "sensor_msgs::msg::dds_::Image_");
  EXPECT_EQ(typeName(info.handle()), "sensor_msgs::msg::dds_::CameraInfo_");
  char name[256] = {};
  ASSERT_GE(dds_get_name(image.handle(), name, sizeof name), 0);
  EXPECT_STREQ(name, "rt/stereoguard/left/image_annotated");
  ASSERT_GE(dds_get_name(info.handle(), name, sizeof name), 0);
  EXPECT_STREQ(name, "rt/stereoguard/left/camera_info");
  EXPECT_STREQ(builtin_interfaces_msg_dds__Time__desc.m_typename, "builtin_interfaces::msg::dds_::Time_");
  EXPECT_STREQ(std_msgs_msg_dds__Header__desc.m_typename, "std_msgs::msg::dds_::Header_");
  EXPECT_STREQ(sensor_msgs_msg_dds__RegionOfInterest__desc.m_typename, "sensor_msgs::msg::dds_::RegionOfInterest_");
}

// sensor_msgs/Image: header (stamp sec, nanosec; frame_id), height, width,
// encoding, is_bigendian, step, data. XCDR1: 4-byte alignment of uint32
// relative to the payload start, strings and sequences as uint32 length + elements,
// the payload padded to a multiple of 4 with the count in the encapsulation options.
TEST(Ros2Types, ImageSerializesToTheXcdr1LayoutOfTheRosMessage) {
  dds::Participant participant(kDomain);
  std::uint8_t pixels[2] = {7, 9};
  sensor_msgs_msg_dds__Image_ image{};
  image.header.stamp.sec = 1;
  image.header.stamp.nanosec = 2;
  image.header.frame_id = const_cast<char*>("cam");
  image.height = 1;
  image.width = 2;
  image.encoding = const_cast<char*>("mono8");
  image.is_bigendian = 0;
  image.step = 2;
  image.data._length = image.data._maximum = 2;
  image.data._buffer = pixels;
  image.data._release = false;

  Bytes want;
  // Encapsulation CDR_LE (XCDR1); options: the low two bits count the padding bytes
  // that round the payload up to a multiple of 4 (46 bytes -> 2).
  want.u8(0x00), want.u8(0x01), want.u8(0x00), want.u8(0x02);
  want.u32(1);           // 0  header.stamp.sec
  want.u32(2);           // 4  header.stamp.nanosec
  want.str("cam");       // 8  header.frame_id: length 4, "cam\0" (ends at 16)
  want.u32(1);           // 16 height
  want.u32(2);           // 20 width
  want.str("mono8");     // 24 encoding: length 6, "mono8\0" (ends at 34)
  want.u8(0);            // 34 is_bigendian
  want.pad(1);           // 35 padding to 36
  want.u32(2);           // 36 step
  want.u32(2);           // 40 data length
  want.u8(7), want.u8(9);  // 44 data
  want.pad(2);             // 46 end padding to 48 (announced in the options)
  const auto got = serialize(participant, dds::kRos2AnnotatedImageTopic, image);
  EXPECT_EQ(got, want.v) << "got:\n" << hex(got) << "\nwant:\n" << hex(want.v);
}

// sensor_msgs/CameraInfo: after the header, height, width, distortion_model,
// d (sequence<double>: 8-byte alignment in XCDR1), k[9], r[9], p[12],
// binning_x, binning_y, roi.
TEST(Ros2Types, CameraInfoSerializesToTheXcdr1LayoutOfTheRosMessage) {
  dds::Participant participant(kDomain);
  double d[1] = {0.5};
  sensor_msgs_msg_dds__CameraInfo_ info{};
  info.header.frame_id = const_cast<char*>("");
  info.height = 2;
  info.width = 3;
  info.distortion_model = const_cast<char*>("plumb_bob");
  info.d._length = info.d._maximum = 1;
  info.d._buffer = d;
  info.d._release = false;
  for (int i = 0; i < 9; ++i) info.k[i] = 1.0 + i;
  for (int i = 0; i < 9; ++i) info.r[i] = i % 4 == 0 ? 1.0 : 0.0;
  for (int i = 0; i < 12; ++i) info.p[i] = 0.25 * i;
  info.binning_x = 0;
  info.binning_y = 1;
  info.roi = {4, 5, 6, 7, true};

  Bytes want;
  want.u8(0x00), want.u8(0x01), want.u8(0x00), want.u8(0x03);  // CDR_LE, 3 bytes of end padding (321 -> 324)
  want.u32(0), want.u32(0);  // 0 stamp
  want.str("");              // 8 frame_id: length 1, "\0"
  want.pad(3);               // 13 padding to 16
  want.u32(2), want.u32(3);  // 16 height, 20 width
  want.str("plumb_bob");     // 24 length 10 + 10 bytes (ends at 38)
  want.pad(2);               // 38 padding to 40
  want.u32(1);               // 40 d length
  want.pad(4);               // 44 padding to 48 (double: 8-byte alignment in XCDR1)
  want.f64(0.5);             // 48 d[0]
  for (int i = 0; i < 9; ++i) want.f64(1.0 + i);                  // 56 k
  for (int i = 0; i < 9; ++i) want.f64(i % 4 == 0 ? 1.0 : 0.0);   // 128 r
  for (int i = 0; i < 12; ++i) want.f64(0.25 * i);                // 200 p
  want.u32(0), want.u32(1);                                       // 296 binning_x, binning_y
  want.u32(4), want.u32(5), want.u32(6), want.u32(7), want.u8(1);  // 304 roi (ends at 321)
  want.pad(3);                                                     // 321 end padding
  const auto got = serialize(participant, dds::kRos2CameraInfoTopic, info);
  EXPECT_EQ(got, want.v) << "got:\n" << hex(got) << "\nwant:\n" << hex(want.v);
}

// The bridge's messages: K, P of the rectified left camera from the rig; the
// annotated image as bgr8 with step = 3 * width, boxes drawn where detected.
TEST(Ros2Bridge, CameraInfoAndAnnotatedImageFromTheRig) {
  StereoRig rig;
  rig.focal_px = 700.0;
  rig.cx_px = 320.5;
  rig.cy_px = 180.25;
  rig.baseline_m = 0.5;
  rig.width = 64;
  rig.height = 48;
  sensor_msgs_msg_dds__CameraInfo_ info{};
  fillRos2CameraInfo(rig, 1500000000LL, "left", info);
  EXPECT_EQ(info.header.stamp.sec, 1);
  EXPECT_EQ(info.header.stamp.nanosec, 500000000u);
  EXPECT_EQ(info.width, 64u);
  EXPECT_EQ(info.height, 48u);
  const double k[9] = {700.0, 0, 320.5, 0, 700.0, 180.25, 0, 0, 1};
  const double p[12] = {700.0, 0, 320.5, 0, 0, 700.0, 180.25, 0, 0, 0, 1, 0};
  for (int i = 0; i < 9; ++i) EXPECT_EQ(info.k[i], k[i]) << "k[" << i << "]";
  for (int i = 0; i < 12; ++i) EXPECT_EQ(info.p[i], p[i]) << "p[" << i << "]";
  EXPECT_EQ(info.d._length, 5u);

  const cv::Mat left(48, 64, CV_8UC1, cv::Scalar(100));
  HumanDetection person;
  person.box = cv::Rect2f(10, 8, 20, 30);
  person.distance_m = 5.0f;
  const cv::Mat annotated = annotateLeft(left, {person}, true);
  sensor_msgs_msg_dds__Image_ image{};
  fillRos2Image(annotated, 0, "left", image);
  EXPECT_STREQ(image.encoding, "bgr8");
  EXPECT_EQ(image.step, 64u * 3u);
  EXPECT_EQ(image.data._length, 64u * 3u * 48u);
  EXPECT_EQ(annotated.at<cv::Vec3b>(8, 20), cv::Vec3b(0, 0, 255)) << "top edge of the box (near: red)";
  EXPECT_EQ(annotated.at<cv::Vec3b>(2, 2), cv::Vec3b(100, 100, 100)) << "outside the box: the grey image";
  const cv::Mat mono = annotateLeft(left, {}, false);
  fillRos2Image(mono, 0, "left", image);
  EXPECT_STREQ(image.encoding, "mono8");
  EXPECT_EQ(image.step, 64u);
}

}  // namespace
}  // namespace sg
