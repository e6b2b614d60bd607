// stereoguard: offline tools (segment, detect, evaluate, synth, bench) and the
// launcher of the DDS pipeline (run). Exit status: 0 success, 2 bad usage, bad
// input (one message on stderr naming the file, field or value) or a DDS entity
// that DDS Security does not permit (record, replay, run with a secured
// configuration), 1 internal failure.
#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "dds/dds.hpp"

int main(int argc, char** argv) {
  CLI::App app{"stereoguard: finds people around a vehicle with a calibrated stereo camera"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "stereoguard 0.1.0");
  sg::cli::addSegmentCommand(app);
  sg::cli::addDetectCommand(app);
  sg::cli::addEvaluateCommand(app);
  sg::cli::addSynthCommand(app);
  sg::cli::addBenchCommand(app);
  sg::cli::addRunCommand(app);
  sg::cli::addConfigDocsCommand(app);
  sg::cli::addRecordCommand(app);
  sg::cli::addReplayCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? 0 : 2;
  } catch (const sg::InputError& e) {
    std::cerr << "stereoguard: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    // Refused by DDS Security: the identity's permissions lack a grant; a
    // configuration error, like bad input, not a failure of the tool.
    const auto* dds = dynamic_cast<const sg::dds::DdsError*>(&e);
    if (dds != nullptr && dds->notAllowedBySecurity()) {
      std::cerr << "stereoguard: configuration error: not allowed by DDS Security: " << e.what() << "\n";
      return 2;
    }
    std::cerr << "stereoguard: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
