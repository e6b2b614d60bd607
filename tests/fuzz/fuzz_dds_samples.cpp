// libFuzzer target: DDS samples as they arrive from the network. Input: one
// byte choosing the type (StereoFrame, FeatureFrame, Segmentation,
// HumanDetections, StageMetrics), one byte whose lowest bit says the payload
// is byte-swapped, then the XCDR1 payload. Cyclone validates and deserializes
// it (as a reader does), then the project's read*() conversion must either
// accept a consistent sample or throw sg::InputError naming the field.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "config/errors.hpp"
#include "dds/conversions.hpp"
#include "dds/stage_metrics.hpp"
#include "dds_cdr.hpp"

namespace {

[[noreturn]] void broken(const std::string& what) {
  std::fprintf(stderr, "invariant violated: %s\n", what.c_str());
  std::abort();
}

void checkImage(const cv::Mat& image, int width, int height, const char* name) {
  if (image.type() != CV_8UC1 || image.cols != width || image.rows != height) {
    broken(std::string(name) + " image does not have the declared size");
  }
}

void stereoFrame(const sg::fuzz::CdrSample& s) {
  sg::dds::StereoFrameData out;
  sg::dds::readStereoFrame(s.as<sg_idl_StereoFrame>(), out);
  if (!out.info.payload_valid) return;
  checkImage(out.left, out.rig.width, out.rig.height, "left");
  checkImage(out.right, out.rig.width, out.rig.height, "right");
}

void featureFrame(const sg::fuzz::CdrSample& s) {
  sg::dds::FeatureFrameData out;
  sg::dds::readFeatureFrame(s.as<sg_idl_FeatureFrame>(), out);
  if (!out.info.payload_valid) return;
  checkImage(out.left_features, out.rig.width, out.rig.height, "left_features");
  checkImage(out.right_features, out.rig.width, out.rig.height, "right_features");
  if (!out.left.empty()) checkImage(out.left, out.rig.width, out.rig.height, "left");
}

void segmentation(const sg::fuzz::CdrSample& s) {
  sg::dds::SegmentationData out;
  sg::dds::readSegmentation(s.as<sg_idl_Segmentation>(), out);
  if (!out.info.payload_valid) return;
  const cv::Rect frame(0, 0, out.rig.width, out.rig.height);
  if (out.result.ground.offset_per_row.size() != static_cast<std::size_t>(out.rig.height)) {
    broken("ground profile does not have one offset per row");
  }
  for (const auto& o : out.result.obstacles) {
    // An obstacle box covers at least one pixel (a box of zero width or height is refused).
    if (o.box.x < 0 || o.box.y < 0 || o.box.width < 1 || o.box.height < 1 || o.box.x + o.box.width > frame.width ||
        o.box.y + o.box.height > frame.height) {
      broken("obstacle box empty or outside the image");
    }
    if (o.offset_px < 0 || o.offset_px >= out.rig.width) broken("obstacle offset outside 0..width-1");
  }
  if (!out.result.labels.empty()) checkImage(out.result.labels, out.rig.width, out.rig.height, "labels");
}

void detections(const sg::fuzz::CdrSample& s) {
  sg::dds::DetectionsData out;
  sg::dds::readDetections(s.as<sg_idl_HumanDetections>(), out);
  if (!out.info.payload_valid) return;
  for (const auto& d : out.detections) {
    if (d.box.x < 0.0f || d.box.y < 0.0f || !(d.box.width > 0.0f) || !(d.box.height > 0.0f) ||
        d.box.x + d.box.width > static_cast<float>(out.width) + 1e-3f ||
        d.box.y + d.box.height > static_cast<float>(out.height) + 1e-3f || !(d.score >= 0.0f && d.score <= 1.0f)) {
      broken("detection box empty or outside the image, or score outside its range");
    }
  }
}

void stageMetrics(const sg::fuzz::CdrSample& s) { (void)sg::dds::readStageMetrics(s.as<sg_idl_StageMetrics>()); }

struct SampleType {
  const dds_topic_descriptor_t* desc;
  void (*read)(const sg::fuzz::CdrSample&);
};

const SampleType kTypes[] = {
    {&sg_idl_StereoFrame_desc, stereoFrame},          {&sg_idl_FeatureFrame_desc, featureFrame},
    {&sg_idl_Segmentation_desc, segmentation},        {&sg_idl_HumanDetections_desc, detections},
    {&sg_idl_StageMetrics_desc, stageMetrics},
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const SampleType& type = kTypes[data[0] % (sizeof(kTypes) / sizeof(kTypes[0]))];
  sg::fuzz::CdrSample sample(*type.desc);
  if (!sample.load(data + 2, size - 2, (data[1] & 1) != 0)) return 0;
  try {
    type.read(sample);
  } catch (const sg::InputError&) {
    // rejected with a message naming the field: the expected outcome
  }
  return 0;
}
