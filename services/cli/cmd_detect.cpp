#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"

namespace sg::cli {

void addDetectCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("detect", "(not available yet)");
  cmd->callback([] { throw InputError("'detect' is not available yet"); });
}

}  // namespace sg::cli
