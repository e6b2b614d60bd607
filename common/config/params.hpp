#pragma once
// One table per Params struct: every field listed once, with its key, unit,
// range and description. The range check (validate), the YAML loader, the
// --help text and the config reference in docs/ are all generated from it,
// so they cannot drift apart.
//
// A Params struct lists its fields in a visit() member template:
//
//   struct FeatureParams {
//     int edge_threshold = 24;
//     template <class V> void visit(V& v) {
//       v.field("edge_threshold", edge_threshold, 1, 255, "grey levels", "gradient magnitude marking an edge");
//     }
//     void validate() const { validateParams(*this, "features"); }
//   };
//
// Nested Params use v.group("name", member). Supported field types: bool,
// int, float, double (and std::uint32_t / std::int64_t via the arithmetic overload).
#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "config/errors.hpp"

namespace sg {

// Documentation of one field, as produced by describeParams().
struct ParamDoc {
  std::string key;          // dotted path, e.g. "ground.min_votes"
  std::string type;         // bool, int, float, double
  std::string default_value;
  double min = 0.0;
  double max = 0.0;
  std::string unit;
  std::string description;
};

namespace detail {

template <class T>
const char* typeName() {
  if constexpr (std::is_same_v<T, bool>) return "bool";
  else if constexpr (std::is_integral_v<T>) return "int";
  else if constexpr (std::is_same_v<T, float>) return "float";
  else return "double";
}

inline std::string joinKey(const std::string& prefix, const char* key) {
  return prefix.empty() ? std::string(key) : prefix + "." + key;
}

template <class T>
std::string formatValue(const T& value) {
  std::ostringstream out;
  if constexpr (std::is_same_v<T, bool>) out << (value ? "true" : "false");
  else out << value;
  return out.str();
}

class RangeChecker {
 public:
  explicit RangeChecker(std::string prefix) : prefix_(std::move(prefix)) {}

  template <class T>
  void field(const char* key, T& value, double min, double max, const char* unit, const char* /*description*/) {
    if constexpr (std::is_same_v<T, bool>) {
      return;
    } else {
      const double v = static_cast<double>(value);
      if (!std::isfinite(v) || v < min || v > max) {
        std::ostringstream msg;
        msg << "parameter '" << joinKey(prefix_, key) << "' = " << formatValue(value) << " is out of range [" << min
            << ", " << max << "]" << (unit[0] ? " (" : "") << unit << (unit[0] ? ")" : "");
        throw ParamError(msg.str());
      }
    }
  }

  template <class P>
  void group(const char* key, P& params) {
    RangeChecker inner(joinKey(prefix_, key));
    params.visit(inner);
  }

 private:
  std::string prefix_;
};

class Describer {
 public:
  Describer(std::string prefix, std::vector<ParamDoc>& out) : prefix_(std::move(prefix)), out_(out) {}

  template <class T>
  void field(const char* key, T& value, double min, double max, const char* unit, const char* description) {
    out_.push_back(ParamDoc{joinKey(prefix_, key), typeName<T>(), formatValue(value), min, max, unit, description});
  }

  template <class P>
  void group(const char* key, P& params) {
    Describer inner(joinKey(prefix_, key), out_);
    params.visit(inner);
  }

 private:
  std::string prefix_;
  std::vector<ParamDoc>& out_;
};

}  // namespace detail

// Throws ParamError naming the first field outside its range. `prefix` is
// prepended to the key in the message (e.g. "segmentation.ground").
template <class P>
void validateParams(const P& params, const std::string& prefix = "") {
  detail::RangeChecker checker(prefix);
  // visit() only reads through the checker; the cast lets one visit() serve readers and writers.
  const_cast<P&>(params).visit(checker);
}

// Every field with its default (the values in `params`), range, unit and description.
template <class P>
std::vector<ParamDoc> describeParams(const P& params, const std::string& prefix = "") {
  std::vector<ParamDoc> docs;
  detail::Describer describer(prefix, docs);
  const_cast<P&>(params).visit(describer);
  return docs;
}

}  // namespace sg
