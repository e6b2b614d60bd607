#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"

namespace sg::cli {

void addBenchCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("bench", "(not available yet)");
  cmd->callback([] { throw InputError("'bench' is not available yet"); });
}

}  // namespace sg::cli
