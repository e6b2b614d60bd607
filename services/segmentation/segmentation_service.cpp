#include "segmentation_service.hpp"

namespace sg {

SegmentationService::SegmentationService(dds::ShutdownSignal& signals, const SegmentationServiceParams& params,
                                         std::uint64_t frame_limit)
    : runtime_(signals, "segmentation", params.transport),
      pipe_(runtime_, dds::kFeatureFrameTopic, dds::kSegmentationTopic, frame_limit),
      segmenter_(params.segmenter),
      send_correlation_(params.send_correlation) {}

void SegmentationService::compute(const sg_idl_FeatureFrame& in, const dds::FrameInfo& info,
                                  sg_idl_Segmentation& out) {
  dds::readFeatureFrame(in, input_);
  if (info.scene_start) segmenter_.reset();  // no ground line of another scene as the fallback
  segmenter_.compute(input_.left_features, input_.right_features, input_.rig, output_.result);
  output_.info = info;
  output_.rig = input_.rig;
  if (send_correlation_) {
    dds::quantizeCorrelation(output_.result.correlation_initial, output_.correlation);
  } else {
    output_.correlation.release();
  }
  encoder_.fill(output_, out);
  runtime_.log().debug("frame {}: {} obstacles, ground {}, {} label runs ({} bytes)", info.frame_id,
                       output_.result.obstacles.size(), toString(output_.result.ground.source), encoder_.labelRuns(),
                       encoder_.labelRuns() * 5);
}

void SegmentationService::run() {
  pipe_.run([this](const sg_idl_FeatureFrame& in, const dds::FrameInfo& info, sg_idl_Segmentation& out) {
    compute(in, info, out);
  });
  runtime_.finish();
}

}  // namespace sg
