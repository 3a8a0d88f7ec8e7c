#pragma once
// Stop requests from outside (a batch scheduler's SIGTERM, a user's Ctrl-C): the handler only
// records the signal; the run loop polls it after each step and stops there, resumable.
namespace vimd {

// Handlers for SIGTERM and SIGINT. The first asks the run to stop; a second is acknowledged on
// stderr and changes nothing (the stop, its checkpoint included, is already under way: ending
// before the checkpoint is in place would leave the run unable to continue); a third ends the
// process at once, saying so, for a run that does not get to its stop.
void install_stop_handlers();
// The signal that asked the run to stop, or 0.
int stop_signal();
// Records a stop request as a handler would (tests; signal-safe).
void request_stop(int signal);

}  // namespace vimd
