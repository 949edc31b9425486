// Stop signals: the first one only records itself; a second of the same kind takes its
// default action. In a child process (a death test), so that the flag, which cannot be
// cleared, does not stop the runs of other tests in this process.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>

#include "runtime/signals.hpp"

namespace hardrod {
namespace {

TEST(SignalsDeathTest, FirstSignalIsRecordedSecondActs) {
  EXPECT_EXIT(
      {
        install_stop_signals();
        if (stop_signal() != 0 || stop_signal_name() != "a signal to another rank") std::exit(1);
        std::raise(SIGUSR1);
        if (stop_signal() != SIGUSR1 || stop_signal_name() != "SIGUSR1") std::exit(2);
        std::raise(SIGUSR1);  // the handler was reset: this one ends the process
        std::exit(3);
      },
      testing::KilledBySignal(SIGUSR1), "");
}

}  // namespace
}  // namespace hardrod
