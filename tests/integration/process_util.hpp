#pragma once
// Child processes for the integration tests: real executables with their own
// environment (loopback DDS, a domain per test), bounded waits, and cleanup
// (SIGTERM, then SIGKILL) when a test ends early.
#include <signal.h>
#include <sys/types.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace sg::test {

// CYCLONEDDS_URI of this process: the repository's loopback configuration
// (set when absent, so a test binary run by hand is safe too).
std::string loopbackUri();
void useLoopbackDds();
// Environment of a child process on loopback DDS in `domain` (one domain per test).
std::map<std::string, std::string> loopbackEnv(int domain);

class ChildProcess {
 public:
  // argv[0] is the executable path. stdout and stderr go to `log_path`.
  ChildProcess(std::vector<std::string> argv, const std::map<std::string, std::string>& env,
               const std::string& log_path);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  void signal(int sig) const;
  // Exit status (code, or 128 + signal) when it ended within `timeout`.
  std::optional<int> waitFor(std::chrono::milliseconds timeout);
  bool running() const { return !status_.has_value(); }

 private:
  pid_t pid_ = -1;
  std::optional<int> status_;
};

// Direct children of `pid` (from /proc/<pid>/task/*/children).
std::vector<pid_t> childrenOf(pid_t pid);
// First child of `pid` whose command line contains `needle`; -1 when none.
pid_t childMatching(pid_t pid, const std::string& needle);

// Success when `child` ends within `timeout` with status `expected`; the failure names the log.
::testing::AssertionResult exitsWith(ChildProcess& child, int expected, std::chrono::milliseconds timeout,
                                     const std::string& log);

std::string readFile(const std::string& path);
// Last `lines` lines of a log, for failure messages.
std::string tail(const std::string& path, int lines = 30);

}  // namespace sg::test
