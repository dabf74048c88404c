// Was a timed run disturbed by other work on the machine? Measured per run from this
// process's resource usage (getrusage RUSAGE_SELF: CPU time of all its threads, involuntary
// context switches) and the 1-minute load average, before and after the run. A disturbed
// sweep repetition is re-run (`sweep --retries`); a row that stays disturbed is labelled
// DISTURBED in every output and gets no speed-up.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace clothbench::harness {

/// This process's counters at one moment.
struct ResourceSample {
  double wall_seconds = 0.0;           ///< monotonic clock
  double cpu_seconds = 0.0;            ///< user + system time of every thread of the process
  long involuntary_switches = 0;       ///< ru_nivcsw: preempted while it could have run
  double load_average = -1.0;          ///< 1-minute load average (-1: unavailable)
};

/// The counters now.
ResourceSample sample_resources();

/// OMP_WAIT_POLICY as this process sees it: "active", "passive", or "unset" (the runtime's
/// default: libgomp spins a while, then sleeps).
std::string omp_wait_policy();

/// Thresholds of disturbance; they scale with the threads a run may use, so they hold from 1
/// to 128 threads alike.
struct DisturbanceCriteria {
  /// Involuntary context switches per second per usable core above which another process
  /// took the cores. Measured on the 2-core development VM with nothing else running: 2-5
  /// per second at 1 thread, 25-30 at 2 threads; with one busy process per core beside the
  /// run, 100-140 at either thread count (the scheduler's time slices).
  double max_switch_rate = 60.0;
  /// Switches a run may always show, however short (a short run's rate is noise).
  long min_switches = 10;
  /// With spinning waits (OMP_WAIT_POLICY=active) every thread is on a CPU all the time, so
  /// CPU time / (wall x usable cores) below this means CPU time was taken away. Not judged with
  /// passive or default waits, where threads that wait sleep (a load imbalance looks the same).
  double min_cpu_share = 0.8;
  /// Load average (1 min) above hardware threads + this margin, both before and after the
  /// run: more runnable work than cores even if every thread of this run counted.
  double load_margin = 0.5;
};

/// What one run's counters say.
struct Disturbance {
  int threads = 1;
  int usable_cores = 1;  ///< min(threads, hardware threads)
  double wall_seconds = 0.0;
  double cpu_seconds = 0.0;
  double cpu_share = 0.0;            ///< cpu / (wall x usable cores)
  long involuntary_switches = 0;
  double switch_rate = 0.0;          ///< involuntary switches per second per usable core
  double load_before = -1.0, load_after = -1.0;
  std::string wait_policy;
  bool oversubscribed = false;       ///< threads > hardware: switches are the run's own
  bool disturbed = false;
  std::vector<std::string> reasons;  ///< one line per criterion met
};

/// Judges the run between `before` and `after` with `threads` threads on a machine with
/// `hardware_threads`, under `wait_policy` (omp_wait_policy()). An oversubscribed run's own
/// threads preempt each other, so its switches are recorded, not judged.
Disturbance assess_disturbance(const ResourceSample& before, const ResourceSample& after,
                               int threads, int hardware_threads, const std::string& wait_policy,
                               const DisturbanceCriteria& criteria = {});

/// The record as JSON: {disturbed, reasons[], cpu_seconds, wall_seconds, cpu_share,
/// involuntary_switches, switch_rate_per_core_second, load_before, load_after (null when
/// unavailable), wait_policy, oversubscribed}.
nlohmann::json disturbance_json(const Disturbance& d);

}  // namespace clothbench::harness
