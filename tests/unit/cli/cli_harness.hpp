#pragma once
// Running the real `stereoguard` executable from a test: shell quoting, a scratch folder
// per test, and the command's exit status with its output captured in files there.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace sg::test {

inline std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// A fresh, empty folder for the running test: TMPDIR/PREFIX_<random seed>_<test name>.
inline std::filesystem::path scratchDirForThisTest(const std::string& prefix) {
  const auto* info = ::testing::UnitTest::GetInstance();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(info->random_seed()) + "_" +
                                                info->current_test_info()->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Runs `exe args...` through the shell with stdout and stderr redirected as given
// (">FILE", ">>FILE", "2>&1", ...). Returns the exit status, or -1 when a signal ended it.
inline int runExecutable(const std::string& exe, const std::vector<std::string>& args, const std::string& redirects) {
  std::string cmd = shellQuote(exe);
  for (const auto& a : args) cmd += " " + shellQuote(a);
  cmd += " " + redirects;
  const int raw = std::system(cmd.c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

}  // namespace sg::test
