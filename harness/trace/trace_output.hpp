// What `clothbench run --trace FILE` does after the run: measure the cost of a record, write
// the trace file, draw the timeline of one step, and say so (issue 17, per-chunk traces).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "kernels/chunk_trace.hpp"

namespace clothbench::harness {

/// Records reserved per thread before a traced run (40 bytes each; more are added at loop
/// entry when needed, never inside a loop).
constexpr std::size_t kTraceRecordsPerThread = std::size_t{1} << 15;

/// Writes `trace` to `file` with `context` (machine, scene, scheduler, threads) in its header,
/// prints the figures (chunks, bytes, the estimated cost against `run_seconds`), and draws
/// the timeline of `step` (default: the step with the most chunks) as FILE's stem +
/// "-timeline.png" beside it when gnuplot is installed; `quiet`: prints only problems.
/// Throws what writing throws.
void write_trace_outputs(const kernels::ChunkTrace& trace, const std::filesystem::path& file,
                         const nlohmann::json& context, double run_seconds, std::optional<int> step,
                         bool quiet = false);

}  // namespace clothbench::harness
