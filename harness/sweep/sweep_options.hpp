// Options of `clothbench sweep` (the grid of schedulers x thread counts behind the paper's
// Table 2 and Fig. 12) and the parsing of its list arguments.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/loop_runner.hpp"

namespace clothbench::harness {

/// How the OpenMP threads of every run are pinned.
enum class BindMode {
  none,  ///< leave it to the OpenMP runtime (OMP_PROC_BIND / OMP_PLACES are respected)
  core,  ///< thread k of the team is bound to hwloc core k mod cores before each run
};

/// The paper's six configurations of Fig. 12, the default scheduler list.
inline constexpr std::string_view kPaperSchedulers =
    "static,dynamic:1,dynamic:2,dynamic:3,guided:1,active-lists";

/// Everything a sweep needs, as given on the command line.
struct SweepOptions {
  std::filesystem::path scene_file;
  std::optional<std::string> size_class;  ///< --class S|W|A|B (size_class.hpp), if given
  std::vector<std::string> schedulers;  ///< specs as given, e.g. "dynamic:2"; order is kept
  std::vector<int> threads;             ///< empty = default_thread_counts()
  int repeat = 3;                       ///< measured repetitions per row and timing level
  int warmup_steps = 2;                 ///< steps of the uncounted warm-up run per row (0: none)
  /// A reference run at least this long counts as the first uninstrumented run of its
  /// scheduler's 1-thread row when rows have no warm-up (a process's first run pays start-up
  /// costs that a short run would show, a long one not).
  double count_reference_after_seconds = 60.0;
  std::optional<int> steps;             ///< override the scene's step count
  kernels::Instrumentation instrument = kernels::Instrumentation::loops;
  /// --instrument-only: the schedulers (specs, as given) whose rows get the instrumented runs;
  /// empty: every row. run_sweep checks that each is one of `schedulers` and records their
  /// canonical names in settings.instrument_only.
  std::vector<std::string> instrument_only;
  BindMode bind = BindMode::none;
  bool allow_oversubscribe = false;  ///< thread counts above the hardware threads
  /// Re-runs of a disturbed repetition (disturbance.hpp) before it counts as disturbed.
  int retries = 2;
  bool resume = false;               ///< skip rows already in OUT/sweep.json
  bool quiet = false;                ///< no progress bar, no per-row lines
  bool plots = true;                 ///< run gnuplot at the end
  /// --trace DIR: extra traced runs per row (min(--repeat, 3), the median kept),
  /// DIR/<scheduler>-<threads>t.cbtrace (+ timeline)
  std::optional<std::filesystem::path> trace_dir;
  /// --trace-overheads FILE: scheduling costs copied into every trace's header (predict uses
  /// them); see harness/predict/overhead_model.hpp.
  std::optional<std::filesystem::path> trace_overheads;
  /// --trace-bandwidth FILE: the triad's bandwidth by thread count, copied likewise (the
  /// predictor's ceiling); see harness/predict/bandwidth_model.hpp.
  std::optional<std::filesystem::path> trace_bandwidth;
  std::filesystem::path output_dir = "results/latest";
  std::vector<std::string> command_line;  ///< argv, recorded in the result
};

/// Splits "a,b,c" at commas; empty items are an error (std::invalid_argument naming `flag`).
std::vector<std::string> split_list(std::string_view text, const char* flag);

/// Parses "1,2,4" or ranges "1-8" (every integer); each count must be >= 1. Throws
/// std::invalid_argument with a message naming `flag` and the bad item.
std::vector<int> parse_thread_list(std::string_view text, const char* flag);

/// Default thread counts: powers of two up to `cores`, plus `cores` itself (1,2 on 2 cores;
/// 1,2,4,6 on 6 cores). `cores` comes from hwloc (physical cores).
std::vector<int> default_thread_counts(int cores);

/// What the sweep knows of its reference run (an uninstrumented 1-thread run of the first
/// scheduler, measured like a row's runs) when it decides whether to count it.
struct ReferenceRunFacts {
  bool resuming = false;     ///< the sweep continues an earlier one (--resume)
  bool disturbed = false;    ///< other work on the machine disturbed it (disturbance.hpp)
  double wall_seconds = 0.0;
};

/// Whether the reference run counts as the first uninstrumented run of its scheduler's
/// 1-thread row instead of being thrown away: only in a fresh sweep (not resuming) with a
/// 1-thread row in `threads`, whose rows have no warm-up and no binding (the reference had
/// neither, so it was measured exactly as they are), and only when the run was undisturbed and
/// at least options.count_reference_after_seconds long (a short run would carry the process's
/// start-up costs into the row).
bool reference_counts_in_row(const SweepOptions& options, const std::vector<int>& threads,
                             const ReferenceRunFacts& reference);

/// options.instrument_only as the canonical scheduler names, in the order given, each once.
/// `grid` holds the canonical names of options.schedulers. Throws std::invalid_argument naming
/// --instrument-only when a spec is malformed, is not in the grid, or instrumentation is off.
std::vector<std::string> canonical_instrument_only(const SweepOptions& options,
                                                   const std::vector<std::string>& grid);

/// "off" | "loops" | "chunks" and back.
kernels::Instrumentation parse_instrumentation(std::string_view text);
std::string to_string(kernels::Instrumentation instrumentation);
std::string to_string(BindMode mode);

}  // namespace clothbench::harness
