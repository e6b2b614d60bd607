// stereoguard-localization: StereoFrame + Segmentation -> HumanDetections.
#include "localization_service.hpp"

int main(int argc, char** argv) {
  return sg::dds::stageMain<sg::LocalizationServiceParams, sg::LocalizationService>(argc, argv, "localization");
}
