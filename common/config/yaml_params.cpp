#include "config/yaml_params.hpp"

#include <algorithm>
#include <filesystem>

namespace sg {

namespace detail {

void YamlReader::rejectUnknownKeys() const {
  for (const auto& entry : node_) {
    // A key written as a list or a mapping ("? a: 1") names nothing.
    if (!entry.first.IsScalar())
      throw ParamError(file_ + ": line " + std::to_string(entry.first.Mark().line + 1) + ": a key" +
                       (prefix_.empty() ? std::string() : " under '" + prefix_ + "'") +
                       " is not a name (a list or a mapping)");
    const std::string key = entry.first.as<std::string>();
    if (std::find(seen_.begin(), seen_.end(), key) == seen_.end()) {
      std::string known;
      for (const auto& k : seen_) known += (known.empty() ? "" : ", ") + k;
      throw ParamError(file_ + ": unknown key '" + joinKey(prefix_, key.c_str()) + "' (known keys: " + known + ")");
    }
  }
}

}  // namespace detail

YAML::Node loadYamlFile(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw ParamError(path + ": no such file");
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw ParamError(path + ": not valid YAML: " + e.what());
  }
}

}  // namespace sg
