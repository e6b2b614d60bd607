#include "config/yaml_params.hpp"

#include <algorithm>
#include <filesystem>

namespace sg {

namespace detail {

void YamlReader::rejectUnknownKeys() const {
  for (const auto& entry : node_) {
    const std::string key = keyName(entry.first, file_, prefix_);
    if (std::find(seen_.begin(), seen_.end(), key) == seen_.end()) {
      std::string known;
      for (const auto& k : seen_) known += (known.empty() ? "" : ", ") + k;
      throw ParamError(file_ + ": unknown key '" + joinKey(prefix_, key.c_str()) + "' (known keys: " + known + ")");
    }
  }
}

}  // namespace detail

std::string keyName(const YAML::Node& key, const std::string& file, const std::string& prefix) {
  if (!key.IsScalar())
    throw ParamError(file + ": line " + std::to_string(key.Mark().line + 1) + ": a key" +
                     (prefix.empty() ? std::string() : " under '" + prefix + "'") +
                     " is not a name (a list or a mapping)");
  return key.Scalar();
}

YAML::Node loadYamlFile(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw ParamError(path + ": no such file");
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw ParamError(path + ": not valid YAML: " + e.what());
  }
}

}  // namespace sg
