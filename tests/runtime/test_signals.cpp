// Stop signals: the first one only records itself; a repeated SIGTERM or SIGUSR1 waits for the
// checkpoint like the first, and only a second Ctrl-C kills at once. In child processes (death
// tests), so that the flag, which cannot be cleared, does not stop the runs of other tests.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>

#include "runtime/signals.hpp"

namespace hardrod {
namespace {

TEST(SignalsDeathTest, FirstSignalIsRecordedRepeatsWait) {
  EXPECT_EXIT(
      {
        install_stop_signals();
        if (stop_signal() != 0 || stop_signal_name() != "a signal to another rank") std::exit(1);
        std::raise(SIGUSR1);
        if (stop_signal() != SIGUSR1 || stop_signal_name() != "SIGUSR1") std::exit(2);
        std::raise(SIGUSR1);  // a scheduler's warning sent twice: still only recorded
        std::raise(SIGTERM);
        std::raise(SIGTERM);
        if (stop_signal() != SIGUSR1) std::exit(3);  // the first one is kept
        std::exit(0);
      },
      testing::ExitedWithCode(0), "");
}

TEST(SignalsDeathTest, SecondCtrlCKillsAtOnce) {
  EXPECT_EXIT(
      {
        install_stop_signals();
        std::raise(SIGTERM);
        std::raise(SIGINT);  // the first Ctrl-C: recorded (SIGTERM stays the stop's name)
        if (stop_signal() != SIGTERM) std::exit(1);
        std::raise(SIGINT);  // the second: the default action
        std::exit(2);
      },
      testing::KilledBySignal(SIGINT), "");
}

}  // namespace
}  // namespace hardrod
