// The versioned JSON document of one sweep (`clothbench.sweep`, schema_version 1) and how
// a row of it is made from measured runs. Layout (every key always present):
//
//   schema "clothbench.sweep", schema_version 1, created_utc, updated_utc, complete (bool),
//   command [argv], settings {schedulers, threads, repeat, warmup_steps, steps, instrument,
//   bind, oversubscribe, retries, omp_wait_policy (the last two absent in older documents)}, scene {name, file, hash, source}, machine (machine_context()),
//   openmp_environment (openmp_environment()), reference {scheduler, threads, state_digest,
//   state_bytes}, rows [ROW ...]
//
//   ROW: scheduler (as given), scheduler_canonical, note, threads, oversubscribed,
//   time_seconds {median, min, max, samples[]}        -- uninstrumented runs
//   instrumented {level, time_seconds {...} | null, cost_seconds | null, cost_percent | null}
//   accounting {from_run, wall_seconds, step_seconds, sequential_overhead_seconds,
//     parallel_overhead_seconds, load_imbalance_seconds, parallel_work_seconds,
//     unaccounted_seconds, imbalance_percent, thread_work_cv, loops, chunks,
//     thread_work_seconds[]} | null (instrument off)
//   verification {passed, failures[], runs, bit_identical, state_digest, max_mass_error}
//   disturbance {disturbed, disturbed_runs, runs, reruns, records [{disturbed, reasons[],
//     cpu_seconds, wall_seconds, cpu_share, involuntary_switches, switch_rate_per_core_second,
//     load_before, load_after, wait_policy, oversubscribed, instrumented, attempts}]}
//     (absent in documents written before disturbance was measured)
//   cg_iterations, steps, binding {mode, bound, threads [{thread, cpuset, last_pu}]}
//   derived {speedup, efficiency, speedup_vs_best_1thread, efficiency_vs_best_1thread}
//     (numbers, or null when this row or its 1-thread baseline failed or is missing)
#pragma once

#include <nlohmann/json.hpp>
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

/// The accounting block of one run as JSON.
nlohmann::json accounting_json(const OverheadAccounting& a, std::size_t from_run);

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
