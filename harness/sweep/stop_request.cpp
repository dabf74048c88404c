// Signal handling of `clothbench sweep` (see stop_request.hpp).
#include "harness/sweep/stop_request.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>

namespace clothbench::harness {
namespace {

// The process-wide state a signal handler can reach: the signal, and the line it writes
// (set before the handler is installed, only read by it).
volatile std::sig_atomic_t received_signal = 0;
char stop_message[256] = {};
int stop_message_length = 0;

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
  const ssize_t written =
      write(STDERR_FILENO, stop_message, static_cast<size_t>(stop_message_length));
  (void)written;
}

}  // namespace

StopRequest::StopRequest(const char* command, const char* unit) {
  received_signal = 0;
  const int length =
      std::snprintf(stop_message, sizeof stop_message,
                    "\n%s: stopping after %s (Ctrl-C again aborts at once)\n", command, unit);
  stop_message_length =
      length < 0 ? 0 : std::min(length, static_cast<int>(sizeof stop_message) - 1);
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
