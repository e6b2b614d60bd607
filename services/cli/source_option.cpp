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
  return cmd.add_flag("--sequence", sequence,
                      "the frames are consecutive (a drive in KITTI layout): keep the previous frame's ground line "
                      "and the tracks (default: synthetic scenes and KITTI object frames each stand alone; pairs:DIR "
                      "is one sequence)");
}

}  // namespace sg::cli
