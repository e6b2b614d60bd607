// DDS Security on loopback (config/security): with the governance (every
// stereoguard topic access-controlled and encrypted, no unauthenticated
// participants) and the permissions made by make-test-pki.sh,
//  - the display identity reads every HumanDetections sample the localization
//    identity writes;
//  - the intruder identity (valid certificate of the same CA, permissions
//    without human_detections) cannot create the reader, or receives nothing;
//  - a participant without security neither matches nor receives anything;
//  - a stage started with an identity whose permissions lack its topics stops
//    at once with status 2 (a configuration error the launcher does not
//    restart) and one line naming the stage, the topic and the missing grant;
//    so does the stereoguard tool (record).
// Skipped when openssl or Cyclone's security plugins are not installed.
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "process_util.hpp"

namespace sg {
namespace {

using namespace std::chrono_literals;

constexpr int kDomain = 184;  // one domain per integration test
constexpr int kStageDomain = 204;
constexpr int kToolDomain = 205;
constexpr int kSamples = 60;  // 2 s at 30 Hz

// The last JSON object line of a probe's log (Cyclone may log warnings before it).
nlohmann::json probeResult(const std::string& log) {
  std::istringstream lines(test::readFile(log));
  std::string line;
  std::string last;
  while (std::getline(lines, line))
    if (!line.empty() && line.front() == '{') last = line;
  if (last.empty()) return nlohmann::json::object();
  return nlohmann::json::parse(last, nullptr, false);
}

class Pki {
 public:
  Pki() {
    std::string pattern = (std::filesystem::temp_directory_path() / "sg-pki-XXXXXX").string();
    if (mkdtemp(pattern.data()) != nullptr) dir_ = pattern;
  }
  ~Pki() {
    std::error_code ec;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
  }
  Pki(const Pki&) = delete;
  Pki& operator=(const Pki&) = delete;
  const std::string& dir() const { return dir_; }
  // CYCLONEDDS_URI: the loopback network settings plus the identity's <Security>.
  std::string uri(const std::string& identity) const {
    return test::loopbackUri() + ",file://" + dir_ + "/" + identity + ".xml";
  }

