#pragma once
// YAML -> Params, driven by each Params struct's visit() table (config/params.hpp).
// Unknown keys, values of the wrong type and values out of range are rejected
// with a ParamError naming the file, the key and the value.
#include <string>

#include <yaml-cpp/yaml.h>

#include "config/params.hpp"

namespace sg {

namespace detail {

class YamlReader {
 public:
  YamlReader(const YAML::Node& node, std::string file, std::string prefix)
      : node_(node), file_(std::move(file)), prefix_(std::move(prefix)) {}

  template <class T>
  void field(const char* key, T& value, double /*min*/, double /*max*/, const char* /*unit*/,
             const char* /*description*/) {
    seen_.emplace_back(key);
    const YAML::Node item = node_[key];
    if (!item) return;  // keep the default
    try {
      if (!item.IsScalar()) throw YAML::Exception(item.Mark(), "not a scalar");
      value = item.as<T>();
    } catch (const YAML::Exception&) {
      throw ParamError(file_ + ": key '" + joinKey(prefix_, key) + "' must be " + article<T>() + typeName<T>() +
                       ", got '" + (item.IsScalar() ? item.Scalar() : std::string("a non-scalar")) + "'");
    }
  }

  template <class P>
  void group(const char* key, P& params) {
    seen_.emplace_back(key);
    const YAML::Node item = node_[key];
    if (!item) return;
    if (!item.IsMap()) throw ParamError(file_ + ": key '" + joinKey(prefix_, key) + "' must be a mapping");
    YamlReader inner(item, file_, joinKey(prefix_, key));
    params.visit(inner);
    inner.rejectUnknownKeys();
  }

  void rejectUnknownKeys() const;

 private:
  template <class T>
  static const char* article() {
    return std::is_integral_v<T> && !std::is_same_v<T, bool> ? "an " : "a ";
  }

  YAML::Node node_;
  std::string file_;
  std::string prefix_;
  std::vector<std::string> seen_;
};

}  // namespace detail

// Fills `params` from a YAML mapping; keys absent from the node keep their
// current value. Validates the ranges afterwards. `file` names the source in errors.
template <class P>
void loadParams(const YAML::Node& node, P& params, const std::string& file, const std::string& prefix = "") {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) throw ParamError(file + ": " + (prefix.empty() ? "the document" : "key '" + prefix + "'") +
                                      " must be a mapping");
  detail::YamlReader reader(node, file, prefix);
  params.visit(reader);
  reader.rejectUnknownKeys();
  try {
    validateParams(params, prefix);
  } catch (const ParamError& e) {
    throw ParamError(file + ": " + e.what());  // the range message names the key; add the file
  }
}

// Parses a YAML file (ParamError naming the file and line on a syntax error)
// and returns its root node.
YAML::Node loadYamlFile(const std::string& path);

// The name a mapping's key gives (`key` from iterating a mapping of `file`, under the group
// `prefix`, empty at the top). A key written as a list or a mapping ("? a: 1") names nothing: a
// ParamError with the file, the line and the group.
std::string keyName(const YAML::Node& key, const std::string& file, const std::string& prefix = "");

}  // namespace sg
