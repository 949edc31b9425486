// The stop-signal flag and its handler (see signals.hpp). The handler only stores the
// signal number: nothing else is async-signal-safe.
#include "runtime/signals.hpp"

#include <csignal>

namespace hardrod {

namespace {
volatile std::sig_atomic_t g_stop_signal = 0;
volatile std::sig_atomic_t g_interrupts = 0;

// The first of these signals names the request. A second Ctrl-C kills at once (a person at the
// terminal means it); a repeated SIGTERM or SIGUSR1 (schedulers and wrappers often send their
// warning twice) waits for the checkpoint like the first. signal() and raise() are
// async-signal-safe.
extern "C" void on_stop_signal(int signal) {
  if (signal == SIGINT && ++g_interrupts >= 2) {
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
    return;
  }
  if (g_stop_signal == 0) g_stop_signal = signal;
}
}  // namespace

void install_stop_signals() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  action.sa_flags = 0;
  sigemptyset(&action.sa_mask);
  for (int s : {SIGTERM, SIGUSR1, SIGINT}) sigaction(s, &action, nullptr);
}

int stop_signal() { return g_stop_signal; }

std::string stop_signal_name() {
  switch (g_stop_signal) {
    case SIGTERM:
      return "SIGTERM";
    case SIGUSR1:
      return "SIGUSR1";
    case SIGINT:
      return "SIGINT";
    default:
      return "a signal to another rank";
  }
}

}  // namespace hardrod
