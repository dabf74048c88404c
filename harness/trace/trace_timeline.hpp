// The timeline picture of one step of a per-chunk trace (issue 17): threads as rows, chunks as
// bars coloured by loop site, idle time as the gaps between them - what one would otherwise
// open Paraver for. Bounded in size: one step, and at most a cap of bars (neighbouring chunks
// of a thread are merged below the picture's resolution first).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "harness/report/sweep_plots.hpp"
#include "harness/trace/trace_file.hpp"

namespace clothbench::harness {

/// The step a timeline shows by default: the one with the most chunks (the first of equals).
/// 0 when the trace has no loops.
int default_timeline_step(const TraceDocument& trace);

/// One bar of the timeline: a thread's chunk, or several neighbouring ones merged.
struct TimelineBar {
  int thread = 0;
  std::int64_t start_ns = 0;
  std::int64_t end_ns = 0;
  int site = 0;  ///< loop site of the (longest part of the) bar
};

/// The bars of `step`, at most `cap`: chunks of one thread and one site closer than a gap
/// threshold (1/2000 of the step's span: below the picture's resolution; then 4x larger until
/// under the cap) are merged; once the gap exceeds the step, neighbours of any site merge.
std::vector<TimelineBar> timeline_bars(const TraceDocument& trace, int step, std::size_t cap);

/// Writes `name`.{dat,gp,png} into `dir`: the timeline of `step` (at most 50000 bars), the
/// 11 loop sites with the most time in that step in their own colours and the rest grey.
PlotOutcome plot_timeline(const TraceDocument& trace, int step, const std::filesystem::path& dir,
                          const std::string& name);

}  // namespace clothbench::harness
