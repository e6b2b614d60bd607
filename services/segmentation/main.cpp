// stereoguard-segmentation: FeatureFrame -> Segmentation.
#include "segmentation_service.hpp"

int main(int argc, char** argv) {
  return sg::dds::stageMain<sg::SegmentationServiceParams, sg::SegmentationService>(argc, argv, "segmentation");
}
