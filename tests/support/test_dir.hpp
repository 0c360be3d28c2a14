#pragma once
/// A per-test working folder for the tests that run whole commands (CLI, sweeps, reports).

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace kfx::test {

/// `prefix` + the current test's name under the system's temporary folder, emptied and created:
/// a fresh folder each test, named so that a failing test's files are easy to find.
inline std::filesystem::path fresh_test_dir(const std::string& prefix) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      (prefix + ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace kfx::test
