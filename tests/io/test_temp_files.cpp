/// Temporary files of killed runs: `kfx convert` interrupted by SIGINT or SIGTERM leaves no
/// `.tmp` behind, and a later write of the same path removes temporaries of dead processes
/// (a SIGKILL leaves them) but not those of live ones.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/binary_output_file.hpp"
#include "support/io_test_support.hpp"

extern char** environ;

namespace kfx::io {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("kfx_temp_files_test") {}
};

/// Files in `folder` whose name ends in ".tmp".
std::vector<std::string> temporaries_in(const fs::path& folder) {
  std::vector<std::string> found;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".tmp") == 0) found.push_back(name);
  }
  return found;
}

/// Starts `kfx convert` of a long synthetic sequence into `out` (no shell in between, so the
/// signal reaches kfx itself); returns its pid.
pid_t start_long_convert(const std::string& out) {
  std::vector<std::string> args = {KFX_CLI_PATH, "convert",
                                   "synthetic:frames=100000,width=160,height=120", out};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  const int status = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  EXPECT_EQ(status, 0) << "cannot start " << argv[0];
  return status == 0 ? pid : -1;
}

/// Waits (up to 20 s) until the temporary of `out` written by `pid` holds data.
bool wait_for_data(const std::string& out, pid_t pid) {
  const std::string temp = out + "." + std::to_string(pid) + ".tmp";
  for (int i = 0; i < 400; ++i) {
    std::error_code error;
    if (fs::exists(temp, error) && fs::file_size(temp, error) > 0) return true;
    std::this_thread::sleep_for(50ms);
  }
  return false;
}

TEST(TempFiles, InterruptedConvertLeavesNoTemporary) {
  for (int signal_number : {SIGTERM, SIGINT}) {
    TempDir dir;
    const std::string out = dir.file("killed.raw");
    const pid_t pid = start_long_convert(out);
    ASSERT_GT(pid, 0);
    ASSERT_TRUE(wait_for_data(out, pid)) << "kfx convert wrote no temporary";
    ASSERT_EQ(kill(pid, signal_number), 0);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    // It died of the signal (the handler re-raises it), after removing its temporary.
    EXPECT_TRUE(WIFSIGNALED(status)) << "status " << status;
    if (WIFSIGNALED(status)) EXPECT_EQ(WTERMSIG(status), signal_number);
    EXPECT_TRUE(temporaries_in(dir.path()).empty()) << temporaries_in(dir.path()).front();
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST(TempFiles, LaterWriteRemovesStaleTemporariesOfDeadProcessesOnly) {
  TempDir dir;
  const std::string out = dir.file("stale.raw");
  // A SIGKILLed convert cannot clean up: its temporary stays.
  const pid_t killed = start_long_convert(out);
  ASSERT_GT(killed, 0);
  ASSERT_TRUE(wait_for_data(out, killed));
  ASSERT_EQ(kill(killed, SIGKILL), 0);
  ASSERT_EQ(waitpid(killed, nullptr, 0), killed);
  const std::string stale = out + "." + std::to_string(killed) + ".tmp";
  ASSERT_TRUE(fs::exists(stale));
  // Temporaries of a live process (this one) and of another file are not ours to remove.
  const std::string live = out + "." + std::to_string(getppid()) + ".tmp";
  const std::string other = dir.file("other.raw") + "." + std::to_string(killed) + ".tmp";
  test::write_text(live, "x");
  test::write_text(other, "x");

  EXPECT_EQ(temp_files::remove_stale(out), 1);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));

  // Writing the path again does it too.
  test::write_text(stale, "x");
  {
    BinaryOutputFile file(out, "test");
    EXPECT_FALSE(fs::exists(stale));
    EXPECT_TRUE(fs::exists(temp_files::name_for(out)));
  }
  EXPECT_FALSE(fs::exists(temp_files::name_for(out)));  // abandoned: removed
}

TEST(TempFiles, TrackingSlotsAreReusedAndBounded) {
  std::vector<int> slots;
  for (int i = 0; i < temp_files::kMaxLiveTempFiles + 3; ++i) {
    slots.push_back(temp_files::track("/nonexistent/t" + std::to_string(i)));
  }
  int untracked = 0;
  for (int slot : slots) untracked += slot < 0;
  EXPECT_GE(untracked, 3);  // beyond the table: not tracked, no overflow
  for (int slot : slots) temp_files::forget(slot);
  const int again = temp_files::track("/nonexistent/again");
  EXPECT_GE(again, 0);
  temp_files::forget(again);
  EXPECT_EQ(temp_files::track(std::string(5000, 'x')), -1);  // too long to track
}

}  // namespace
}  // namespace kfx::io
