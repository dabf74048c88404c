// Rebuilding per-iteration costs and sequential time from a trace (see trace_workload.hpp).
#include "harness/predict/trace_workload.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <stdexcept>

namespace clothbench::harness {

void IterationCosts::add(std::int64_t iterations, double seconds) {
  if (iterations <= 0) return;
  if (start_.empty()) {
    start_.push_back(0);
    cumulative_.push_back(0.0);
  }
  start_.push_back(start_.back() + iterations);
  cumulative_.push_back(cumulative_.back() + seconds);
}

double IterationCosts::prefix(std::int64_t i) const {
  if (i <= 0 || start_.empty()) return 0.0;
  // The segment holding i: the last start <= i.
  const auto s = static_cast<std::size_t>(std::upper_bound(start_.begin(), start_.end(), i) -
                                          start_.begin() - 1);
  if (s + 1 >= start_.size()) return cumulative_.back();
  if (start_[s] == i) return cumulative_[s];
  const double segment = cumulative_[s + 1] - cumulative_[s];
  const auto length = static_cast<double>(start_[s + 1] - start_[s]);
  return cumulative_[s] + segment * static_cast<double>(i - start_[s]) / length;
}

void IterationCosts::scale(double factor) {
  for (double& c : cumulative_) c *= factor;
}

double IterationCosts::range(std::int64_t begin, std::int64_t end) const {
  return end > begin ? prefix(end) - prefix(begin) : 0.0;
}

TraceWorkload build_workload(const TraceDocument& trace, const std::string& name) {
  const nlohmann::json& h = trace.header;
  TraceWorkload w;
  w.scheduler = h.value("scheduler", std::string("unknown"));
  w.threads = h.value("threads", 1);
  w.scene = h.value("scene", std::string());
  w.space = w.scheduler.ends_with("@active") ? schedulers::IterationSpace::active
                                             : schedulers::IterationSpace::blocks;
  w.openmp_runtime = "unknown";
  w.wait_policy = h.value("omp_wait_policy", std::string("not recorded"));
  if (h.contains("machine") && h["machine"].is_object()) {
    const nlohmann::json& m = h["machine"];
    if (m.contains("openmp") && m["openmp"].contains("runtime")) {
      w.openmp_runtime = m["openmp"]["runtime"].value("name", std::string("unknown"));
    }
    if (m.contains("cpu")) w.machine_cores = m["cpu"].value("cores", 0);
  }
  if (h.contains("overheads") && h["overheads"].is_object()) {
    w.stored_overheads = overhead_model_from_json(h["overheads"], name + "'s header");
  }
  if (h.contains("bandwidth") && !h["bandwidth"].is_null()) {
    w.stored_bandwidth = bandwidth_model_from_json(h["bandwidth"], name + "'s header");
  }
  if (h.contains("cost") && h["cost"].is_object()) {
    w.run_seconds = h["cost"].value("run_seconds", 0.0);
  }
  std::vector<int> site_kind;
  if (h.contains("sites")) {
    for (const auto& s : h["sites"]) {
      const std::string kind = s.value("kind", std::string("index"));
      int code = -1;
      if (kind == "particles") code = 0;
      if (kind == "edges") code = 1;
      if (kind == "triples") code = 2;
      if (kind == "ghosts") code = 3;
      site_kind.push_back(code);
    }
  }

  w.loops.resize(trace.loops.size());
  std::int64_t busy_ns = 0;
  std::size_t c = 0;
  for (std::size_t i = 0; i < trace.loops.size(); ++i) {
    const kernels::LoopRecord& loop = trace.loops[i];
    if (loop.instance != i) {
      throw std::invalid_argument(
          fmt::format("{}: loop record {} holds instance {}", name, i, loop.instance));
    }
    TracedLoop& out = w.loops[i];
    out.site = loop.site;
    out.kind = loop.site >= 0 && static_cast<std::size_t>(loop.site) < site_kind.size()
                   ? site_kind[static_cast<std::size_t>(loop.site)]
                   : -1;
    out.step = loop.step;
    out.span_seconds = 1e-9 * static_cast<double>(loop.exit_ns - loop.entry_ns);
    w.loop_span_seconds += out.span_seconds;
    std::int64_t covered = 0, elements = 0;
    for (; c < trace.chunks.size() && trace.chunks[c].instance == i; ++c) {
      const kernels::ChunkRecord& chunk = trace.chunks[c];
      if (chunk.begin != covered || chunk.end < chunk.begin || chunk.end > loop.n) {
        throw std::invalid_argument(fmt::format(
            "{}: loop instance {}: chunk [{}, {}) does not continue the ranges at {} of [0, {})",
            name, i, chunk.begin, chunk.end, covered, loop.n));
      }
      const std::int64_t ns = chunk.end_ns - chunk.start_ns;
      busy_ns += ns;
      const double seconds = 1e-9 * static_cast<double>(ns);
      out.costs.add(chunk.end - chunk.begin, seconds);
      if (w.space == schedulers::IterationSpace::blocks && out.kind >= 0) {
        out.active.add(chunk.elements, seconds);
        if (chunk.elements == 0) out.dropped_for_active_seconds += seconds;
      }
      covered = chunk.end;
      elements += chunk.elements;
    }
    if (loop.bytes_per_element >= 0.0) {
      out.bytes = loop.bytes_per_element * static_cast<double>(elements);
    } else {
      ++w.loops_without_bytes;
    }
    if (covered != loop.n) {
      throw std::invalid_argument(fmt::format(
          "{}: loop instance {}: its chunks cover [0, {}) of [0, {})", name, i, covered, loop.n));
    }
    if (w.space == schedulers::IterationSpace::active || out.kind < 0) out.active = out.costs;
    w.dropped_for_active_seconds += out.dropped_for_active_seconds;
  }
  if (c != trace.chunks.size()) {
    throw std::invalid_argument(
        fmt::format("{}: chunk {} names loop instance {}, which the trace does not hold", name, c,
                    trace.chunks[c].instance));
  }
  w.busy_seconds = 1e-9 * static_cast<double>(busy_ns);
  w.sequential_seconds = std::max(0.0, w.run_seconds - w.loop_span_seconds);
  return w;
}

void take_loop_times(TraceWorkload& fine, const TraceWorkload& totals, const std::string& fine_name,
                     const std::string& totals_name) {
  const auto refuse = [&](const std::string& why) {
    throw std::invalid_argument(
        fmt::format("{} and {} are not traces of the same run over the same iteration space: {}",
                    fine_name, totals_name, why));
  };
  if (fine.space != totals.space) refuse("one is over blocks, the other over the Active-Lists");
  if (fine.loops.size() != totals.loops.size()) {
    refuse(fmt::format("{} and {} loop instances", fine.loops.size(), totals.loops.size()));
  }
  double busy = 0.0, dropped = 0.0, spans = 0.0;
  for (std::size_t i = 0; i < fine.loops.size(); ++i) {
    TracedLoop& f = fine.loops[i];
    const TracedLoop& t = totals.loops[i];
    if (f.step != t.step || f.site != t.site || f.costs.size() != t.costs.size()) {
      refuse(fmt::format(
          "loop instance {}: step {} site {} over {} iterations against step {} site {} over {}", i,
          f.step, f.site, f.costs.size(), t.step, t.site, t.costs.size()));
    }
    const double want = t.costs.total();
    const double have = f.costs.total();
    if (have > 0.0) {
      const double factor = want / have;
      f.costs.scale(factor);
      f.active.scale(factor);
      f.dropped_for_active_seconds *= factor;
    } else {  // the fine trace saw no time in this instance: spread the total evenly
      f.costs = IterationCosts{};
      f.costs.add(t.costs.size(), want);
      const std::int64_t entries = f.active.size();
      f.active = IterationCosts{};
      f.active.add(entries, want);
    }
    f.span_seconds = t.span_seconds;
    busy += f.costs.total();
    dropped += f.dropped_for_active_seconds;
    spans += f.span_seconds;
  }
  fine.busy_seconds = busy;
  fine.dropped_for_active_seconds = dropped;
  fine.loop_span_seconds = spans;
  fine.run_seconds = totals.run_seconds;
  fine.sequential_seconds = totals.sequential_seconds;
  fine.loop_times_from = totals_name;
}

OverheadModel choose_overheads(const std::optional<OverheadModel>& given,
                               const TraceWorkload& workload) {
  OverheadModel model = given.value_or(workload.stored_overheads.value_or(OverheadModel{}));
  if (const std::string warning = wait_policy_mismatch(model, workload.wait_policy);
      !warning.empty()) {
    model.source += "; WARNING: " + warning;
  }
  return model;
}

BandwidthModel choose_bandwidth(const std::optional<BandwidthModel>& given,
                                const TraceWorkload& workload) {
  return given.value_or(workload.stored_bandwidth.value_or(BandwidthModel{}));
}

}  // namespace clothbench::harness
