// stereoguard-segmentation: FeatureFrame -> Segmentation.
#include <CLI/CLI.hpp>

#include "segmentation_service.hpp"

int main(int argc, char** argv) {
  sg::dds::ShutdownSignal signals;  // first: every later thread inherits the blocked SIGINT/SIGTERM
  sg::dds::ServiceOptions options;
  return sg::dds::serviceMain(
      argc, argv, "segmentation", nullptr,
      [&](const sg::dds::ServiceOptions& opts) {
        sg::SegmentationServiceParams params;
        sg::dds::loadServiceConfig(opts.config_path, params);
        sg::SegmentationService service(signals, params, opts.frames);
        service.run();
      },
      options);
}
