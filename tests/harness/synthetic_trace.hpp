// Synthetic 1-thread traces for the predictor's tests (unit_predict*.cpp): costs, element
// counts and bytes chosen by the test, so that every predicted figure can be worked out by hand.
#pragma once

#include <cstdint>
#include <vector>

#include "harness/trace/trace_file.hpp"
#include "kernels/chunk_trace.hpp"

namespace clothbench_test {

/// A 1-thread dynamic:1 trace over blocks of one edge loop per entry of `loops`: each loop's
/// iterations as one chunk each, with the given costs (ms) and element counts (1 each unless
/// given), `sequential_ms` outside the loops, and `bytes_per_element` recorded with every loop
/// (kBytesNotRecorded: as a trace of format 1). The header says 2 cores and libgomp.
inline clothbench::harness::TraceDocument synthetic_trace(
    const std::vector<std::vector<double>>& loops, double sequential_ms,
    const std::vector<std::vector<int>>& elements = {},
    double bytes_per_element = clothbench::kernels::kBytesNotRecorded) {
  clothbench::harness::TraceDocument t;
  std::int64_t clock = 0;
  double span_ms = 0.0;
  for (std::size_t i = 0; i < loops.size(); ++i) {
    const auto n = static_cast<std::int64_t>(loops[i].size());
    const std::int64_t entry = clock;
    for (std::int64_t b = 0; b < n; ++b) {
      const auto ns = static_cast<std::int64_t>(loops[i][static_cast<std::size_t>(b)] * 1e6);
      const int e = elements.empty() ? 1 : elements[i][static_cast<std::size_t>(b)];
      t.chunks.push_back({static_cast<std::uint32_t>(i), 0, static_cast<std::int32_t>(b),
                          static_cast<std::int32_t>(b + 1), e, 0, clock, clock + ns});
      clock += ns;
    }
    t.loops.push_back({static_cast<std::uint32_t>(i), 1, 0, 0, n, entry, clock, bytes_per_element});
    span_ms += 1e-6 * static_cast<double>(clock - entry);
  }
  t.header = {
      {"scheduler", "dynamic:1@blocks"},
      {"threads", 1},
      {"sites", {{{"id", 0}, {"name", "evaluate:1/edges"}, {"kind", "edges"}}}},
      {"cost", {{"run_seconds", (span_ms + sequential_ms) * 1e-3}}},
      {"machine", {{"cpu", {{"cores", 2}}}, {"openmp", {{"runtime", {{"name", "libgomp"}}}}}}}};
  return t;
}

}  // namespace clothbench_test