 private:
  std::string dir_;
};

// Runs make-test-pki.sh into pki.dir(): its exit status (77: DDS Security not
// available), nothing when it did not end within a minute.
std::optional<int> makeTestPki(const Pki& pki, const std::string& log) {
  test::ChildProcess make({"/bin/sh", std::string(SG_SOURCE_DIR) + "/config/security/make-test-pki.sh", pki.dir()},
                          {}, log);
  return make.waitFor(60s);
}

// The test PKI in `pki`, made by make-test-pki.sh (log in `log`): "" when made,
// else why not; `unavailable` when openssl or the security plugins are missing.
std::string preparePki(const Pki& pki, const std::string& log, bool& unavailable) {
  unavailable = false;
  if (pki.dir().empty()) return "cannot create a temporary folder";
  const auto status = makeTestPki(pki, log);
  if (!status.has_value()) return "make-test-pki.sh did not end";
  if (*status == 77) {
    unavailable = true;
    return "DDS Security not available: " + test::tail(log, 3);
  }
  return *status == 0 ? std::string() : test::tail(log);
}

TEST(DdsSecurity, OnlyAuthorizedIdentitiesReadDetections) {
  test::useLoopbackDds();
  const std::string logs = SG_TEST_LOG_DIR;
  Pki pki;
  ASSERT_FALSE(pki.dir().empty()) << "cannot create a temporary folder";
  {
    const std::string log = logs + "/security_pki.log";
    const auto status = makeTestPki(pki, log);
    ASSERT_TRUE(status.has_value()) << "make-test-pki.sh did not end";
    if (*status == 77) GTEST_SKIP() << "DDS Security not available: " << test::tail(log, 3);
    ASSERT_EQ(*status, 0) << test::tail(log);
  }
  const std::string probe = SG_SECURITY_PROBE_EXE;
  const std::string domain = std::to_string(kDomain);
  const std::string samples = std::to_string(kSamples);
  auto env = [&](const std::string& uri) {
    return std::map<std::string, std::string>{{"CYCLONEDDS_URI", uri}};
  };
  const std::string display_log = logs + "/security_display.log";
  const std::string intruder_log = logs + "/security_intruder.log";
  const std::string plain_log = logs + "/security_plain.log";
  const std::string writer_log = logs + "/security_writer.log";
  // Readers first; the bounded ones listen for the whole run of the writer.
  test::ChildProcess display({probe, "read", "--domain", domain, "--samples", samples, "--timeout", "30"},
                             env(pki.uri("display")), display_log);
  test::ChildProcess intruder({probe, "read", "--domain", domain, "--samples", samples, "--timeout", "12"},
                              env(pki.uri("intruder")), intruder_log);
  test::ChildProcess plain({probe, "read", "--domain", domain, "--samples", samples, "--timeout", "12"},
                           env(test::loopbackUri()), plain_log);
  test::ChildProcess writer({probe, "write", "--domain", domain, "--samples", samples, "--rate", "30", "--readers",
                             "1", "--match-timeout", "20"},
                            env(pki.uri("localization")), writer_log);

  const auto writer_status = writer.waitFor(40s);
  ASSERT_TRUE(writer_status.has_value()) << test::tail(writer_log);
  ASSERT_EQ(*writer_status, 0) << test::tail(writer_log);
  for (auto* reader : {&display, &intruder, &plain}) {
    const auto status = reader->waitFor(40s);
    ASSERT_TRUE(status.has_value());
    EXPECT_EQ(*status, 0);
  }
  const nlohmann::json w = probeResult(writer_log);
  const nlohmann::json d = probeResult(display_log);
  const nlohmann::json i = probeResult(intruder_log);
  const nlohmann::json p = probeResult(plain_log);
  ASSERT_TRUE(w.value("matched", false)) << "the authorized reader never matched\n" << test::tail(writer_log);
  EXPECT_TRUE(w.value("acked", false)) << w.dump();

  // Authorized: every sample, in order.
  ASSERT_TRUE(d.value("created", false)) << d.dump() << "\n" << test::tail(display_log);
  EXPECT_EQ(d.value("received", -1), kSamples) << d.dump();
  EXPECT_EQ(d.value("seq_gaps", -1), 0) << d.dump();

  // Intruder: access control refuses the reader, or nothing ever arrives.
  ASSERT_TRUE(i.contains("created")) << test::tail(intruder_log);
  if (i["created"].get<bool>()) {
    EXPECT_EQ(i.value("received", -1), 0) << i.dump();
  } else {
    EXPECT_NE(i.value("error", std::string()).find("dds_create"), std::string::npos) << i.dump();
  }
  RecordProperty("intruder", i.dump());

  // No security: no match, no data.
  ASSERT_TRUE(p.value("created", false)) << p.dump() << "\n" << test::tail(plain_log);
  EXPECT_EQ(p.value("received", -1), 0) << p.dump();
  EXPECT_LT(p.value("matched_ms", 0.0), 0.0) << "an unauthenticated participant matched the secure writer: " << p.dump();

  RecordProperty("matched_ms", static_cast<int>(w.value("matched_ms", 0.0)));
}

// features with the intruder identity: it may read stage_metrics, but not
// write it nor touch stereo_frame or feature_frame. Access control refuses its
// first writer; the stage stops with status 2 instead of 1 (a crash, which the
// launcher would restart again and again).
TEST(DdsSecurity, StageWhoseIdentityLacksAGrantStopsWithStatus2NamingTheTopic) {
  test::useLoopbackDds();
  const std::string logs = SG_TEST_LOG_DIR;
  Pki pki;
  bool unavailable = false;
  const std::string why = preparePki(pki, logs + "/security_stage_pki.log", unavailable);
  if (unavailable) GTEST_SKIP() << why;
  ASSERT_EQ(why, "");
  const std::string log = logs + "/security_stage_intruder.log";
  test::ChildProcess stage(
      {SG_FEATURES_EXE, "--config", std::string(SG_SOURCE_DIR) + "/config/features.yaml", "--frames", "1"},
      {{"CYCLONEDDS_URI", pki.uri("intruder")}, {"SG_DDS_DOMAIN", std::to_string(kStageDomain)}}, log);
  EXPECT_TRUE(test::exitsWith(stage, 2, 30s, log));
  const std::string text = test::readFile(log);
  EXPECT_NE(text.find("features error configuration error: the features stage is not allowed by DDS Security: "
                      "dds_create_writer for topic 'stereoguard/stage_metrics' failed: Not Allowed By Security (the "
                      "permissions of this DDS Security identity do not grant publishing it)"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("internal error"), std::string::npos) << text;
}

// The stereoguard tool with the intruder identity: `record` needs readers of
// stereo_frame, which access control refuses; the tool stops with status 2 and
// a configuration error naming the topic, not an internal error.
TEST(DdsSecurity, ToolWhoseIdentityLacksAGrantStopsWithStatus2NamingTheTopic) {
  test::useLoopbackDds();
  const std::string logs = SG_TEST_LOG_DIR;
  Pki pki;
  bool unavailable = false;
  const std::string why = preparePki(pki, logs + "/security_tool_pki.log", unavailable);
  if (unavailable) GTEST_SKIP() << why;
  ASSERT_EQ(why, "");
  const std::string log = logs + "/security_tool_intruder.log";
  test::ChildProcess tool({SG_STEREOGUARD_EXE, "record", "--out", pki.dir() + "/recording", "--frames", "1",
                           "--duration", "5"},
                          {{"CYCLONEDDS_URI", pki.uri("intruder")}, {"SG_DDS_DOMAIN", std::to_string(kToolDomain)}},
                          log);
  EXPECT_TRUE(test::exitsWith(tool, 2, 30s, log));
  const std::string text = test::readFile(log);
  EXPECT_NE(text.find("stereoguard: configuration error: not allowed by DDS Security: "), std::string::npos) << text;
  EXPECT_NE(text.find("topic 'stereoguard/stereo_frame'"), std::string::npos) << text;
  EXPECT_EQ(text.find("internal error"), std::string::npos) << text;
}

}  // namespace
}  // namespace sg
