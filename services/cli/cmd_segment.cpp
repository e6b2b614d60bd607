#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"

namespace sg::cli {

void addSegmentCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("segment", "(not available yet)");
  cmd->callback([] { throw InputError("'segment' is not available yet"); });
}

}  // namespace sg::cli
