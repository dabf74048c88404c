// The timeline picture of one step of a per-chunk trace (see trace_timeline.hpp).
#include "harness/trace/trace_timeline.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <map>
#include <sstream>
#include <unordered_map>

#include "harness/output/atomic_file.hpp"

namespace clothbench::harness {

int default_timeline_step(const TraceDocument& trace) {
  std::unordered_map<std::uint32_t, int> step_of;
  for (const auto& loop : trace.loops) step_of[loop.instance] = loop.step;
  std::map<int, std::int64_t> chunks;
  for (const auto& loop : trace.loops) chunks[loop.step] += 0;
  for (const auto& c : trace.chunks) ++chunks[step_of[c.instance]];
  int best = 0;
  std::int64_t most = -1;
  for (const auto& [step, count] : chunks) {
    if (count > most) {
      best = step;
      most = count;
    }
  }
  return best;
}

namespace {

/// Merges neighbouring bars of each thread whose gap is below `gap_ns` (same site only when
/// `same_site`); bars are sorted by (thread, start). The merged bar keeps the longer site.
std::vector<TimelineBar> merge(const std::vector<TimelineBar>& bars, std::int64_t gap_ns,
                               bool same_site) {
  std::vector<TimelineBar> out;
  std::int64_t longest = 0;  // duration of the part whose site the last bar carries
  for (const TimelineBar& b : bars) {
    if (!out.empty()) {
      TimelineBar& last = out.back();
      if (last.thread == b.thread && b.start_ns - last.end_ns <= gap_ns &&
          (!same_site || last.site == b.site)) {
        if (b.end_ns - b.start_ns > longest) {
          longest = b.end_ns - b.start_ns;
          last.site = b.site;
        }
        last.end_ns = std::max(last.end_ns, b.end_ns);
        continue;
      }
    }
    out.push_back(b);
    longest = b.end_ns - b.start_ns;
  }
  return out;
}

}  // namespace

std::vector<TimelineBar> timeline_bars(const TraceDocument& trace, int step, std::size_t cap) {
  std::unordered_map<std::uint32_t, int> site_of;
  for (const auto& loop : trace.loops) {
    if (loop.step == step) site_of[loop.instance] = loop.site;
  }
  std::vector<TimelineBar> bars;
  std::int64_t first = 0, last = 0;
  for (const auto& c : trace.chunks) {
    const auto it = site_of.find(c.instance);
    if (it == site_of.end()) continue;
    if (bars.empty() || c.start_ns < first) first = c.start_ns;
    if (bars.empty() || c.end_ns > last) last = c.end_ns;
    bars.push_back(TimelineBar{c.thread, c.start_ns, c.end_ns, it->second});
  }
  std::sort(bars.begin(), bars.end(), [](const TimelineBar& a, const TimelineBar& b) {
    return a.thread != b.thread ? a.thread < b.thread : a.start_ns < b.start_ns;
  });
  // Chunks of one site closer than a pixel of a 2000-pixel picture are one bar; then coarser
  // until under the cap (and across sites once the gap exceeds the step).
  const std::int64_t span = std::max<std::int64_t>(1, last - first);
  std::int64_t gap = std::max<std::int64_t>(1, span / 2000);
  bars = merge(bars, gap, true);
  while (bars.size() > cap) {
    gap *= 4;
    bars = merge(bars, gap, /*same_site=*/gap <= span);
  }
  return bars;
}

PlotOutcome plot_timeline(const TraceDocument& trace, int step, const std::filesystem::path& dir,
                          const std::string& name) {
  PlotOutcome outcome;
  const std::vector<TimelineBar> bars = timeline_bars(trace, step, 50000);
  if (bars.empty()) {
    outcome.problems.push_back(fmt::format("trace timeline: step {} has no chunks", step));
    return outcome;
  }
  // The sites with the most time in this step get their own colour and key entry.
  const auto& sites = trace.header.at("sites");
  std::map<int, std::int64_t> busy;
  std::int64_t origin = bars.front().start_ns;
  int threads = 1;
  for (const TimelineBar& b : bars) {
    busy[b.site] += b.end_ns - b.start_ns;
    origin = std::min(origin, b.start_ns);
    threads = std::max(threads, b.thread + 1);
  }
  std::vector<std::pair<std::int64_t, int>> ranked;
  for (const auto& [site, ns] : busy) ranked.emplace_back(-ns, site);
  std::sort(ranked.begin(), ranked.end());
  constexpr std::size_t kColoured = 11;
  std::map<int, std::size_t> group;  // site -> data block; kColoured = the rest
  for (std::size_t k = 0; k < ranked.size(); ++k) {
    group[ranked[k].second] = std::min(k, kColoured);
  }
  const std::size_t blocks = std::min(ranked.size(), kColoured + 1);
  std::vector<std::string> data(blocks);
  for (const TimelineBar& b : bars) {
    data[group[b.site]] +=
        fmt::format("{:.6f} {:.6f} {}\n", 1e-6 * static_cast<double>(b.start_ns - origin),
                    1e-6 * static_cast<double>(b.end_ns - origin), b.thread);
  }
  std::string all;
  for (const std::string& block : data) all += (block.empty() ? "nan nan 0\n" : block) + "\n\n";
  write_file_atomically(dir / (name + ".dat"), all);

  static const char* const kColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728",
                                         "#9467bd", "#8c564b", "#e377c2", "#17becf",
                                         "#bcbd22", "#7f7f7f", "#393b79"};
  std::ostringstream gp;
  gp << png_terminal(1600, std::max(400, 120 + 60 * threads)) << "set output '" << name << ".png'\n"
     << fmt::format(
            "set title {}\n",
            gnuplot_quote(fmt::format(
                "{} ({}, {} threads): step {}, {} bars", trace.header.value("scene", std::string()),
                trace.header.value("scheduler", std::string()), threads, step, bars.size())))
     << "set xlabel "
     << gnuplot_quote(
            "time since the step's first chunk [ms]  (gaps: idle, barriers, "
            "sequential work)")
     << "\n"
     << fmt::format("set ylabel 'thread'\nset yrange [-0.6:{}.6]\nset ytics 1\n", threads - 1)
     << "set key outside right top Left reverse font ',9'\nset style fill solid 1.0 noborder\n"
     << "set grid xtics\nplot ";
  for (std::size_t k = 0; k < blocks; ++k) {
    const std::string title =
        k < kColoured ? sites.at(static_cast<std::size_t>(ranked[k].second)).value("name", "?")
                      : std::string("other loops");
    gp << (k > 0 ? ", \\\n     " : "")
       << fmt::format(
              "'{}.dat' index {} using (($1+$2)/2):3:(($2-$1)/2):(0.4) with boxxyerror "
              "lc rgb '{}' title {}",
              name, k, k < kColoured ? kColours[k] : "#c0c0c0", gnuplot_quote(title));
  }
  gp << "\n";
  run_gnuplot(dir, name, gp.str(), outcome);
  return outcome;
}

}  // namespace clothbench::harness
