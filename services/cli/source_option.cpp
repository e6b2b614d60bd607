// The --source option shared by every command that reads frames.
#include <string>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "io/frame_source.hpp"

namespace sg::cli {

CLI::Option* addSourceOption(CLI::App& cmd, std::string& source) {
  return cmd.add_option("--source", source, kFrameSourceHelp)->capture_default_str();
}

CLI::Option* addSequenceFlag(CLI::App& cmd, bool& sequence) {
  return cmd.add_flag("--sequence", sequence, kSequenceHelp);
}

}  // namespace sg::cli
