#pragma once
// The configuration reference (docs/config-reference.md), generated from the
// Params tables (describeParams) of every service configuration, so the
// document cannot drift from the code: `stereoguard config-docs --check`
// fails when the committed file differs from what the code describes.
#include <string>
#include <vector>

#include "config/params.hpp"

namespace sg::cli {

// One configuration file: which program reads it and what it holds.
struct ConfigFileDoc {
  std::string file;        // path below the repository root, e.g. "config/features.yaml"
  std::string program;     // executable reading it, e.g. "stereoguard-features"
  std::string summary;     // one line: what the program does with it
  std::vector<ParamDoc> keys;
};

// Every service configuration with its keys, in pipeline order.
std::vector<ConfigFileDoc> describeServiceConfigs();

// The whole reference as Markdown.
std::string configReferenceMarkdown();

}  // namespace sg::cli
