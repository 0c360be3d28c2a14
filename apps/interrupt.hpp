#pragma once
/// Ctrl-C during a long command: the first SIGINT asks the command to stop after the frame in
/// hand and keep what it did (every output of the frames done); a second one stops at once, as
/// SIGINT does by default.

#include <stdexcept>

namespace kfx::cli {

/// Exit status of a command stopped by SIGINT (128 + SIGINT, as shells report it).
constexpr int kInterruptedExitStatus = 130;

/// While alive, SIGINT sets a flag instead of ending the process; a second SIGINT restores the
/// handler that was there before (the default, or the temporary-file cleanup of
/// io/atomic_file.hpp) and raises it. The destructor restores that handler too.
class InterruptRequests {
 public:
  InterruptRequests();
  ~InterruptRequests();
  InterruptRequests(const InterruptRequests&) = delete;
  InterruptRequests& operator=(const InterruptRequests&) = delete;

  /// Whether a SIGINT came since construction.
  static bool requested();
};

/// Thrown once a command interrupted by SIGINT has written what it keeps; main() prints the
/// message and exits with kInterruptedExitStatus.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace kfx::cli
