#pragma once
// Stop requests from outside (a batch scheduler's SIGTERM, a user's Ctrl-C): the handler only
// records the signal; the run loop polls it after each step and stops there, resumable.
namespace vimd {

// Handlers for SIGTERM and SIGINT; a second one of either kind ends the process at once.
void install_stop_handlers();
// The signal that asked the run to stop, or 0.
int stop_signal();
// Records a stop request as a handler would (tests; signal-safe).
void request_stop(int signal);

}  // namespace vimd
