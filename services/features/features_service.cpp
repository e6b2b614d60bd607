#include "features_service.hpp"

namespace sg {

FeaturesService::FeaturesService(dds::ShutdownSignal& signals, const FeaturesServiceParams& params,
                                 std::uint64_t frame_limit)
    : params_(params),
      runtime_(signals, "features", params.transport),
      pipe_(runtime_, dds::kStereoFrameTopic, dds::kFeatureFrameTopic, frame_limit),
      extractor_(params.features) {}

void FeaturesService::compute(const sg_idl_StereoFrame& in, const dds::FrameInfo& info, sg_idl_FeatureFrame& out) {
  dds::readStereoFrame(in, input_);
  extractor_.compute(input_.left, output_.left_features);
  extractor_.compute(input_.right, output_.right_features);
  output_.info = info;
  output_.rig = input_.rig;
  if (params_.forward_grey) {
    output_.left = input_.left;
    output_.right = input_.right;
  } else {
    output_.left.release();
    output_.right.release();
  }
  dds::fillFeatureFrame(output_, out);
}

void FeaturesService::run() {
  pipe_.run([this](const sg_idl_StereoFrame& in, const dds::FrameInfo& info, sg_idl_FeatureFrame& out) {
    compute(in, info, out);
  });
  runtime_.finish();
}

}  // namespace sg
