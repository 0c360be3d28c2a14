#include "interrupt.hpp"

#include <signal.h>

#include <cstring>

namespace kfx::cli {
namespace {

volatile sig_atomic_t g_requested = 0;
struct sigaction g_previous;

extern "C" void on_sigint(int signal_number) {
  if (g_requested) {  // the second one: stop now, through whatever SIGINT did before
    sigaction(signal_number, &g_previous, nullptr);
    raise(signal_number);
    return;
  }
  g_requested = 1;
}

}  // namespace

InterruptRequests::InterruptRequests() {
  g_requested = 0;
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = on_sigint;
  sigemptyset(&action.sa_mask);
  // SA_RESTART: a read or write in progress carries on rather than failing with EINTR.
  action.sa_flags = SA_RESTART;
  sigaction(SIGINT, &action, &g_previous);
  // A SIGINT the caller ignores (a shell's background job) stays ignored.
  if (g_previous.sa_handler == SIG_IGN) sigaction(SIGINT, &g_previous, nullptr);
}

InterruptRequests::~InterruptRequests() { sigaction(SIGINT, &g_previous, nullptr); }

bool InterruptRequests::requested() { return g_requested != 0; }

}  // namespace kfx::cli
