#include <functional>

#include <gtest/gtest.h>

#include "config/params.hpp"
#include "config/yaml_params.hpp"

namespace sg {
namespace {

struct InnerParams {
  double spacing_m = 0.5;
  bool enabled = true;
  template <class V>
  void visit(V& v) {
    v.field("spacing_m", spacing_m, 0.01, 10.0, "metres", "grid spacing");
    v.field("enabled", enabled, 0, 1, "", "switch");
  }
};

struct OuterParams {
  int window_px = 9;
  float gain = 1.5f;
  InnerParams inner;
  template <class V>
  void visit(V& v) {
    v.field("window_px", window_px, 3, 31, "pixels", "window size");
    v.field("gain", gain, 0.0, 4.0, "", "gain");
    v.group("inner", inner);
  }
};

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ParamError& e) {
    return e.what();
  }
  return "";
}

TEST(Params, DefaultsAreValid) { EXPECT_NO_THROW(validateParams(OuterParams{}, "outer")); }

TEST(Params, OutOfRangeNamesTheKeyAndRange) {
  OuterParams p;
  p.inner.spacing_m = 20.0;
  const std::string msg = errorOf([&] { validateParams(p, "outer"); });
  EXPECT_NE(msg.find("outer.inner.spacing_m"), std::string::npos) << msg;
  EXPECT_NE(msg.find("[0.01, 10]"), std::string::npos) << msg;
}

TEST(Params, NanIsRejected) {
  OuterParams p;
  p.gain = std::nanf("");
  EXPECT_THROW(validateParams(p), ParamError);
}

TEST(Params, YamlOverridesAndKeepsDefaults) {
  OuterParams p;
  loadParams(YAML::Load("window_px: 15\ninner: {spacing_m: 2.0}"), p, "test.yaml");
  EXPECT_EQ(p.window_px, 15);
  EXPECT_DOUBLE_EQ(p.inner.spacing_m, 2.0);
  EXPECT_FLOAT_EQ(p.gain, 1.5f);
}

TEST(Params, YamlUnknownKeyIsRejected) {
  OuterParams p;
  const std::string msg = errorOf([&] { loadParams(YAML::Load("inner: {spacnig_m: 2.0}"), p, "test.yaml"); });
  EXPECT_NE(msg.find("inner.spacnig_m"), std::string::npos) << msg;
  EXPECT_NE(msg.find("test.yaml"), std::string::npos) << msg;
}

TEST(Params, YamlKeyThatIsNotANameIsRejected) {
  // "? a: 1" makes the mapping {a: 1} a key (found by the configuration fuzzer).
  OuterParams p;
  const std::string msg =
      errorOf([&] { loadParams(YAML::Load("inner:\n  spacing_m: 2.0\n  ? window_px: 3\n"), p, "test.yaml"); });
  EXPECT_NE(msg.find("test.yaml"), std::string::npos) << msg;
  EXPECT_NE(msg.find("line 3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'inner'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not a name"), std::string::npos) << msg;
}

TEST(Params, YamlWrongTypeIsRejected) {
  OuterParams p;
  const std::string msg = errorOf([&] { loadParams(YAML::Load("window_px: wide"), p, "test.yaml"); });
  EXPECT_NE(msg.find("window_px"), std::string::npos) << msg;
  EXPECT_NE(msg.find("wide"), std::string::npos) << msg;
}

TEST(Params, YamlOutOfRangeIsRejected) {
  OuterParams p;
  EXPECT_THROW(loadParams(YAML::Load("window_px: 99"), p, "test.yaml"), ParamError);
}

TEST(Params, DescribeListsEveryField) {
  const auto docs = describeParams(OuterParams{});
  ASSERT_EQ(docs.size(), 4u);
  EXPECT_EQ(docs[2].key, "inner.spacing_m");
  EXPECT_EQ(docs[2].unit, "metres");
  EXPECT_EQ(docs[0].default_value, "9");
}

TEST(Params, MissingFileIsNamed) {
  const std::string msg = errorOf([] { loadYamlFile("/nonexistent/x.yaml"); });
  EXPECT_NE(msg.find("/nonexistent/x.yaml"), std::string::npos);
}

}  // namespace
}  // namespace sg
