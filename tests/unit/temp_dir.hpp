#pragma once
// A per-test scratch folder under the system temp dir, removed afterwards.
// Named after the test so parallel ctest runs never share one.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace sg::test {

class TempDir {
 public:
  explicit TempDir(const std::string& prefix) {
    const auto* unit = ::testing::UnitTest::GetInstance();
    path_ = std::filesystem::temp_directory_path() /
            (prefix + "_" + std::to_string(unit->random_seed()) + "_" + unit->current_test_info()->name());
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string path() const { return path_.string(); }
  // Path of `name` inside the folder; its parent folders are created.
  std::string file(const std::string& name) const {
    std::filesystem::create_directories((path_ / name).parent_path());
    return (path_ / name).string();
  }
  // Writes `text` to `name` (bytes as given) and returns its path.
  std::string write(const std::string& name, const std::string& text) const {
    const std::string p = file(name);
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace sg::test
