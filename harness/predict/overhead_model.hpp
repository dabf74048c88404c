// The scheduling costs the predictor adds to the replayed work (issue 17): per loop (fork/join
// and the closing barrier) and per chunk (dispatch), read from the JSON that
// `clothbench-micro --benchmark_filter=scheduling_overhead --benchmark_out=FILE
// --benchmark_format=json` writes (harness/micro/scheduling_overhead.cpp), or zero.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace clothbench::harness {

/// Costs per loop and per chunk, as measured at one team size.
struct OverheadModel {
  /// Where the figures come from, for the output: the file, or why they are zero.
  std::string source = "none: overheads assumed zero (no --overheads FILE; the trace stores none)";
  bool measured = false;
  int measured_threads = 0;   ///< team size of the micro-benchmark run
  double loop_seconds = 0.0;  ///< per loop: static@blocks' overhead (fork/join, barrier)
  std::map<std::string, double> dispatch_seconds;  ///< per chunk, by canonical spec
  /// Results the micro-benchmark marked disturbed (other work took the cores): not used for
  /// dispatch costs (static@blocks is used anyway, and listed, when it is one of them).
  std::vector<std::string> disturbed;

  /// Dispatch cost of one chunk of `canonical`: its own figure, else that of the same kind
  /// with another chunk size (e.g. dynamic:3 from dynamic:1), else 0.
  [[nodiscard]] double dispatch(const std::string& canonical) const;
  /// How dispatch(canonical) was found, for the output ("measured", "from dynamic:1@blocks",
  /// "none: 0").
  [[nodiscard]] std::string dispatch_source(const std::string& canonical) const;
};

/// Reads the Google Benchmark JSON of the scheduling_overhead benchmarks. Per loop: the
/// median per-loop overhead of static@blocks (one chunk per thread). Per chunk of a spec S:
/// (its per-loop overhead - static's) / (its chunks per loop / P), at least 0; results marked
/// disturbed are left out (and listed in the source text) except static@blocks. Throws
/// std::invalid_argument naming the file when it cannot be read or holds no static@blocks
/// result.
OverheadModel read_overhead_model(const std::filesystem::path& file);

}  // namespace clothbench::harness
