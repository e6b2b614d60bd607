#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"

namespace sg::cli {

void addEvaluateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("evaluate", "(not available yet)");
  cmd->callback([] { throw InputError("'evaluate' is not available yet"); });
}

}  // namespace sg::cli
