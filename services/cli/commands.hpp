#pragma once
// Each subcommand of `stereoguard` adds itself to the app. Callbacks report
// bad usage or bad input by throwing sg::InputError (exit status 2); any other
// exception is an internal failure (exit status 1).
namespace CLI {
class App;
}

namespace sg::cli {

void addSegmentCommand(CLI::App& app);
void addSynthCommand(CLI::App& app);
void addDetectCommand(CLI::App& app);
void addEvaluateCommand(CLI::App& app);
void addBenchCommand(CLI::App& app);
void addRunCommand(CLI::App& app);
void addConfigDocsCommand(CLI::App& app);
void addRecordCommand(CLI::App& app);
void addReplayCommand(CLI::App& app);

}  // namespace sg::cli
