// The versioned JSON document of one sweep (`clothbench.sweep`, schema_version 1) and how
// a row of it is made from measured runs. Layout (every key always present):
//
//   schema "clothbench.sweep", schema_version 1, created_utc, updated_utc, complete (bool),
//   command [argv], settings {schedulers, threads, repeat, warmup_steps, steps, instrument,
//   instrument_only [canonical scheduler names; empty: every row], bind, oversubscribe,
//   retries, omp_wait_policy, count_reference_after_seconds (instrument_only and the last
//   three absent in older documents)},
//   scene {name, file, hash, source}, machine (machine_context()), openmp_environment
//   (openmp_environment()), reference {scheduler, threads, state_digest, state_bytes,
//   verification_passed, wall_seconds, disturbed, counted_in_row (the reference run is the
//   first uninstrumented run of its scheduler's 1-thread row; the last three absent in older
//   documents)},
//   sessions [{started_utc, load_average, rows_at_start, reference "run" | "stored" | "digest"
//   (a resume compared its rows with the stored reference state, or by its digest)}] (one
//   per start or --resume; absent in older documents; `machine` is the first session's, and a
//   resume must match its build, compiler, processor, host, OpenMP runtime and allocator),
//   rows [ROW ...],
//   partial_rows [{scheduler_canonical, threads, plain [RUN ...], timed [RUN ...],
//     core_round_trip_before_ns (rows of 2 or more threads; absent in older documents)}] (the
//     runs of rows an interrupted session did not finish, taken up by --resume; absent when none)
//
//   RUN: instrumentation, cg_iterations, steps_done, mass_error, finite, bit_identical,
//   state_digest, attempts, reference (as a ROW record's; absent in older documents),
//   verification {passed, failures[]}, accounting (as ROW's, from_run
//   0), disturbance (as a ROW's record, plus threads and usable_cores), memory
//   {start_resident_bytes, peak_resident_bytes, scope "run" | "process" | "unknown"} (the
//   process's resident set when the run's set-up began and its highest until the run's last
//   step; "run": the high-water mark was reset at the start, so the peak is this run's;
//   resident_memory.hpp; absent in older documents)
//
//   ROW: scheduler (as given), scheduler_canonical, note, threads, oversubscribed,
//   time_seconds {median, min, max, samples[]}        -- uninstrumented runs
//   instrumented {level, time_seconds {...} | null, cost_seconds | null, cost_percent | null,
//     cost_ratio | null (instrumented median / uninstrumented median; absent in older documents)}
//   accounting {from_run, wall_seconds, step_seconds, sequential_overhead_seconds,
//     parallel_overhead_seconds, load_imbalance_seconds, parallel_work_seconds,
//     unaccounted_seconds, imbalance_percent, thread_work_cv, loops, chunks,
//     thread_work_seconds[],
//     source "median instrumented run", runs (instrumented runs; from_run indexes them),
//     identity {wall_seconds, parts_seconds, residual_seconds, overheads_seconds,
//       time_median_seconds, wall_over_time, overheads_exceed_time, note}
//     (source, runs and identity absent in older documents: accounting_identity() derives
//     the same figures from the fields above)} | null (instrument off)
//   verification {passed, failures[], runs, bit_identical, state_digest, max_mass_error}
//   disturbance {disturbed, disturbed_runs, runs, reruns, records [{disturbed, reasons[],
//     cpu_seconds, wall_seconds, cpu_share, involuntary_switches, switch_rate_per_core_second,
//     load_before, load_after, wait_policy, oversubscribed, instrumented, attempts,
//     reference (true only for the sweep's reference run when counted_in_row: the first
//     record of that row; absent in older documents)}]}
//     (absent in documents written before disturbance was measured)
//   memory {peak_resident_bytes (the highest of its runs' peaks) | null, scope "run" |
//     "process" | "unknown", runs_measured, runs, records [{start_resident_bytes,
//     peak_resident_bytes, scope, instrumented}] (plain runs, then instrumented, as
//     disturbance.records)} (absent in older documents)
//   cg_iterations, steps, binding {mode, bound, threads [{thread, cpuset, last_pu}]}
//   derived {speedup, efficiency, speedup_vs_best_1thread, efficiency_vs_best_1thread}
//     (numbers, or null when this row or its 1-thread baseline failed or is missing)
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "harness/sweep/measured_run.hpp"
#include "harness/sweep/sweep_options.hpp"

