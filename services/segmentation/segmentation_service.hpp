#pragma once
// Segmentation stage: FeatureFrame -> Segmentation (seed paper Sec. III via
// vision/segmenter.hpp: ground/background polyline, obstacles, labels).
#include <cstdint>

#include "dds/conversions.hpp"
#include "dds/pipe_stage.hpp"
#include "dds/service.hpp"
#include "vision/segmenter.hpp"

namespace sg {

struct SegmentationServiceParams {
  dds::TransportParams transport;
  SegmenterParams segmenter;
  bool send_correlation = true;  // put the correlation image (rows x offsets, 1 byte each) in every Segmentation

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("segmenter", segmenter);
    v.field("send_correlation", send_correlation, 0, 1, "",
            "send the correlation image before removal (height x offsets bytes, ~48 KB at 375 x 128) for displays");
  }
  void validate() const {
    validateParams(*this, "segmentation_service");
    segmenter.validate();
  }
};

class SegmentationService {
 public:
  SegmentationService(dds::ShutdownSignal& signals, const SegmentationServiceParams& params,
                      std::uint64_t frame_limit);
  void run();

 private:
  void compute(const sg_idl_FeatureFrame& in, const dds::FrameInfo& info, sg_idl_Segmentation& out);

  dds::ServiceRuntime runtime_;
  dds::PipeStage<sg_idl_FeatureFrame, sg_idl_Segmentation> pipe_;
  Segmenter segmenter_;
  bool send_correlation_;
  dds::FeatureFrameData input_;
  dds::SegmentationData output_;
  dds::SegmentationEncoder encoder_;
};

}  // namespace sg
