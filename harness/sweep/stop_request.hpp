// Ctrl-C (SIGINT) and SIGTERM during `clothbench sweep` (and `clothbench stress`): the first
// one asks the command to stop after the run in progress (every finished row or cell is
// already on disk), a second one ends the process at once with the signal's default action.
#pragma once

#include <signal.h>

namespace clothbench::harness {

/// While alive, SIGINT and SIGTERM only record that a stop was asked for (the first time;
/// a second signal terminates the process). The previous handlers are restored on
/// destruction. The handler writes one line to stderr saying so, naming `command` (e.g.
/// "clothbench sweep") and what it finishes first (`unit`, e.g. "the current run"; both
/// are cut to fit a fixed buffer). One instance at a time.
class StopRequest {
 public:
  explicit StopRequest(const char* command = "clothbench sweep",
                       const char* unit = "the current run");
  ~StopRequest();
  StopRequest(const StopRequest&) = delete;
  StopRequest& operator=(const StopRequest&) = delete;

  /// The first signal received (SIGINT or SIGTERM), 0 while none was.
  [[nodiscard]] int signal() const;

 private:
  struct sigaction previous_interrupt_ {};
  struct sigaction previous_terminate_ {};
};

/// "SIGINT", "SIGTERM", or "a signal".
const char* signal_name(int signal_number);

}  // namespace clothbench::harness
