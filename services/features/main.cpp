// stereoguard-features: StereoFrame -> FeatureFrame.
#include <CLI/CLI.hpp>

#include "features_service.hpp"

int main(int argc, char** argv) {
  sg::dds::ShutdownSignal signals;  // first: every later thread inherits the blocked SIGINT/SIGTERM
  sg::dds::ServiceOptions options;
  return sg::dds::serviceMain(
      argc, argv, "features", nullptr,
      [&](const sg::dds::ServiceOptions& opts) {
        sg::FeaturesServiceParams params;
        sg::dds::loadServiceConfig(opts.config_path, params);
        sg::FeaturesService service(signals, params, opts.frames);
        service.run();
      },
      options);
}
