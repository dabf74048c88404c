// One timed, verified simulation run of a sweep and its overhead decomposition
// (MODEL.md section 7; the paper's Table 2 columns plus load imbalance).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "harness/run/disturbance.hpp"
#include "harness/run/resident_memory.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/run/verify.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/loop_driver.hpp"

namespace clothbench::harness {

/// Where the time of one run went (seconds). With the kernel's step timer `step_seconds`:
///   sequential_overhead = step_seconds - loop_wall        (outside parallel loops)
///   parallel_overhead   = loop_wall - busiest_sum          (fork/join, barriers, dispatch)
///   load_imbalance      = busiest_sum - mean_sum           (waiting for the busiest thread)
///   parallel_work       = mean_sum                         (mean thread work in loops)
/// so the four add up to step_seconds; `unaccounted` = wall - step_seconds is what the outer
/// clock saw outside the kernel's timer (should be ~0; the identity test bounds it).
struct OverheadAccounting {
  double wall_seconds = 0.0;  ///< outer clock around all step() calls
  double step_seconds = 0.0;  ///< sum of StepReport::seconds
  double sequential_overhead = 0.0;
  double parallel_overhead = 0.0;
  double load_imbalance = 0.0;
  double parallel_work = 0.0;
  double unaccounted = 0.0;
  /// 100 * (busiest_sum / mean_sum - 1): how much longer the busiest thread worked than the mean.
  double imbalance_percent = 0.0;
  /// Standard deviation / mean of the per-thread total work (0 for one thread).
  double thread_work_cv = 0.0;
  std::int64_t loops = 0;   ///< loop executions
  std::int64_t chunks = 0;  ///< chunks over all threads
  std::vector<double> thread_work;  ///< per thread, seconds
};

/// One measured run.
struct MeasuredRun {
  OverheadAccounting accounting;  ///< timings only meaningful when instrumented (else wall)
  kernels::Instrumentation instrumentation = kernels::Instrumentation::off;
  std::int64_t cg_iterations = 0;
  int steps_done = 0;
  double mass_error = 0.0;
  bool finite = true;
  bool bit_identical = true;  ///< final state bytes equal the reference's
  std::string state_digest;   ///< FNV-1a 64 of state_bytes()
  Verification verification;
  /// Whether other work on the machine disturbed the timed steps (disturbance.hpp).
  Disturbance disturbance;
  int attempts = 1;  ///< runs made for this repetition (1 + disturbed runs re-done)
  /// The sweep's reference run, counted as the first uninstrumented run of its row
  /// (reference_counts_in_row); marked in the row's run records.
  bool reference = false;
  /// Resident memory from the start of the run's set-up (a fresh simulation) to its last
  /// step (resident_memory.hpp); filled by the caller that builds the simulation.
  RunMemory memory;
};

/// Runs `steps` steps of `simulation` (fresh, thread count already set with
/// omp_set_num_threads) through `driver`, timing with `instrumentation`, then verifies the
/// final state with the one verifier (verify_state: finite, mass, no crack, no particle
/// inside an obstacle, and - when `reference` is not null - bit-identity of state_bytes()
/// to it) and the steps' costs finite.
MeasuredRun measure_run(kernels::Simulation& simulation, schedulers::LoopDriver& driver,
                        int steps, kernels::Instrumentation instrumentation,
                        const StateReference* reference);

/// Computes the derived fields of `a` (components, percent, CV) from a LoopTimes and the
/// two clocks. Exposed for the accounting tests.
OverheadAccounting account(const kernels::LoopTimes& times, double wall_seconds,
                           double step_seconds);

}  // namespace clothbench::harness
