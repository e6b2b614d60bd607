#pragma once
// Each subcommand of `stereoguard` adds itself to the app. Callbacks report
// bad usage or bad input by throwing sg::InputError (exit status 2); any other
// exception is an internal failure (exit status 1).
#include <string>

namespace CLI {
class App;
class Option;
}  // namespace CLI

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

// The --source option of every command that reads frames: one help text for
// every source kind (io/frame_source.hpp). A command checks the kind with
// checkFrameSourceKind() or openFrameSource(), whose error lists the valid kinds.
CLI::Option* addSourceOption(CLI::App& cmd, std::string& source);
// The --sequence flag of the commands that read frames in order (detect and evaluate, and run,
// which passes it to the acquisition stage): keep the state across frames the source calls
// scenes of their own.
CLI::Option* addSequenceFlag(CLI::App& cmd, bool& sequence);

}  // namespace sg::cli
