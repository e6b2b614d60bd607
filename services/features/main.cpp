// stereoguard-features: StereoFrame -> FeatureFrame.
#include "features_service.hpp"

int main(int argc, char** argv) {
  return sg::dds::stageMain<sg::FeaturesServiceParams, sg::FeaturesService>(argc, argv, "features");
}
