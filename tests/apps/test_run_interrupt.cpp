/// Ctrl-C during `kfx run`, with real signals to a child process: the first SIGINT finishes the
/// frame in hand and writes every output of the frames done (marked interrupted, exit 130), and
/// `kfx report` works on that folder; a second SIGINT stops at once and writes nothing more.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

int count_lines(const fs::path& path) {
  std::ifstream in(path);
  int lines = 0;
  for (std::string line; std::getline(in, line);) lines += line.empty() || line[0] == '#' ? 0 : 1;
  return lines;
}

/// `kfx run` over a long synthetic sequence (far more frames than the test waits for) as a
/// child process, its output in `log`; returns its pid.
pid_t start_long_run(const fs::path& out, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    // As from a terminal: a test runner started in the background may ignore SIGINT, and an
    // ignored signal stays ignored across exec.
    signal(SIGINT, SIG_DFL);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    execl(KFX_CLI_PATH, KFX_CLI_PATH, "run", "synthetic:frames=5000,width=160,height=120",
          "--backend", "cpu", "--out", out.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

/// Waits up to a minute for `done()`; false on timeout.
template <class Done>
bool wait_for(Done done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < until) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

/// Ends a child that never got going (so a failing test does not leave a 5000-frame run).
void stop_child(pid_t pid) {
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
}

class RunInterrupt : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::fresh_test_dir("kfx_interrupt_"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(RunInterrupt, FirstSigintWritesEveryOutputOfTheFramesDone) {
  const fs::path out = dir_ / "run", log = dir_ / "output.txt";
  const pid_t pid = start_long_run(out, log);
  ASSERT_GT(pid, 0);
  // A few frames in: slambench.log.partial has a line per finished frame after its header.
  if (!wait_for([&] { return count_lines(out / "slambench.log.partial") >= 4; })) {
    stop_child(pid);
    FAIL() << "no frame done within a minute: " << read_text(log);
  }
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const std::string output = read_text(log);
  ASSERT_TRUE(WIFEXITED(status)) << output;
  EXPECT_EQ(WEXITSTATUS(status), 130) << output;
  EXPECT_NE(output.find("interrupted (Ctrl-C)"), std::string::npos) << output;

  const auto stats = nlohmann::json::parse(read_text(out / "stats.json"));
  EXPECT_TRUE(stats["interrupted"].get<bool>());
  EXPECT_EQ(stats["frames_in_input"], 5000);
  const int frames = stats["frames"].get<int>();
  EXPECT_GE(frames, 3);
  EXPECT_LT(frames, 5000);
  // Every output covers the same frames: a pose and a log line per frame done.
  EXPECT_EQ(count_lines(out / "trajectory.txt"), frames);
  EXPECT_EQ(count_lines(out / "slambench.log"), frames + 1);  // with its header
  for (const char* name : {"config.txt", "mesh.ply", "groundtruth.txt", "report.html"}) {
    EXPECT_TRUE(fs::exists(out / name)) << name;
  }
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_NE(entry.path().extension(), ".partial") << "a temporary left: " << entry.path();
  }
  EXPECT_NE(read_text(out / "report.html").find("\"interrupted\":true"), std::string::npos);
  const auto report = test::run_kfx("report " + out.string());
  EXPECT_EQ(report.exit_code, 0) << report.output;
}

TEST_F(RunInterrupt, SecondSigintStopsAtOnce) {
  const fs::path out = dir_ / "run", log = dir_ / "output.txt";
  const pid_t pid = start_long_run(out, log);
  ASSERT_GT(pid, 0);
  if (!wait_for([&] { return count_lines(out / "slambench.log.partial") >= 2; })) {
    stop_child(pid);
    FAIL() << "no frame done within a minute: " << read_text(log);
  }
  ASSERT_EQ(kill(pid, SIGINT), 0);
  // The second once the first was taken (two pending SIGINTs would merge into one).
  if (!wait_for([&] { return read_text(log).find("interrupted (Ctrl-C)") != std::string::npos; })) {
    stop_child(pid);
    FAIL() << "the first SIGINT was not taken: " << read_text(log);
  }
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const std::string output = read_text(log);
  ASSERT_TRUE(WIFSIGNALED(status)) << output;
  EXPECT_EQ(WTERMSIG(status), SIGINT);
  EXPECT_FALSE(fs::exists(out / "stats.json"));
}

}  // namespace
}  // namespace kfx
