#include "io/atomic_file.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/platform.hpp"

namespace kfx::io {

namespace temp_files {
namespace {

/// Longest tracked path (bytes, with the terminating 0).
constexpr size_t kMaxTrackedPath = 4096;

enum SlotState : int { kFree = 0, kFilling = 1, kLive = 2 };

/// One tracked file: plain storage the signal handler can read without locks or allocation.
struct Slot {
  std::atomic<int> state{kFree};
  char path[kMaxTrackedPath];
};

Slot g_slots[kMaxLiveTempFiles];
std::atomic<bool> g_handlers_installed{false};

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};

/// Unlinks every live temporary, then lets the signal do what it would have done: the handler
/// is reset to the default and the signal raised again (both async-signal-safe, as is unlink).
extern "C" void remove_temporaries_and_die(int signal_number) {
  for (Slot& slot : g_slots) {
    if (slot.state.load(std::memory_order_acquire) == kLive) unlink(slot.path);
  }
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = SIG_DFL;
  sigemptyset(&action.sa_mask);
  sigaction(signal_number, &action, nullptr);
  raise(signal_number);
}

void install_handlers_once() {
  bool expected = false;
  if (!g_handlers_installed.compare_exchange_strong(expected, true)) return;
  for (int signal_number : kSignals) {
    struct sigaction previous;
    if (sigaction(signal_number, nullptr, &previous) != 0) continue;
    // A signal the caller ignores (nohup, a shell's background job) stays ignored; a handler
    // someone else installed stays theirs.
    if (previous.sa_handler != SIG_DFL) continue;
    struct sigaction action;
    std::memset(&action, 0, sizeof(action));
    action.sa_handler = remove_temporaries_and_die;
    sigemptyset(&action.sa_mask);
    sigaction(signal_number, &action, nullptr);
  }
}

/// The pid in a temporary's name `<file>.<pid>.tmp`, or −1 when `name` is not one of `file`'s.
long pid_in_name(const std::string& name, const std::string& file) {
  const std::string suffix = ".tmp";
  if (name.size() <= file.size() + 1 + suffix.size() || name.compare(0, file.size(), file) != 0 ||
      name[file.size()] != '.' ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) {
    return -1;
  }
  const std::string digits =
      name.substr(file.size() + 1, name.size() - file.size() - 1 - suffix.size());
  if (digits.empty() || digits.size() > 9) return -1;
  for (char c : digits) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return -1;
  }
  return std::stol(digits);
}

}  // namespace

int track(const std::string& path) {
  if (path.size() >= kMaxTrackedPath) return -1;
  install_handlers_once();
  for (int i = 0; i < kMaxLiveTempFiles; ++i) {
    int expected = kFree;
    if (g_slots[i].state.compare_exchange_strong(expected, kFilling)) {
      std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
      g_slots[i].state.store(kLive, std::memory_order_release);
      return i;
    }
  }
  return -1;
}

void forget(int slot) {
  if (slot >= 0 && slot < kMaxLiveTempFiles) g_slots[slot].state.store(kFree);
}

std::string name_for(const std::string& path) {
  return path + "." + std::to_string(static_cast<long>(getpid())) + ".tmp";
}

int remove_stale(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const std::string file = target.filename().string();
  fs::path folder = target.parent_path();
  if (folder.empty()) folder = ".";
  std::error_code error;
  int removed = 0;
  for (fs::directory_iterator it(folder, error), end; !error && it != end; it.increment(error)) {
    const long pid = pid_in_name(it->path().filename().string(), file);
    if (pid <= 0 || pid == static_cast<long>(getpid())) continue;
    // kill(pid, 0) probes without signalling: ESRCH means no such process.
    if (kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code remove_error;
    if (fs::remove(it->path(), remove_error)) ++removed;
  }
  return removed;
}

}  // namespace temp_files

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)), temp_path_(path_ + ".partial") {
  stream_.open(temp_path_, std::ios::out | std::ios::trunc);
  KFX_CHECK(stream_.is_open(), "cannot write '" << temp_path_ << "'");
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    stream_.close();
    std::remove(temp_path_.c_str());
  }
}

void AtomicFile::commit() {
  stream_.flush();
  KFX_CHECK(stream_.good(), "error while writing '" << temp_path_ << "'");
  stream_.close();
  KFX_CHECK(std::rename(temp_path_.c_str(), path_.c_str()) == 0,
            "cannot rename '" << temp_path_ << "' to '" << path_ << "'");
  committed_ = true;
}

}  // namespace kfx::io
