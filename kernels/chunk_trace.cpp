// The in-memory per-chunk trace: loop spans over all threads, site table, and the measured
// cost of one record (see chunk_trace.hpp).
#include "kernels/chunk_trace.hpp"

#include <cstring>

namespace clothbench::kernels {

std::vector<LoopRecord> ChunkTrace::loops() const {
  std::vector<LoopRecord> merged = loops_;
  for (const PerThread& t : threads_) {
    const std::size_t n = std::min(merged.size(), t.entry_ns.size());
    for (std::size_t i = 0; i < n; ++i) {
      merged[i].entry_ns = std::min(merged[i].entry_ns, t.entry_ns[i]);
      merged[i].exit_ns = std::max(merged[i].exit_ns, t.exit_ns[i]);
    }
  }
  return merged;
}

std::int32_t ChunkTrace::site_index(const LoopSite& site, int kind) {
  for (std::size_t i = 0; i < sites_.size(); ++i) {
    const TraceSite& s = sites_[i];
    // String literals of one function may or may not be merged: compare the text.
    if (s.line == site.line && s.kind == kind &&
        (s.function == site.function || std::strcmp(s.function, site.function) == 0)) {
      return static_cast<std::int32_t>(i);
    }
  }
  sites_.push_back(TraceSite{site.function, site.line, kind});
  return static_cast<std::int32_t>(sites_.size() - 1);
}

double ChunkTrace::measure_record_seconds(int records) {
  ChunkTrace scratch;
  scratch.start(1, static_cast<std::size_t>(records));
  const Clock::time_point begin = Clock::now();
  for (int k = 0; k < records; ++k) {
    const std::int64_t start = scratch.ns(Clock::now());
    const std::int64_t end = scratch.ns(Clock::now());
    scratch.add_chunk(0, ChunkRecord{0, 0, k, k + 1, 1, 0, start, end});
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - begin).count();
  return records > 0 ? seconds / records : 0.0;
}

}  // namespace clothbench::kernels
