// Self-test probes: run a driver on a small parallel loop and count how often each index
// is visited. The registry probes every driver it creates, because some OpenMP runtimes
// get some schedule clauses wrong (libomp 14 with Clang 14 runs every iteration of
// `schedule(monotonic:static)` and `schedule(nonmonotonic:static)` on every thread).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "schedulers/loop_driver.hpp"

namespace clothbench::schedulers {

/// Outcome of one probe: several consecutive loops in one parallel region.
struct ProbeReport {
  bool exactly_once = true;             ///< every index of every loop visited exactly once
  int threads = 0;                      ///< team size the probe actually got
  std::int64_t wrong_indices = 0;       ///< indices visited != 1 times (over all loops)
  std::int64_t first_wrong_n = 0;       ///< loop size of the first wrong loop
  std::int64_t first_wrong_index = -1;  ///< first index visited != 1 times
  int first_wrong_visits = 0;           ///< how often it was visited
  bool range_out_of_bounds = false;     ///< a body range was empty or outside [0, n)
  /// One-line description, e.g. "index 0 of 1000 visited 4 times with 4 threads".
  [[nodiscard]] std::string describe() const;
};

/// Runs `driver` in a parallel region of `threads` threads (must be called outside any
/// parallel region) over loops of 1000, 0 and 3 iterations, and counts the visits.
ProbeReport probe_exactly_once(LoopDriver& driver, int threads = 4);

/// A schedule clause the running OpenMP runtime gets wrong.
struct RuntimeDefect {
  std::string spec;         ///< literal scheduler spec, e.g. "monotonic:static@blocks"
  std::string description;  ///< what goes wrong, from the probe
};

/// Probes the literal clauses known to be fragile (static with a schedule modifier,
/// with and without chunk) and returns those that fail. Empty on a correct runtime.
std::vector<RuntimeDefect> detect_runtime_defects();

}  // namespace clothbench::schedulers
