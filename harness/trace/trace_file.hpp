// The per-chunk trace file of `clothbench run --trace FILE` (issue 17): write and read.
//
// Layout (little-endian, as the x86-64 and AArch64 machines it runs on):
//   line 1  "clothbench-trace 2"
//   line 2  the JSON header, one line: format, machine context, scene, scheduler, threads,
//           the loop sites (id -> name), record counts and layouts, the cost of tracing, and
//           what `--trace-overheads` / `--trace-bandwidth` copied in (overheads, bandwidth)
//   then    header.loop_count   LoopRecord  (48 bytes each, kernels/chunk_trace.hpp)
//   then    header.chunk_count  ChunkRecord (40 bytes each), sorted by loop instance, begin
// numpy: np.fromfile(f, dtype, count, offset) with the dtypes the header's layouts give.
// Format 1 (before loops recorded their bytes per element) had 40-byte loop records without
// the last field; read_trace still reads it, with kBytesNotRecorded for every loop.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "kernels/chunk_trace.hpp"

namespace clothbench::harness {

/// A trace as written or read back: header, loop instances, chunks.
struct TraceDocument {
  nlohmann::json header;
  std::vector<kernels::LoopRecord> loops;    ///< by instance
  std::vector<kernels::ChunkRecord> chunks;  ///< by (instance, begin)
};

/// The name of a loop site: "function:line/kind", e.g. "evaluate:232/edges" (kind "index"
/// for for_index loops).
std::string loop_site_name(const kernels::TraceSite& site);

/// The file name `sweep --trace DIR` gives the trace of a row, and `predict --validate` looks
/// for: "<scheduler>-<threads>t.cbtrace" with ':' and '@' as '_' (e.g. "dynamic_1_blocks-2t").
std::string row_trace_file_name(const std::string& scheduler, int threads);

/// Collects a finished trace: its loops (spans over all threads), its chunks sorted, and the
/// header (format, sites, counts, record layouts, cost) merged with `context` (machine,
/// scene, scheduler, threads: what the caller knows). `record_seconds`: the measured cost of
/// one chunk record (ChunkTrace::measure_record_seconds); `run_seconds`: the traced steps'
/// time, to put the estimated cost in proportion.
TraceDocument collect_trace(const kernels::ChunkTrace& trace, const nlohmann::json& context,
                            double record_seconds, double run_seconds);

/// Writes `document` to `file` (layout above; via FILE.tmp, renamed); returns the bytes
/// written. Throws std::runtime_error or std::filesystem::filesystem_error naming the file.
std::uintmax_t write_trace(const std::filesystem::path& file, const TraceDocument& document);

/// Reads a trace file of format 2 or 1; throws std::runtime_error naming the file on a bad or
/// short file.
TraceDocument read_trace(const std::filesystem::path& file);

}  // namespace clothbench::harness
