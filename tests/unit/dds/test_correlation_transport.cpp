// The correlation image in the Segmentation sample: quantization, exact round
// trip of what was quantized, and every inconsistent declaration rejected
// with an InputError naming the field.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "config/errors.hpp"
#include "dds/conversions.hpp"

namespace sg::dds {
namespace {

SegmentationData segmentationWithCorrelation(int width, int height, int offsets) {
  SegmentationData d;
  d.info.frame_id = 5;
  d.info.source = "000005";
  d.rig.focal_px = 700.0;
  d.rig.cx_px = width / 2.0;
  d.rig.cy_px = height / 2.0;
  d.rig.baseline_m = 0.5;
  d.rig.width = width;
  d.rig.height = height;
  d.result.ground.offset_per_row.assign(static_cast<std::size_t>(height), GroundProfile::kUnknown);
  cv::Mat score(height, offsets, CV_32F);
  cv::RNG rng(3);
  rng.fill(score, cv::RNG::UNIFORM, 0.0, 1.0);
  quantizeCorrelation(score, d.correlation);
  return d;
}

std::string messageOf(const sg_idl_Segmentation& m) {
  SegmentationData out;
  try {
    readSegmentation(m, out);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(CorrelationQuantization, ScoresMapToRounded255ths) {
  cv::Mat score = (cv::Mat_<float>(1, 6) << 0.0f, 1.0f, 0.5f, 1.0f / 255.0f, 2.0f, -0.25f);
  score.at<float>(0, 4) = std::numeric_limits<float>::quiet_NaN();
  cv::Mat q;
  quantizeCorrelation(score, q);
  ASSERT_EQ(q.type(), CV_8UC1);
  // 0.5 * 255 = 127.5 rounds away from zero; NaN and negative scores are "no match".
  const std::uint8_t expected[] = {0, 255, 128, 1, 0, 0};
  for (int x = 0; x < 6; ++x) EXPECT_EQ(q.at<std::uint8_t>(0, x), expected[x]) << "offset " << x;
  quantizeCorrelation(cv::Mat(), q);
  EXPECT_TRUE(q.empty());
  EXPECT_THROW(quantizeCorrelation(cv::Mat(2, 2, CV_8UC1), q), InputError);
}

TEST(CorrelationTransport, RoundTripIsExact) {
  const SegmentationData in = segmentationWithCorrelation(200, 75, 128);
  SegmentationEncoder encoder;
  sg_idl_Segmentation msg{};
  encoder.fill(in, msg);
  EXPECT_EQ(msg.correlation.rows, 75u);
  EXPECT_EQ(msg.correlation.offsets, 128u);
  EXPECT_EQ(msg.correlation.score._length, 75u * 128u);
  SegmentationData out;
  readSegmentation(msg, out);
  ASSERT_EQ(out.correlation.size(), in.correlation.size());
  EXPECT_EQ(cv::countNonZero(out.correlation != in.correlation), 0);
}

TEST(CorrelationTransport, AbsentImageIsEmptyAndClearsThePrevious) {
  SegmentationData in = segmentationWithCorrelation(64, 20, 16);
  SegmentationEncoder encoder;
  sg_idl_Segmentation msg{};
  encoder.fill(in, msg);
  SegmentationData out;
  readSegmentation(msg, out);
  ASSERT_FALSE(out.correlation.empty());
  in.correlation.release();
  encoder.fill(in, msg);
  EXPECT_EQ(msg.correlation.rows, 0u);
  EXPECT_EQ(msg.correlation.score._length, 0u);
  readSegmentation(msg, out);  // the same reused object: the old image must not survive
  EXPECT_TRUE(out.correlation.empty());
}

TEST(CorrelationTransport, DeclaredSizeAgainstDataIsChecked) {
  const SegmentationData in = segmentationWithCorrelation(64, 20, 16);
  SegmentationEncoder encoder;
  sg_idl_Segmentation msg{};
  encoder.fill(in, msg);

  sg_idl_Segmentation m = msg;
  m.correlation.score._length -= 1;  // one byte short of rows x offsets
  EXPECT_NE(messageOf(m).find("field 'correlation.score' has 319 bytes but rows*offsets = 20*16 = 320"),
            std::string::npos)
      << messageOf(m);

  m = msg;
  m.correlation.rows = 19;  // one row per image row
  EXPECT_NE(messageOf(m).find("field 'correlation.rows' = 19 differs from the frame height 20"), std::string::npos)
      << messageOf(m);

  m = msg;
  m.correlation.offsets = 0;
  m.correlation.score._length = 0;
  EXPECT_NE(messageOf(m).find("field 'correlation.offsets' = 0"), std::string::npos) << messageOf(m);

  m = msg;
  m.correlation.offsets = 2000;  // beyond any correlation the segmenter makes
  EXPECT_NE(messageOf(m).find("field 'correlation.offsets' = 2000 is not within 1..1024"), std::string::npos)
      << messageOf(m);

  m = msg;
  m.correlation.score._buffer = nullptr;
  EXPECT_NE(messageOf(m).find("field 'correlation.score'"), std::string::npos) << messageOf(m);
}

TEST(CorrelationTransport, EncoderRejectsAnImageOfTheWrongHeight) {
  SegmentationData in = segmentationWithCorrelation(64, 20, 16);
  in.correlation = cv::Mat(21, 16, CV_8UC1, cv::Scalar(0));
  SegmentationEncoder encoder;
  sg_idl_Segmentation msg{};
  EXPECT_THROW(encoder.fill(in, msg), InputError);
}

}  // namespace
}  // namespace sg::dds
