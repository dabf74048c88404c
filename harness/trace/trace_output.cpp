// Writing the trace of a run, its cost and its timeline (see trace_output.hpp).
#include "harness/trace/trace_output.hpp"

#include <fmt/core.h>

#include "harness/report/sweep_plots.hpp"
#include "harness/trace/trace_file.hpp"
#include "harness/trace/trace_timeline.hpp"

namespace clothbench::harness {

void write_trace_outputs(const kernels::ChunkTrace& trace, const std::filesystem::path& file,
                         const nlohmann::json& context, double run_seconds, std::optional<int> step,
                         bool quiet) {
  // The cost of one record, measured now on this machine (two clock reads and a store).
  const double record_seconds = kernels::ChunkTrace::measure_record_seconds(1 << 16);
  const TraceDocument document = collect_trace(trace, context, record_seconds, run_seconds);
  const std::uintmax_t bytes = write_trace(file, document);
  const auto& cost = document.header["cost"];
  if (!quiet) {
    fmt::print(
        "  wrote {} ({} loop instances, {} chunks, {:.1f} MB; tracing cost ~{:.2f} ms = "
        "{} chunks x {:.0f} ns, {:.2f} % of the run)\n",
        file.string(), document.loops.size(), document.chunks.size(),
        static_cast<double>(bytes) / 1e6, 1e3 * cost["estimated_seconds"].get<double>(),
        document.chunks.size(), 1e9 * record_seconds, cost["estimated_percent"].get<double>());
  }
  if (!gnuplot_available()) {
    if (!quiet) fmt::print("  (gnuplot is not installed: no timeline picture)\n");
    return;
  }
  const int shown = step.value_or(default_timeline_step(document));
  const std::filesystem::path dir =
      file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path();
  const PlotOutcome plot = plot_timeline(document, shown, dir, file.stem().string() + "-timeline");
  for (const auto& image : plot.images) {
    if (!quiet) fmt::print("  wrote {} (timeline of step {})\n", image.string(), shown);
  }
  for (const auto& problem : plot.problems) fmt::print(stderr, "clothbench: {}\n", problem);
}

}  // namespace clothbench::harness
