// IDL <-> core conversions: exact round trips, and every malformed sample
// rejected with an InputError naming the field (never a crash).
#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "config/errors.hpp"
#include "dds/conversions.hpp"
#include "dds/stage_metrics.hpp"

namespace sg::dds {
namespace {

// The InputError text of `read`, or "accepted".
template <class F>
std::string errorText(F read) {
  try {
    read();
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

StereoRig testRig(int width, int height) {
  StereoRig rig;
  rig.focal_px = 700.0;
  rig.cx_px = width / 2.0;
  rig.cy_px = height / 2.0;
  rig.baseline_m = 0.5;
  rig.width = width;
  rig.height = height;
  rig.mounting = Mounting{1.6, 0.02};
  return rig;
}

cv::Mat noiseImage(int width, int height, int seed) {
  cv::Mat image(height, width, CV_8UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  return image;
}

StereoFrameData stereoFrame(int width, int height) {
  StereoFrameData d;
  d.info.frame_id = 42;
  d.info.capture_time_ns = 123456789;
  d.info.source = "000042";
  d.info.sample_seq = 7;
  d.info.scene_start = true;
  d.rig = testRig(width, height);
  d.left = noiseImage(width, height, 1);
  d.right = noiseImage(width, height, 2);
  return d;
}

void expectSameImage(const cv::Mat& a, const cv::Mat& b) {
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.type(), b.type());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

TEST(StereoFrameConversion, RoundTripIsExactOnAnAwkwardSize) {
  const StereoFrameData in = stereoFrame(311, 239);
  sg_idl_StereoFrame msg{};
  fillStereoFrame(in, msg);
  EXPECT_EQ(msg.left._length, 311u * 239u);
  EXPECT_FALSE(msg.left._release);  // borrowed, not copied
  StereoFrameData out;
  readStereoFrame(msg, out);
  EXPECT_EQ(out.info.frame_id, 42u);
  EXPECT_EQ(out.info.source, "000042");
  EXPECT_EQ(out.info.sample_seq, 7u);
  EXPECT_TRUE(out.info.scene_start);
  EXPECT_EQ(out.rig.width, 311);
  ASSERT_TRUE(out.rig.mounting.has_value());
  EXPECT_DOUBLE_EQ(out.rig.mounting->pitch_rad, 0.02);
  expectSameImage(in.left, out.left);
  expectSameImage(in.right, out.right);
}

TEST(StereoFrameConversion, DeclaredSizeDisagreeingWithDataIsMalformed) {
  const StereoFrameData in = stereoFrame(64, 48);
  sg_idl_StereoFrame msg{};
  fillStereoFrame(in, msg);
  msg.width = 65;  // 65 * 48 != 64 * 48 bytes
  StereoFrameData out;
  try {
    readStereoFrame(msg, out);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("left"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("frame 42"), std::string::npos) << e.what();
  }
}

TEST(StereoFrameConversion, ZeroSizeAndNullBufferAreMalformed) {
  StereoFrameData in = stereoFrame(64, 48);
  sg_idl_StereoFrame msg{};
  fillStereoFrame(in, msg);
  StereoFrameData out;
  sg_idl_StereoFrame zero = msg;
  zero.width = 0;
  EXPECT_THROW(readStereoFrame(zero, out), InputError);
  sg_idl_StereoFrame null_right = msg;
  null_right.right._buffer = nullptr;
  EXPECT_THROW(readStereoFrame(null_right, out), InputError);
  sg_idl_StereoFrame bad_rig = msg;
  bad_rig.rig.focal_px = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(readStereoFrame(bad_rig, out), InputError);
}

TEST(StereoFrameConversion, EndMarkerCarriesNoImages) {
  FrameInfo marker;
  marker.frame_id = 9;
  marker.end_of_stream = true;
  marker.payload_valid = false;
  sg_idl_StereoFrame msg{};
  fillHeader(marker, msg.header);
  StereoFrameData out;
  readStereoFrame(msg, out);  // must not throw: markers are not validated as frames
  EXPECT_FALSE(out.info.payload_valid);
  EXPECT_TRUE(out.info.end_of_stream);
  EXPECT_TRUE(out.left.empty());
}

TEST(FeatureFrameConversion, GreyImagesAreOptional) {
  FeatureFrameData in;
  in.info.frame_id = 3;
  in.rig = testRig(100, 50);
  in.left_features = noiseImage(100, 50, 3);
  in.right_features = noiseImage(100, 50, 4);
  sg_idl_FeatureFrame msg{};
  fillFeatureFrame(in, msg);
  FeatureFrameData out;
  readFeatureFrame(msg, out);
  expectSameImage(in.left_features, out.left_features);
  expectSameImage(in.right_features, out.right_features);
  EXPECT_TRUE(out.left.empty());
  msg.right_features._length = 100 * 49;
  EXPECT_THROW(readFeatureFrame(msg, out), InputError);
}

SegmentationData segmentation(int width, int height) {
  SegmentationData d;
  d.info.frame_id = 5;
  d.rig = testRig(width, height);
  GroundProfile& g = d.result.ground;
  g.offset_per_row.assign(static_cast<std::size_t>(height), GroundProfile::kUnknown);
  for (int y = height / 2; y < height; ++y) g.offset_per_row[static_cast<std::size_t>(y)] = 0.25f * static_cast<float>(y - height / 2);
  g.horizon_row = height / 2;
  g.background_offset = 0.5f;
  g.vertices = {{0.5f, 0.0f}, {0.0f, static_cast<float>(height / 2)}, {10.0f, static_cast<float>(height - 1)}};
  g.source = GroundSource::kPrior;
  g.offset_per_column = -0.0125f;
  g.reference_column = 48.5f;
  g.offset_per_column_by_row.assign(static_cast<std::size_t>(height), g.offset_per_column);
  for (int y = height / 2; y < height; ++y)
    g.offset_per_column_by_row[static_cast<std::size_t>(y)] = -0.01f - 0.0001f * static_cast<float>(y);
  ObstacleCluster o;
  o.label = kLabelFirstObstacle;
  o.offset_px = 12;
  o.min_offset_px = 10;
  o.max_offset_px = 14;
  o.box = cv::Rect(20, 10, 30, 25);
  o.feature_count = 321;
  d.result.obstacles.push_back(o);
  d.result.labels = cv::Mat(height, width, CV_8UC1, cv::Scalar(kLabelNone));
  d.result.labels(cv::Rect(0, height / 2, width, height - height / 2)).setTo(kLabelGround);
  d.result.labels(o.box).setTo(o.label);
  d.result.labels.at<std::uint8_t>(0, width - 1) = kLabelBackground;  // a run of one pixel at a row end
  d.result.timing_ms = {{"correlation", 1.5}, {"total", 4.0}};
  return d;
}

TEST(SegmentationConversion, RoundTripIsExact) {
  const SegmentationData in = segmentation(97, 61);
  SegmentationEncoder encoder;
  sg_idl_Segmentation msg{};
  encoder.fill(in, msg);
  EXPECT_LT(msg.labels.run_label._length, 97u * 61u / 4);  // run-length coding pays off
  SegmentationData out;
  readSegmentation(msg, out);
  expectSameImage(in.result.labels, out.result.labels);
  ASSERT_EQ(out.result.ground.offset_per_row.size(), 61u);
  for (std::size_t i = 0; i < 61; ++i) {
    const float a = in.result.ground.offset_per_row[i];
    const float b = out.result.ground.offset_per_row[i];
    EXPECT_TRUE((std::isnan(a) && std::isnan(b)) || a == b) << "row " << i;
  }
  EXPECT_EQ(out.result.ground.horizon_row, 30);
  EXPECT_EQ(out.result.ground.source, GroundSource::kPrior);
  ASSERT_EQ(out.result.ground.vertices.size(), 3u);
  EXPECT_EQ(out.result.ground.vertices[2], in.result.ground.vertices[2]);
  EXPECT_EQ(out.result.ground.offset_per_column, in.result.ground.offset_per_column);
  EXPECT_EQ(out.result.ground.reference_column, in.result.ground.reference_column);
  EXPECT_EQ(out.result.ground.offset_per_column_by_row, in.result.ground.offset_per_column_by_row);
  ASSERT_EQ(out.result.obstacles.size(), 1u);
  EXPECT_EQ(out.result.obstacles[0].box, in.result.obstacles[0].box);
  EXPECT_EQ(out.result.obstacles[0].offset_px, 12);
  EXPECT_EQ(out.result.obstacles[0].feature_count, 321);
  EXPECT_EQ(out.result.timing_ms, in.result.timing_ms);
}

TEST(SegmentationConversion, MalformedSamplesAreRejected) {
  const SegmentationData in = segmentation(97, 61);
  SegmentationEncoder encoder;
  sg_idl_Segmentation msg{};
  encoder.fill(in, msg);
  SegmentationData out;

  sg_idl_Segmentation m = msg;
  m.ground.offset_per_row._length = 60;  // one value per row expected
  EXPECT_THROW(readSegmentation(m, out), InputError);

  std::vector<std::uint32_t> lengths(msg.labels.run_length._buffer,
                                     msg.labels.run_length._buffer + msg.labels.run_length._length);
  lengths.back() += 1;  // runs cover one pixel too many
  m = msg;
  m.labels.run_length._buffer = lengths.data();
  EXPECT_THROW(readSegmentation(m, out), InputError);

  std::vector<sg_idl_Obstacle> obstacles(msg.obstacles._buffer, msg.obstacles._buffer + 1);
  obstacles[0].box.right = 98.0f;  // outside the 97-pixel-wide image
  m = msg;
  m.obstacles._buffer = obstacles.data();
  EXPECT_THROW(readSegmentation(m, out), InputError);

  obstacles[0] = msg.obstacles._buffer[0];
  obstacles[0].offset_px = 200;  // beyond the image width
  EXPECT_THROW(readSegmentation(m, out), InputError);

  std::vector<float> offsets(in.result.ground.offset_per_row);
  offsets[40] = std::numeric_limits<float>::infinity();
  m = msg;
  m.ground.offset_per_row._buffer = offsets.data();
  EXPECT_THROW(readSegmentation(m, out), InputError);

  // The transversal slope: finite and at most one offset per column, a reference column inside
  // the image, one slope per row when the per-row sequence is sent at all.
  m = msg;
  m.ground.offset_per_column = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(readSegmentation(m, out), InputError);
  m = msg;
  m.ground.reference_column = -3.0f;
  EXPECT_THROW(readSegmentation(m, out), InputError);
  m = msg;
  m.ground.offset_per_column_by_row._length = 60;
  EXPECT_THROW(readSegmentation(m, out), InputError);
  std::vector<float> slopes(in.result.ground.offset_per_column_by_row);
  slopes[45] = 2.0f;
  m = msg;
  m.ground.offset_per_column_by_row._buffer = slopes.data();
  EXPECT_THROW(readSegmentation(m, out), InputError);
  m = msg;
  m.ground.offset_per_column_by_row._length = 0;  // none: offset_per_column for every row
  readSegmentation(m, out);
  EXPECT_TRUE(out.result.ground.offset_per_column_by_row.empty());
}

// A box of zero width or height (or, for an obstacle box in whole pixels, less
// than one pixel a side) is refused, naming the sample, the field and the box.
TEST(SegmentationConversion, ZeroAreaObstacleBoxIsMalformed) {
  const SegmentationData in = segmentation(97, 61);
  SegmentationEncoder encoder;
  sg_idl_Segmentation msg{};
  encoder.fill(in, msg);
  SegmentationData out;
  std::vector<sg_idl_Obstacle> obstacles(msg.obstacles._buffer, msg.obstacles._buffer + 1);
  sg_idl_Segmentation m = msg;
  m.obstacles._buffer = obstacles.data();
  auto message = [&] { return errorText([&] { readSegmentation(m, out); }); };

  obstacles[0].box.right = obstacles[0].box.left;
  EXPECT_EQ(message(), "Segmentation frame 5: field 'obstacles[0].box' = [20, 10, 20, 35] has zero width "
                       "(left == right)");
  obstacles[0] = msg.obstacles._buffer[0];
  obstacles[0].box.top = obstacles[0].box.bottom;
  EXPECT_EQ(message(), "Segmentation frame 5: field 'obstacles[0].box' = [20, 35, 50, 35] has zero height "
                       "(top == bottom)");
  obstacles[0] = msg.obstacles._buffer[0];
  obstacles[0].box.right = obstacles[0].box.left + 0.5f;
  EXPECT_EQ(message(), "Segmentation frame 5: field 'obstacles[0].box' = [20, 10, 20.5, 35] is less than "
                       "one pixel wide");

  // One pixel a side is the smallest obstacle (min_width_px = min_height_px = 1).
  SegmentationData one = in;
  one.result.obstacles[0].box = cv::Rect(96, 60, 1, 1);
  encoder.fill(one, msg);
  readSegmentation(msg, out);
  ASSERT_EQ(out.result.obstacles.size(), 1u);
  EXPECT_EQ(out.result.obstacles[0].box, cv::Rect(96, 60, 1, 1));
}

TEST(LabelRunLength, SinglePixelImageAndEmptyImage) {
  std::vector<std::uint8_t> labels;
  std::vector<std::uint32_t> lengths;
  encodeLabels(cv::Mat(1, 1, CV_8UC1, cv::Scalar(7)), labels, lengths);
  ASSERT_EQ(labels.size(), 1u);
  cv::Mat decoded;
  decodeLabels(labels.data(), lengths.data(), labels.size(), 1, 1, decoded, "test");
  EXPECT_EQ(decoded.at<std::uint8_t>(0, 0), 7);
  encodeLabels(cv::Mat(), labels, lengths);
  EXPECT_TRUE(labels.empty());
  const std::uint32_t zero = 0;
  const std::uint8_t value = 1;
  EXPECT_THROW(decodeLabels(&value, &zero, 1, 1, 1, decoded, "test"), InputError);
}

TEST(LabelRunLength, FastEncoderMatchesTheReferenceAndRoundTrips) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 200; ++trial) {
    const int w = 1 + static_cast<int>(rng() % 70), h = 1 + static_cast<int>(rng() % 6);
    // Runs of random length (1 to 40 pixels) of a few labels, crossing row ends;
    // every fourth image is a region of a larger one (rows not contiguous).
    cv::Mat big(h + 2, w + 5, CV_8UC1);
    int left = 0;
    std::uint8_t value = 0;
    for (auto it = big.begin<std::uint8_t>(); it != big.end<std::uint8_t>(); ++it) {
      if (left-- <= 0) {
        left = static_cast<int>(rng() % 40);
        value = static_cast<std::uint8_t>(rng() % 4);
      }
      *it = value;
    }
    const cv::Mat labels = trial % 4 == 0 ? big(cv::Rect(3, 1, w, h)) : big(cv::Rect(0, 0, w, h)).clone();
    std::vector<std::uint8_t> fast_labels, ref_labels;
    std::vector<std::uint32_t> fast_lengths, ref_lengths;
    encodeLabels(labels, fast_labels, fast_lengths);
    encodeLabelsReference(labels, ref_labels, ref_lengths);
    ASSERT_EQ(fast_labels, ref_labels) << "trial " << trial;
    ASSERT_EQ(fast_lengths, ref_lengths) << "trial " << trial;
    cv::Mat decoded;
    decodeLabels(fast_labels.data(), fast_lengths.data(), fast_labels.size(), w, h, decoded, "test");
    ASSERT_EQ(cv::countNonZero(decoded != labels), 0) << "trial " << trial;
  }
}

TEST(DetectionsConversion, RoundTripAndValidation) {
  DetectionsData in;
  in.info.frame_id = 8;
  in.width = 1242;
  in.height = 375;
  HumanDetection h;
  h.box = cv::Rect2f(600.5f, 140.0f, 44.0f, 120.0f);
  h.score = 0.83f;
  h.offset_px = 31.4f;
  h.distance_m = 12.4f;
  h.distance_sigma_m = 0.1f;
  h.position_m = Eigen::Vector3f(0.6f, 1.1f, 12.4f);
  h.ground_contact_row = 262;
  h.track_id = 7;
  h.confirmed = true;
  in.detections.push_back(h);
  in.timing_ms["localization"] = 3.0;
  DetectionsEncoder encoder;
  sg_idl_HumanDetections msg{};
  encoder.fill(in, msg);
  DetectionsData out;
  readDetections(msg, out);
  ASSERT_EQ(out.detections.size(), 1u);
  EXPECT_EQ(out.detections[0].box, h.box);
  EXPECT_EQ(out.detections[0].track_id, 7);
  EXPECT_TRUE(out.detections[0].confirmed);
  EXPECT_EQ(out.detections[0].position_m, h.position_m);

  std::vector<sg_idl_Detection> bad(msg.detections._buffer, msg.detections._buffer + 1);
  sg_idl_HumanDetections m = msg;
  m.detections._buffer = bad.data();
  bad[0].score = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(readDetections(m, out), InputError);
  bad[0] = msg.detections._buffer[0];
  bad[0].box.bottom = 400.0f;  // below the 375-row image
  EXPECT_THROW(readDetections(m, out), InputError);
  // The feet of a person cut by the image bottom lie below it: accepted; far below: malformed.
  bad[0] = msg.detections._buffer[0];
  bad[0].ground_contact_row = 404;
  readDetections(m, out);
  EXPECT_EQ(out.detections[0].ground_contact_row, 404);
  bad[0].ground_contact_row = 3 * 375;
  EXPECT_THROW(readDetections(m, out), InputError);
  bad[0].ground_contact_row = -2;
  EXPECT_THROW(readDetections(m, out), InputError);
}

TEST(DetectionsConversion, ZeroAreaBoxIsMalformed) {
  DetectionsData in;
  in.info.frame_id = 8;
  in.width = 1242;
  in.height = 375;
  HumanDetection h;
  h.box = cv::Rect2f(600.5f, 140.0f, 44.0f, 120.0f);
  h.score = 0.83f;
  in.detections.push_back(h);
  h.box = cv::Rect2f(100.0f, 150.0f, 0.25f, 4.0f);  // narrow, but not empty: a valid box
  in.detections.push_back(h);
  DetectionsEncoder encoder;
  sg_idl_HumanDetections msg{};
  encoder.fill(in, msg);
  DetectionsData out;
  readDetections(msg, out);
  ASSERT_EQ(out.detections.size(), 2u);
  EXPECT_EQ(out.detections[1].box, in.detections[1].box);

  std::vector<sg_idl_Detection> bad(msg.detections._buffer, msg.detections._buffer + 2);
  sg_idl_HumanDetections m = msg;
  m.detections._buffer = bad.data();
  auto message = [&] { return errorText([&] { readDetections(m, out); }); };
  bad[1].box.right = bad[1].box.left;
  EXPECT_EQ(message(), "HumanDetections frame 8: field 'detections[1].box' = [100, 150, 100, 154] has zero "
                       "width (left == right)");
  bad[1] = msg.detections._buffer[1];
  bad[1].box.bottom = bad[1].box.top;
  EXPECT_EQ(message(), "HumanDetections frame 8: field 'detections[1].box' = [100, 150, 100.25, 150] has "
                       "zero height (top == bottom)");
}

TEST(SampleGapCounter, CountsMissedSamplesPerWriter) {
  SampleGapCounter gaps;
  EXPECT_EQ(gaps.gapBefore(1, 0), 0u);
  EXPECT_EQ(gaps.gapBefore(1, 1), 0u);
  EXPECT_EQ(gaps.gapBefore(1, 4), 2u);  // 2 and 3 replaced before they were read
  EXPECT_EQ(gaps.gapBefore(2, 0), 0u);  // another writer has its own count
  EXPECT_EQ(gaps.gapBefore(2, 3), 2u);
  EXPECT_EQ(gaps.gapBefore(1, 5), 0u);
  EXPECT_EQ(gaps.gapBefore(3, 5), 5u);  // samples 0..4 of a writer first seen at 5 never arrived
}

TEST(StageStats, PercentilesAndAccounting) {
  StageStats stats("test");
  stats.received(10);
  for (int i = 1; i <= 8; ++i) stats.published(static_cast<double>(i));
  stats.dropped(kDropSuperseded, 1);
  stats.dropped(kDropMalformed, 1);
  EXPECT_EQ(stats.framesReceived(), stats.framesPublished() + stats.framesDropped());
  sg_idl_StageMetrics msg{};
  stats.fillMetrics(msg, true);
  const StageMetricsData m = readStageMetrics(msg);
  EXPECT_EQ(m.stage, "test");
  EXPECT_EQ(m.dropped.at("malformed"), 1u);
  EXPECT_DOUBLE_EQ(m.latency_ms_p50, 4.0);
  EXPECT_DOUBLE_EQ(m.latency_ms_p99, 8.0);
  EXPECT_TRUE(m.final_report);
}

TEST(StageStats, EachSampleCoversOnePeriodAndCountsStayCumulative) {
  StageStats stats("test");
  stats.received(3);
  stats.published(100.0);
  stats.processed(7.0);
  sg_idl_StageMetrics msg{};
  stats.fillMetrics(msg, false);
  EXPECT_DOUBLE_EQ(readStageMetrics(msg).latency_ms_p50, 100.0);
  stats.published(5.0);
  stats.dropped(kDropMalformed, 0);  // nothing dropped: no reason listed
  stats.dropped(kDropMalformed);
  stats.fillMetrics(msg, true);
  const StageMetricsData m = readStageMetrics(msg);
  EXPECT_EQ(m.frames_received, 3u);
  EXPECT_EQ(m.frames_published, 2u);
  EXPECT_DOUBLE_EQ(m.latency_ms_p50, 5.0);  // this period only
  EXPECT_DOUBLE_EQ(m.processing_ms_p50, 0.0);
  EXPECT_EQ(m.dropped.size(), 1u);
  EXPECT_EQ(stats.summary(), "received 3, published 2, dropped 1 (malformed 1)");
}

}  // namespace
}  // namespace sg::dds
