#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"

namespace sg::cli {

void addSynthCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("synth", "(not available yet)");
  cmd->callback([] { throw InputError("'synth' is not available yet"); });
}

}  // namespace sg::cli
