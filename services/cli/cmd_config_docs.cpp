// stereoguard config-docs: the configuration reference (every key of every
// service configuration with type, default, range, unit and description) as
// Markdown, generated from the Params tables. --check FILE compares instead
// of writing and fails (exit status 1) naming the first differing line.
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "config_docs.hpp"

namespace sg::cli {

namespace {

struct ConfigDocsOptions {
  std::string out;    // write here ("" or "-": stdout)
  std::string check;  // compare with this file instead of writing
};

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// 0 when `path` holds exactly `expected`; otherwise prints where they differ and returns 1.
int checkFile(const std::string& path, const std::string& expected) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("--check '" + path + "': cannot read the file");
  std::ostringstream content;
  content << in.rdbuf();
  if (content.str() == expected) {
    std::cout << path << " is up to date\n";
    return 0;
  }
  const auto have = splitLines(content.str());
  const auto want = splitLines(expected);
  std::size_t line = 0;
  while (line < have.size() && line < want.size() && have[line] == want[line]) ++line;
  std::cerr << path << " is stale: it differs from the parameter tables in the code at line " << (line + 1) << "\n"
            << "  file: " << (line < have.size() ? have[line] : std::string("<end of file>")) << "\n"
            << "  code: " << (line < want.size() ? want[line] : std::string("<end of file>")) << "\n"
            << "Regenerate it: stereoguard config-docs --out " << path << "\n";
  return 1;
}

}  // namespace

void addConfigDocsCommand(CLI::App& app) {
  auto opts = std::make_shared<ConfigDocsOptions>();
  auto* cmd = app.add_subcommand(
      "config-docs", "print the configuration reference (every key of every service config) as Markdown");
  cmd->add_option("--out", opts->out, "write to FILE instead of stdout");
  cmd->add_option("--check", opts->check, "compare FILE with the generated reference; exit 1 when it is stale");
  cmd->callback([opts] {
    const std::string text = configReferenceMarkdown();
    if (!opts->check.empty()) {
      const int status = checkFile(opts->check, text);
      if (status != 0) std::exit(status);
      return;
    }
    if (opts->out.empty() || opts->out == "-") {
      std::cout << text;
      return;
    }
    std::ofstream out(opts->out, std::ios::binary);
    out << text;
    if (!out) throw InputError("--out '" + opts->out + "': cannot write the file");
  });
}

}  // namespace sg::cli
