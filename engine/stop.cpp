#include "engine/stop.hpp"

#include <pthread.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>

namespace vimd {
namespace {
// Atomics, not volatile: the signal may be handled on any of the run's threads.
std::atomic<int> requested = 0;
std::atomic<int> signals_after_request = 0;

void say(const char* text) {  // async-signal-safe
  [[maybe_unused]] const ssize_t written = ::write(STDERR_FILENO, text, std::strlen(text));
}

const char* name(int signal) { return signal == SIGINT ? "SIGINT" : "SIGTERM"; }

extern "C" void on_stop_signal(int signal) {
  if (requested == 0) {
    requested = signal;
    return;
  }
  if (++signals_after_request == 1) {
    say("\nvimd: a second ");
    say(name(signal));
    say(": already stopping after this step, with a checkpoint to continue from; a third ends vimd at once, "
        "without it\n");
    return;
  }
  say("\nvimd: a third ");
  say(name(signal));
  say(": ending now, without the stop's checkpoint (a continue starts from the last one written, if any)\n");
  std::signal(signal, SIG_DFL);
  sigset_t own;  // blocked while its own handler runs: unblocked, it ends the process by itself
  sigemptyset(&own);
  sigaddset(&own, signal);
  pthread_sigmask(SIG_UNBLOCK, &own, nullptr);
  std::raise(signal);
}
}  // namespace

void install_stop_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGINT, &action, nullptr);
}

int stop_signal() { return requested; }

void request_stop(int signal) {
  requested = signal;
  signals_after_request = 0;
}

}  // namespace vimd
