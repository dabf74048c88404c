// Signal handling of `clothbench sweep` (see stop_request.hpp).
#include "harness/sweep/stop_request.hpp"

#include <signal.h>
#include <unistd.h>

#include <csignal>

namespace clothbench::harness {
namespace {

// The one piece of process-wide state: a signal handler can reach nothing else.
volatile std::sig_atomic_t received_signal = 0;

extern "C" void on_stop_signal(int number) {
  if (received_signal != 0) {  // the second one: the default action, at once
    struct sigaction fallback {};
    fallback.sa_handler = SIG_DFL;
    sigemptyset(&fallback.sa_mask);
    sigaction(number, &fallback, nullptr);
    raise(number);  // delivered when this handler returns
    return;
  }
  received_signal = number;
  static const char message[] =
      "\nclothbench sweep: stopping after the current run (Ctrl-C again aborts at once)\n";
  const ssize_t written = write(STDERR_FILENO, message, sizeof message - 1);
  (void)written;
}

}  // namespace

StopRequest::StopRequest() {
  received_signal = 0;
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // reads and writes in progress carry on
  sigaction(SIGINT, &action, &previous_interrupt_);
  sigaction(SIGTERM, &action, &previous_terminate_);
}

StopRequest::~StopRequest() {
  sigaction(SIGINT, &previous_interrupt_, nullptr);
  sigaction(SIGTERM, &previous_terminate_, nullptr);
}

int StopRequest::signal() const { return received_signal; }

const char* signal_name(int signal_number) {
  switch (signal_number) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    default:
      return "a signal";
  }
}

}  // namespace clothbench::harness
