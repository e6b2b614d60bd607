// stereoguard-localization: StereoFrame + Segmentation -> HumanDetections.
#include <CLI/CLI.hpp>

#include "localization_service.hpp"

int main(int argc, char** argv) {
  sg::dds::ShutdownSignal signals;  // first: every later thread inherits the blocked SIGINT/SIGTERM
  sg::dds::ServiceOptions options;
  return sg::dds::serviceMain(
      argc, argv, "localization", nullptr,
      [&](const sg::dds::ServiceOptions& opts) {
        sg::LocalizationServiceParams params;
        sg::dds::loadServiceConfig(opts.config_path, params);
        sg::LocalizationService service(signals, params, opts.frames);
        service.run();
      },
      options);
}