namespace clothbench::harness {

/// Version of the `clothbench.sweep` layout; bump when keys change meaning or move.
inline constexpr int kSweepSchemaVersion = 1;

/// Median (lower middle for even counts), min, max and samples of `values` as JSON.
nlohmann::json sample_statistics(const std::vector<double>& values);

/// Index of the median element of `values` (lower middle for even counts); 0 when empty.
std::size_t median_index(const std::vector<double>& values);

/// What identifies one row of the grid.
struct RowKey {
  std::string scheduler_canonical;
  int threads = 0;
};

/// Builds a row from the uninstrumented runs (`plain`) and instrumented runs (`timed`,
/// empty with --instrument off) of one (scheduler, threads) cell. The row is disturbed when
/// any of its runs stayed disturbed (MeasuredRun::disturbance after its retries).
nlohmann::json make_row(const std::string& scheduler, const std::string& canonical,
                        const std::string& note, int threads, bool oversubscribed,
                        const std::vector<MeasuredRun>& plain,
                        const std::vector<MeasuredRun>& timed,
                        kernels::Instrumentation level, int steps, nlohmann::json binding);

/// The accounting identity of a row's overhead figures (MODEL.md section 7). The overheads
/// come from one instrumented run (accounting.from_run of the row's instrumented runs, the
/// median by wall time), not from the uninstrumented runs whose median is the row's Time, so
/// every report shows them beside that run's own wall time:
///   wall = sequential overhead + parallel work + parallel overhead + imbalance + residual
/// where the residual (the time outside the kernel's step timer, plus rounding) is shown too.
/// `overheads_exceed_time` marks a row whose three overheads add up to more than its Time
/// (possible only when the instrumented run took longer than the timed median): reports
/// label such a row and say why (`note`).
struct AccountingIdentity {
  double wall_seconds = 0.0;  ///< the instrumented run's wall time
  double sequential_overhead = 0.0;
  double parallel_work = 0.0;
  double parallel_overhead = 0.0;
  double load_imbalance = 0.0;
  double parts_seconds = 0.0;          ///< the four components' sum
  double residual_seconds = 0.0;       ///< time outside the step timer (unaccounted_seconds)
  double overheads_seconds = 0.0;      ///< sequential + parallel overhead + imbalance
  double time_median_seconds = 0.0;    ///< the row's Time: median of the uninstrumented runs
  double wall_over_time = 0.0;         ///< wall / time median (0 when the median is 0)
  bool overheads_exceed_time = false;  ///< overheads_seconds > time_median_seconds
  std::size_t from_run = 0;            ///< 0-based index among the instrumented runs
  std::size_t runs = 0;                ///< instrumented runs of the row (0 when not recorded)
  std::string note;                    ///< why the overheads exceed the Time; empty otherwise
};

/// The identity of `row` computed from its accounting fields (so rows of older documents get
/// it too); nullopt when the row has no accounting (--instrument off).
std::optional<AccountingIdentity> accounting_identity(const nlohmann::json& row);

/// An identity as the JSON block `accounting.identity`.
nlohmann::json identity_json(const AccountingIdentity& identity);

/// Instrumented median / uninstrumented median of `row`, or nullopt (not instrumented, or an
/// older document without the instrumented samples).
std::optional<double> instrumentation_cost_ratio(const nlohmann::json& row);

/// The accounting block of one run as JSON.
nlohmann::json accounting_json(const OverheadAccounting& a, std::size_t from_run);

/// One measured run as a RUN object (layout above) and back: a run read back makes the same
/// row as the run itself (doubles are written with enough digits to round-trip). Throws
/// std::invalid_argument naming the missing or mistyped key.
nlohmann::json measured_run_json(const MeasuredRun& run);
MeasuredRun measured_run_from_json(const nlohmann::json& j);

/// Records the finished runs of the unfinished row `key` in `document["partial_rows"]`
/// (replacing an earlier entry for it), so an interrupted sweep loses at most the run in
/// progress. `round_trip_before_ns`: the core round trip measured before the row's first run
/// (rows of 2 or more threads; 0 = none, not written).
void store_partial_row(nlohmann::json& document, const RowKey& key,
                       const std::vector<MeasuredRun>& plain, const std::vector<MeasuredRun>& timed,
                       double round_trip_before_ns = 0.0);

/// The runs stored for `key` by store_partial_row, appended to `plain` and `timed`, and its
/// round trip before the row's first run in `*round_trip_before_ns` (0 when none was stored);
/// false (nothing appended) when there are none.
bool take_partial_row(const nlohmann::json& document, const RowKey& key,
                      std::vector<MeasuredRun>& plain, std::vector<MeasuredRun>& timed,
                      double* round_trip_before_ns = nullptr);

/// Removes the entry for `key` (the row is finished), and `partial_rows` once it is empty.
void drop_partial_row(nlohmann::json& document, const RowKey& key);

/// Settings block of a sweep.
nlohmann::json settings_json(const SweepOptions& options, const std::vector<int>& threads,
                             int steps);

/// True when `document[rows]` already holds a row for `key`.
bool has_row(const nlohmann::json& document, const RowKey& key);

/// Checks the structure of a sweep document: schema name and version, every key of the
/// layout above with its JSON type. Returns one line per problem (empty = valid).
std::vector<std::string> validate_sweep_document(const nlohmann::json& document);

/// Throws std::runtime_error naming the field if any number in `j` is NaN or infinite.
void check_finite(const nlohmann::json& j, const std::string& path);

/// Current UTC time as "YYYY-MM-DDTHH:MM:SSZ".
std::string utc_now();

}  // namespace clothbench::harness
