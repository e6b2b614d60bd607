#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"

namespace sg::cli {

void addRunCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "(not available yet)");
  cmd->callback([] { throw InputError("'run' is not available yet"); });
}

}  // namespace sg::cli
