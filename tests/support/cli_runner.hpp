#pragma once
/// Test helper: runs the kfx binary (KFX_CLI_PATH, set by tests/CMakeLists.txt) and captures
/// its exit status and output.

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace kfx::test {

/// Exit status and output (stdout and stderr together) of one kfx command.
struct CommandResult {
  int exit_code;
  std::string output;
};

/// Runs `kfx ARGUMENTS` through the shell; exit_code is −1 when it could not run or was killed.
inline CommandResult run_kfx(const std::string& arguments) {
  const std::string command = std::string(KFX_CLI_PATH) + " " + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  CommandResult result{-1, ""};
  if (!pipe) return result;
  std::array<char, 4096> buffer;
  while (fgets(buffer.data(), buffer.size(), pipe)) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace kfx::test
