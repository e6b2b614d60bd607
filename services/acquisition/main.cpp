// stereoguard-acquisition: frame source -> StereoFrame.
#include <CLI/CLI.hpp>

#include "acquisition_service.hpp"
#include "io/frame_source.hpp"

int main(int argc, char** argv) {
  sg::dds::ShutdownSignal signals;  // first: every later thread inherits the blocked SIGINT/SIGTERM
  sg::dds::ServiceOptions options;
  std::string source = "synthetic";
  std::string calib;
  double rate_hz = -1.0;
  int min_readers = -1;
  int preload = -1;
  bool sequence = false;
  return sg::dds::serviceMain(
      argc, argv, "acquisition",
      [&](CLI::App& app) {
        app.add_option("--source", source, sg::kFrameSourceHelp)->capture_default_str();
        app.add_option("--calib", calib, "calibration file overriding the source's own");
        app.add_option("--rate", rate_hz, "frames per second (overrides rate_hz; 0 = as fast as possible)");
        app.add_option("--min-readers", min_readers, "matched readers awaited before the first frame");
        app.add_option("--preload", preload, "read N frames first and repeat them");
        app.add_flag("--sequence", sequence, sg::kSequenceHelp);
      },
      [&](const sg::dds::ServiceOptions& opts) {
        sg::AcquisitionParams params;
        sg::dds::loadServiceConfig(opts.config_path, params);
        if (rate_hz >= 0.0) params.rate_hz = rate_hz;
        if (min_readers >= 0) params.min_readers = min_readers;
        if (preload >= 0) params.preload_frames = preload;
        if (sequence) params.sequence = true;
        params.validate();
        sg::AcquisitionService service(signals, params, source, calib, opts.frames);
        service.run();
      },
      options);
}
