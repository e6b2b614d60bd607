#pragma once
// IDL samples <-> core types, in one place.
//
// Writing: fill*() / *Encoder::fill() point the C struct at the caller's
// memory (sequence _release = false, no copy); keep the inputs alive and
// unchanged until Writer::write() returns.
// Reading: read*() validate the sample (declared width * height against the
// sequence lengths, offsets and rows within range, boxes inside the image,
// finite numbers) and copy it into owned core types. A malformed sample
// throws sg::InputError naming the topic, field and value; the caller counts
// it as "malformed", logs it and goes on.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"
#include "stereoguard.h"
#include "vision/human_types.hpp"
#include "vision/segmentation_types.hpp"

namespace sg::dds {

// FrameHeader of every image and result topic.
struct FrameInfo {
  std::uint64_t frame_id = 0;          // position in the source, from 0
  std::int64_t capture_time_ns = 0;    // CLOCK_REALTIME at acquisition
  std::string source;                  // frame name, e.g. "000042"
  std::uint64_t sample_seq = 0;        // per writer and topic (set by the publishing stage)
  bool end_of_stream = false;          // no frame follows this one
  bool payload_valid = true;           // false: an end-of-stream marker without a frame
  bool scene_start = false;            // unrelated to the frame before: stages drop their state
};

// CLOCK_REALTIME now, nanoseconds (comparable across processes on one host).
std::int64_t realtimeNowNs();

void fillHeader(const FrameInfo& info, sg_idl_FrameHeader& out);  // borrows info.source
FrameInfo readHeader(const sg_idl_FrameHeader& in);

void fillRig(const StereoRig& rig, sg_idl_RigSummary& out);
// Validates (InputError naming the field); `what` names the sample in messages.
StereoRig readRig(const sg_idl_RigSummary& in, std::uint32_t width, std::uint32_t height, const std::string& what);

struct StereoFrameData {
  FrameInfo info;
  StereoRig rig;
  cv::Mat left;   // CV_8UC1
  cv::Mat right;  // CV_8UC1, same size
};
void fillStereoFrame(const StereoFrameData& data, sg_idl_StereoFrame& out);
// A marker (payload_valid false) is read without images.
void readStereoFrame(const sg_idl_StereoFrame& in, StereoFrameData& out);

struct FeatureFrameData {
  FrameInfo info;
  StereoRig rig;
  cv::Mat left_features;   // CV_8UC1, 0 = no information
  cv::Mat right_features;
  cv::Mat left;            // grey images; may be empty
  cv::Mat right;
};
void fillFeatureFrame(const FeatureFrameData& data, sg_idl_FeatureFrame& out);
void readFeatureFrame(const sg_idl_FeatureFrame& in, FeatureFrameData& out);

// Segmentation as transmitted: ground polyline, obstacles, label image,
// timing and (optionally) the correlation image. The feature images and the
// float correlation images of `result` stay in the segmentation stage.
struct SegmentationData {
  FrameInfo info;
  StereoRig rig;
  SegmentationResult result;
  // Correlation image before removal as sent: CV_8UC1, height x offsets,
  // round(255 * score); empty when not sent (quantizeCorrelation()).
  cv::Mat correlation;
};

// Largest number of offsets a correlation image may declare (CorrelationParams::offsets).
inline constexpr std::uint32_t kMaxCorrelationOffsets = 1024;

// CV_32F correlation scores in [0, 1] -> CV_8UC1 round(255 * score), clamped.
// An empty input gives an empty output. Throws InputError for another type.
void quantizeCorrelation(const cv::Mat& score, cv::Mat& out);

class SegmentationEncoder {
 public:
  // Borrows from `data` and from this encoder's scratch (valid until the next fill()).
  void fill(const SegmentationData& data, sg_idl_Segmentation& out);
  // Runs of the label image in the last fill() (5 bytes each on the wire).
  std::size_t labelRuns() const { return run_label_.size(); }

 private:
  std::vector<float> vertex_offset_;
  std::vector<float> vertex_row_;
  std::vector<sg_idl_Obstacle> obstacles_;
  std::vector<std::uint8_t> run_label_;
  std::vector<std::uint32_t> run_length_;
  std::vector<sg_idl_StageTiming> timing_;
};
void readSegmentation(const sg_idl_Segmentation& in, SegmentationData& out);

struct DetectionsData {
  FrameInfo info;
  int width = 0;   // image size (pixels)
  int height = 0;
  std::vector<HumanDetection> detections;
  std::map<std::string, double> timing_ms;
};

class DetectionsEncoder {
 public:
  void fill(const DetectionsData& data, sg_idl_HumanDetections& out);

 private:
  std::vector<sg_idl_Detection> detections_;
  std::vector<sg_idl_StageTiming> timing_;
};
void readDetections(const sg_idl_HumanDetections& in, DetectionsData& out);

// Run-length code of a CV_8UC1 label image, row-major (a run may continue into
// the next row); exposed for tests. Runs are found eight bytes at a time.
void encodeLabels(const cv::Mat& labels, std::vector<std::uint8_t>& run_label, std::vector<std::uint32_t>& run_length);
// The same code pixel by pixel: the reference of encodeLabels().
void encodeLabelsReference(const cv::Mat& labels, std::vector<std::uint8_t>& run_label,
                           std::vector<std::uint32_t>& run_length);
// Throws InputError when the runs do not cover exactly width * height pixels.
void decodeLabels(const std::uint8_t* run_label, const std::uint32_t* run_length, std::size_t runs, int width,
                  int height, cv::Mat& labels, const std::string& what);

}  // namespace sg::dds
