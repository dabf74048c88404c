// The scheduling costs the predictor adds to the replayed work (issue 17): per loop (fork/join
// and the closing barrier) and per chunk (dispatch), read from the JSON that
// `clothbench-micro --benchmark_filter=scheduling_overhead --benchmark_out=FILE
// --benchmark_format=json` writes (harness/micro/scheduling_overhead.cpp, which measures every
// scheduler at 1 thread and at the machine's team size P), or from a trace's header (copied
// there by `run|sweep --trace-overheads FILE`), or zero.
//
// Only what P threads cost beyond 1 thread is added: a trace's chunk and loop times already
// hold what its loops paid at 1 thread, so the model is overhead(P) - overhead(1), per loop and
// per chunk, added at every predicted thread count above 1 and never at 1.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace clothbench::harness {

/// Costs per loop and per chunk beyond a 1-thread run's, measured at one team size.
struct OverheadModel {
  /// Where the figures come from, for the output: the file, or why they are zero.
  std::string source = "none: overheads assumed zero (no --overheads FILE; the trace stores none)";
  bool measured = false;
  int measured_threads = 0;  ///< team size P of the micro-benchmark run
  /// OMP_WAIT_POLICY of the micro-benchmark run ("active", "passive", "unset"; "not recorded"
  /// for files and headers that predate it): sleeping waits cost far more per loop.
  std::string wait_policy = "not recorded";
  /// The cache-line round trip between two cores (ns; 0: not recorded) while static@blocks ran
  /// at P, i.e. where the host had put the cores when the per-loop cost was measured
  /// (harness/run/core_round_trip.hpp): the mean of the benchmark's before and after values.
  double round_trip_ns = 0.0;
  /// The same for each spec's P-thread result, which its dispatch cost comes from.
  std::map<std::string, double> dispatch_round_trip_ns;
  /// Per loop, above 1 thread: static@blocks' overhead at P - at 1 thread, at least 0. The
  /// replay lets every thread but the first start each loop this much later (the fork's
  /// wake-up, which dominates when waiting threads sleep), so a self-scheduled clause absorbs
  /// part of it where static cannot (schedule_simulation.hpp).
  double loop_seconds = 0.0;
  double loop_seconds_at_one = 0.0;       ///< static@blocks' per-loop overhead at 1 thread
  double loop_seconds_at_measured = 0.0;  ///< static@blocks' per-loop overhead at P threads
  /// Per chunk, added above 1 thread, by canonical spec: dispatch at P - dispatch at 1, >= 0.
  std::map<std::string, double> dispatch_seconds;
  /// Results the micro-benchmark marked disturbed (other work took the cores), at either team
  /// size: not used for dispatch costs (static@blocks is used anyway, and listed, when it is
  /// one of them).
  std::vector<std::string> disturbed;

  /// Dispatch cost of one chunk of `canonical`: its own figure, else that of the same kind
  /// with another chunk size (e.g. dynamic:3 from dynamic:1), else 0.
  [[nodiscard]] double dispatch(const std::string& canonical) const;
  /// How dispatch(canonical) was found, for the output ("measured", "from dynamic:1@blocks",
  /// "none: 0").
  [[nodiscard]] std::string dispatch_source(const std::string& canonical) const;
};

/// Reads the Google Benchmark JSON of the scheduling_overhead benchmarks, which holds each
/// spec at 1 thread and at P > 1 threads (the `threads` counter). With o(S, T) the median
/// per-loop overhead of spec S at T threads and c(S, T) its chunks per loop:
///   per loop  = max(0, o(static@blocks, P) - o(static@blocks, 1))
///   per chunk = max(0, d(S, P) - d(S, 1)),  d(S, T) = (o(S, T) - o(static@blocks, T)) /
///                                                     (c(S, T) / T)
/// Results marked disturbed at either size are left out (and listed in the source text) except
/// static@blocks; a spec measured at one size only is left out. Throws std::invalid_argument
/// naming the file when it cannot be read or holds no static@blocks result at both 1 and P > 1
/// threads.
OverheadModel read_overhead_model(const std::filesystem::path& file);

/// The note a prediction carries when `model` was measured under another OMP_WAIT_POLICY than
/// the traced run's `trace_policy` (both recorded), else empty.
std::string wait_policy_mismatch(const OverheadModel& model, const std::string& trace_policy);

/// The model as stored in a trace's header ("overheads"): every figure and the source text.
nlohmann::json overhead_model_json(const OverheadModel& model);
/// Reads what overhead_model_json wrote; `origin` (e.g. "TRACE's header") prefixes the source
/// text. Throws std::invalid_argument naming `origin` when a figure is missing or not a number.
OverheadModel overhead_model_from_json(const nlohmann::json& stored, const std::string& origin);

}  // namespace clothbench::harness
