// The memory bandwidth the predictor's ceiling divides by (issue 17: "a memory-bandwidth
// ceiling from the triad for the loops whose bytes would saturate it"): STREAM's triad
// measured by clothbench-micro at every thread count from 1 to the machine's physical cores
// (harness/micro/gradient_evaluation.cpp, `--benchmark_filter=^triad --benchmark_format=json
// --benchmark_out=FILE`), read from that file, or from a trace's header (copied there by
// `run|sweep --trace-bandwidth FILE`).
//
// B(P): the triad at P threads where measured; between two measured counts, linear in P;
// beyond the largest measured count N, the N-thread triad (bandwidth beyond N cores is
// assumed flat: the predictor says so). A loop instance moving `bytes` (its LoopBytes per
// element times its elements, kernels/loop_bytes.hpp) cannot finish in less than
// bytes / B(P).
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

namespace clothbench::harness {

/// The triad's bandwidth by thread count.
struct BandwidthModel {
  /// Where the figures come from, for the output: the file, or why there are none.
  std::string source =
      "none: no bandwidth ceiling (no --bandwidth FILE; the trace stores no triad)";
  /// Bytes per second by threads; holds 1 whenever it is not empty.
  std::map<int, double> triad;

  [[nodiscard]] bool measured() const { return !triad.empty(); }
  /// The largest measured thread count (0 when none).
  [[nodiscard]] int largest_threads() const { return triad.empty() ? 0 : triad.rbegin()->first; }
  /// B(threads) in bytes per second (rule above); 0 when nothing is measured.
  [[nodiscard]] double at(int threads) const;
  /// How at(threads) was found: "measured", "interpolated between 2 and 4 threads", "flat
  /// beyond 2 cores: the 2-core triad", or "none".
  [[nodiscard]] std::string basis(int threads) const;
};

/// Reads the Google Benchmark JSON of clothbench-micro's triad: every `triad/...` result with
/// its `threads` and `bytes_per_second` counters (the median where repetitions give several).
/// Throws std::invalid_argument naming the file when it cannot be read, holds no triad, no
/// triad at 1 thread, or a bytes_per_second that is missing or not a positive number.
BandwidthModel read_bandwidth_model(const std::filesystem::path& file);

/// The model as a trace header stores it ("bandwidth"): the source and the figures.
nlohmann::json bandwidth_model_json(const BandwidthModel& model);
/// Reads what bandwidth_model_json wrote; `origin` (e.g. "TRACE's header") prefixes the source
/// text. Throws std::invalid_argument naming `origin` when a figure is missing, not a positive
/// number, or there is none at 1 thread.
BandwidthModel bandwidth_model_from_json(const nlohmann::json& stored, const std::string& origin);

}  // namespace clothbench::harness
