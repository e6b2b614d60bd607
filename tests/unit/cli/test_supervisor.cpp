// The launcher's restart decision (services/cli/supervisor.cpp) on real child
// processes: exit status 1 or a signal is a crash and restarted with back-off;
// status 2 (bad configuration, e.g. a stage refused by DDS Security) and 0 are
// final.
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "cli/supervisor.hpp"

namespace sg::cli {
namespace {

using namespace std::chrono_literals;

// Polls until every child ended for good (or 10 s passed).
void settle(Supervisor& supervisor) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  for (;;) {
    supervisor.poll();
    bool done = true;
    for (const auto& c : supervisor.children()) done = done && c.exit_status.has_value();
    if (done || std::chrono::steady_clock::now() > deadline) return;
    std::this_thread::sleep_for(5ms);
  }
}

TEST(Supervisor, Status2AndStatus0AreFinalStatus1IsRestarted) {
  RestartPolicy policy;
  policy.backoff = 10ms;
  policy.backoff_max = 10ms;
  policy.max_restarts = 2;
  Supervisor supervisor({}, policy);
  std::vector<std::string> events;
  supervisor.on_event = [&](const std::string& name, const std::string& message) {
    events.push_back(name + " " + message);
  };
  supervisor.start(ProcessSpec{"configuration", "/bin/sh", {"-c", "exit 2"}, true, true});
  supervisor.start(ProcessSpec{"done", "/bin/sh", {"-c", "exit 0"}, true, true});
  supervisor.start(ProcessSpec{"crash", "/bin/sh", {"-c", "exit 1"}, true, true});
  settle(supervisor);
  std::string log;
  for (const auto& e : events) log += e + "\n";

  const auto* configuration = supervisor.child("configuration");
  ASSERT_TRUE(configuration->exit_status.has_value()) << log;
  EXPECT_EQ(*configuration->exit_status, 2);
  EXPECT_EQ(configuration->restarts, 0) << log;
  EXPECT_NE(log.find("configuration exited with status 2 (bad configuration or input; not restarted)"),
            std::string::npos)
      << log;
  const auto* done = supervisor.child("done");
  ASSERT_TRUE(done->exit_status.has_value()) << log;
  EXPECT_EQ(*done->exit_status, 0);
  EXPECT_EQ(done->restarts, 0) << log;
  const auto* crash = supervisor.child("crash");
  ASSERT_TRUE(crash->exit_status.has_value()) << log;
  EXPECT_EQ(*crash->exit_status, 1);
  EXPECT_EQ(crash->restarts, 2) << log;  // up to max_restarts
}

}  // namespace
}  // namespace sg::cli
