#pragma once
// Features stage: StereoFrame -> FeatureFrame (seed paper Sec. III, feature
// images via vision/feature_image.hpp). No algorithm code here.
#include <cstdint>

#include "dds/conversions.hpp"
#include "dds/pipe_stage.hpp"
#include "dds/service.hpp"
#include "vision/feature_image.hpp"

namespace sg {

struct FeaturesServiceParams {
  dds::TransportParams transport;
  FeatureParams features;
  bool forward_grey = false;  // also send the grey images in FeatureFrame (segmentation does not need them)

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("features", features);
    v.field("forward_grey", forward_grey, 0, 1, "", "include the grey images in FeatureFrame");
  }
  void validate() const {
    validateParams(*this, "features_service");
    features.validate();
  }
};

class FeaturesService {
 public:
  FeaturesService(dds::ShutdownSignal& signals, const FeaturesServiceParams& params, std::uint64_t frame_limit);
  void run();

 private:
  void compute(const sg_idl_StereoFrame& in, const dds::FrameInfo& info, sg_idl_FeatureFrame& out);

  FeaturesServiceParams params_;
  dds::ServiceRuntime runtime_;
  dds::PipeStage<sg_idl_StereoFrame, sg_idl_FeatureFrame> pipe_;
  FeatureExtractor extractor_;
  dds::StereoFrameData input_;
  dds::FeatureFrameData output_;
};

}  // namespace sg
