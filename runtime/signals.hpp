// Stop signals: SIGTERM, SIGUSR1 and SIGINT only set a flag that the run loop polls before
// every burst of steps; the ranks agree on it in the next step's reduction, finish that step,
// write a checkpoint and stop (see runtime/run_loop.hpp). This file does not decide what a
// stop does; it only records which signal arrived.
#pragma once

#include <string>

namespace hardrod {

// Installed by main() before MPI starts, so a signal during start-up is not lost either. Only a
// second Ctrl-C takes the default action (kills at once); a repeated SIGTERM or SIGUSR1 (batch
// systems send one, or a chosen signal, some time before the wall-clock limit, and some send it
// twice) still waits for the checkpoint.
void install_stop_signals();
int stop_signal();  // the first of SIGTERM, SIGUSR1, SIGINT received, 0 if none
// "SIGTERM", "SIGUSR1", "SIGINT", or "a signal to another rank" when none arrived here.
std::string stop_signal_name();

}  // namespace hardrod
