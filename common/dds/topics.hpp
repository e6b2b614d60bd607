#pragma once
// Topic names and the C types idlc generated for them (idl/stereoguard.idl).
//
//   topic                          type             QoS group (dds/qos.hpp)
//   stereoguard/stereo_frame       StereoFrame      images
//   stereoguard/feature_frame      FeatureFrame     images
//   stereoguard/segmentation       Segmentation     results
//   stereoguard/human_detections   HumanDetections  results
//   stereoguard/stage_metrics      StageMetrics     metrics (keyed by stage)
#include "dds/dds.hpp"
#include "stereoguard.h"

namespace sg::dds {

inline constexpr const char* kStereoFrameTopic = "stereoguard/stereo_frame";
inline constexpr const char* kFeatureFrameTopic = "stereoguard/feature_frame";
inline constexpr const char* kSegmentationTopic = "stereoguard/segmentation";
inline constexpr const char* kHumanDetectionsTopic = "stereoguard/human_detections";
inline constexpr const char* kStageMetricsTopic = "stereoguard/stage_metrics";

#define SG_DDS_TYPE_SUPPORT(T)                                               \
  template <>                                                                \
  struct TypeSupport<T> {                                                    \
    static const dds_topic_descriptor_t* descriptor() { return &T##_desc; } \
  }

SG_DDS_TYPE_SUPPORT(sg_idl_StereoFrame);
SG_DDS_TYPE_SUPPORT(sg_idl_FeatureFrame);
SG_DDS_TYPE_SUPPORT(sg_idl_Segmentation);
SG_DDS_TYPE_SUPPORT(sg_idl_HumanDetections);
SG_DDS_TYPE_SUPPORT(sg_idl_StageMetrics);

#undef SG_DDS_TYPE_SUPPORT

}  // namespace sg::dds
