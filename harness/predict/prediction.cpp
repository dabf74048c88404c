// Predicted Table 2 and Fig. 12 from a trace (see prediction.hpp).
#include "harness/predict/prediction.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <map>
#include <sstream>
#include <stdexcept>

#include "harness/output/atomic_file.hpp"

namespace clothbench::harness {

OmpRuntimeModel runtime_model(const std::string& runtime_name) {
  return runtime_name == "libomp" || runtime_name == "libiomp5" ? OmpRuntimeModel::libomp
                                                                : OmpRuntimeModel::libgomp;
}

PredictedRow predict_row(const TraceWorkload& workload, const ScheduleModel& model, int threads,
                         const OverheadModel& overheads, const BandwidthModel& bandwidth) {
  const bool active = model.spec.space == schedulers::IterationSpace::active;
  if (!active && workload.space == schedulers::IterationSpace::active) {
    throw std::invalid_argument(fmt::format(
        "{} runs over blocks, but the trace ({}) is over the Active-Lists, which hold no "
        "per-block costs: trace a run over blocks (e.g. dynamic:1)",
        model.name(), workload.scheduler));
  }
  PredictedRow row;
  row.scheduler = model.name();
  row.threads = threads;
  row.beyond_cores = workload.machine_cores > 0 && threads > workload.machine_cores;
  // The trace's times already hold what its loops cost at 1 thread; the model's figures are
  // what P threads cost beyond that (overhead_model.hpp), so none is added at 1 thread.
  const bool beyond_one = threads > 1;
  row.dispatch_seconds = beyond_one ? overheads.dispatch(row.scheduler) : 0.0;
  const double per_loop = beyond_one ? overheads.loop_seconds : 0.0;
  row.bandwidth = bandwidth.at(threads);
  double loop_wall = 0.0, busiest_sum = 0.0, mean_sum = 0.0;
  for (const TracedLoop& loop : workload.loops) {
    const LoopSimulation s = simulate_loop(model, active ? loop.active : loop.costs, threads,
                                           row.dispatch_seconds, false, per_loop);
    double sum = 0.0;
    for (double w : s.thread_work) sum += w;
    // The ceiling: no faster than its bytes at B(P); a bound loop is stretched as a whole. A
    // loop that moved its bytes faster than the triad in the trace itself (its data stayed in
    // cache) is held to its own 1-thread rate scaled as the triad scales, W B(1) / B(P) with W
    // its work: so the ceiling never lengthens a 1-thread row beyond the trace.
    double least = 0.0;
    if (loop.bytes > 0.0 && row.bandwidth > 0.0) {
      least = loop.bytes / row.bandwidth;
      const double one = bandwidth.at(1);
      if (one > 0.0) least = std::min(least, sum * (one / row.bandwidth));
    }
    double makespan = s.makespan, stretch = 1.0;
    if (least > makespan) {
      ++row.bandwidth_bound_loops;
      row.bandwidth_added_seconds += least - makespan;
      if (makespan > 0.0) stretch = least / makespan;
      makespan = least;
    }
    busiest_sum += stretch * *std::max_element(s.thread_work.begin(), s.thread_work.end());
    mean_sum += stretch * sum / threads;
    loop_wall += makespan;
    row.chunks += s.chunks;
  }
  row.sequential_overhead = workload.sequential_seconds;
  row.parallel_overhead = loop_wall - busiest_sum;
  row.load_imbalance = busiest_sum - mean_sum;
  row.parallel_work = mean_sum;
  row.imbalance_percent = mean_sum > 0.0 ? 100.0 * (busiest_sum / mean_sum - 1.0) : 0.0;
  row.time = workload.sequential_seconds + loop_wall;
  return row;
}

namespace {

/// What the ceiling rests on and where it does not apply, as notes of `p`.
void add_bandwidth_notes(Prediction& p, const std::vector<int>& threads) {
  const BandwidthModel& b = p.bandwidth;
  if (!b.measured()) return;
  const TraceWorkload& w = *p.workload;
  if (w.loops_without_bytes > 0) {
    p.notes.push_back(fmt::format(
        "{} of {} loop instances carry no bytes per element (a trace of format 1, written "
        "before loops declared them): no bandwidth ceiling for them",
        w.loops_without_bytes, w.loops.size()));
  }
  std::int64_t cached = 0;
  for (const TracedLoop& loop : w.loops) {
    const double work = loop.costs.range(0, loop.costs.size());
    if (loop.bytes > 0.0 && work * b.at(1) < loop.bytes) ++cached;
  }
  if (cached > 0) {
    p.notes.push_back(fmt::format(
        "{} of {} loop instances moved their bytes faster than the 1-thread triad in the trace "
        "itself (their data stayed in cache between loops, the triad's arrays do not): their "
        "ceiling is their own 1-thread rate, scaled with P as the triad scales",
        cached, w.loops.size()));
  }
  const int largest = b.largest_threads();
  if (std::any_of(threads.begin(), threads.end(), [&](int t) { return t > largest; })) {
    p.notes.push_back(fmt::format(
        "bandwidth beyond {0} core{1} assumed flat at the {0}-core triad ({2:.2f} GB/s)", largest,
        largest == 1 ? "" : "s", 1e-9 * b.at(largest)));
  }
}

}  // namespace

Prediction predict(const TraceWorkload& workload, const std::string& trace_file,
                   const std::vector<std::string>& schedulers, const std::vector<int>& threads,
                   const OverheadModel& overheads, const BandwidthModel& bandwidth) {
  Prediction p;
  p.trace_file = trace_file;
  p.workload = &workload;
  p.overheads = overheads;
  p.bandwidth = bandwidth;
  const double whole = workload.sequential_seconds + workload.busy_seconds;
  p.sequential_share = whole > 0.0 ? workload.sequential_seconds / whole : 0.0;
  if (p.sequential_share > 0.0) p.amdahl_limit = 1.0 / p.sequential_share;
  const OmpRuntimeModel runtime = runtime_model(workload.openmp_runtime);
  if (runtime == OmpRuntimeModel::libomp) {
    p.notes.push_back(
        "the trace ran on libomp: guided:k is modelled as libgomp's max(k, ceil(R/P)), which "
        "libomp's iterative guided only approximates");
  }
  if (workload.run_seconds <= 0.0) {
    p.notes.push_back("the trace records no run time: sequential time taken as 0");
  }
  add_bandwidth_notes(p, threads);
  for (const std::string& text : schedulers) {
    const ScheduleModel model = ScheduleModel::parse(text, runtime);
    if (model.spec.space == schedulers::IterationSpace::active &&
        workload.space == schedulers::IterationSpace::blocks &&
        workload.dropped_for_active_seconds > 0.0) {
      p.notes.push_back(fmt::format(
          "{}: the trace is over blocks; its {:.3g} s in blocks without a live element are "
          "left out over the Active-Lists, which never visit them",
          model.name(), workload.dropped_for_active_seconds));
    }
    const PredictedRow one = predict_row(workload, model, 1, overheads, bandwidth);
    for (int t : threads) {
      PredictedRow row = t == 1 ? one : predict_row(workload, model, t, overheads, bandwidth);
      row.speedup = row.time > 0.0 ? one.time / row.time : 0.0;
      row.efficiency = row.speedup / t;
      p.rows.push_back(row);
    }
  }
  return p;
}

namespace {

std::string basis(const PredictedRow& row) {
  return row.beyond_cores ? "predicted (beyond the traced machine's cores)" : "predicted";
}

}  // namespace

std::string format_prediction_markdown(const Prediction& p) {
  const TraceWorkload& w = *p.workload;
  std::ostringstream out;
  out << "# Predicted Table 2 (schedule replay of a trace)\n\n";
  out << fmt::format(
      "Trace: {} ({}, {} at {} thread{}, OpenMP runtime {}, {} loop instances; traced machine: "
      "{} cores). Busy time {:.4f} s, time outside loops {:.4f} s, run {:.4f} s.\n",
      p.trace_file, w.scene.empty() ? "scene not recorded" : w.scene, w.scheduler, w.threads,
      w.threads == 1 ? "" : "s", w.openmp_runtime, w.loops.size(),
      w.machine_cores > 0 ? std::to_string(w.machine_cores) : "?", w.busy_seconds,
      w.sequential_seconds, w.run_seconds);
  if (!w.loop_times_from.empty()) {
    out << fmt::format(
        "Loop times, loop spans and time outside loops from {} (the same run with fewer chunks, "
        "so less tracing cost); the trace above gives only how each loop's time splits over its "
        "iterations.\n",
        w.loop_times_from);
  }
  out << fmt::format("Overheads: {}.\n", p.overheads.source);
  out << fmt::format("Bandwidth ceiling: {}.\n", p.bandwidth.source);
  if (p.bandwidth.measured()) {
    out << "A loop instance takes at least its bytes (its loop's bytes per element x its "
           "elements, kernels/loop_bytes.hpp) / B(P), B(P) the triad at P threads.\n";
  }
  if (p.amdahl_limit) {
    out << fmt::format(
        "Amdahl limit: sequential share s = {:.3g} (time outside loops / (that + busy time)), "
        "speed-up at most 1/s = {:.0f}.\n",
        p.sequential_share, *p.amdahl_limit);
  } else {
    out << "Amdahl limit: none (the trace has no time outside its loops).\n";
  }
  for (const std::string& note : p.notes) out << "Note: " << note << ".\n";
  std::string current;
  for (const PredictedRow& row : p.rows) {
    if (row.scheduler != current) {
      current = row.scheduler;
      out << fmt::format("\n## {} (dispatch per chunk above 1 thread {:.1f} ns, {})\n\n", current,
                         1e9 * p.overheads.dispatch(current), p.overheads.dispatch_source(current));
      out << "| Threads | Basis | Seq. overhead [s] | Para. overhead [s] | Imbalance [s] | "
             "Imbalance [%] | Time [s] | Speed-up | Efficiency | Chunks | B(P) [GB/s] | "
             "Bandwidth-bound loops | Bandwidth added [s] |\n";
      out << "|--:|:--|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n";
    }
    out << fmt::format(
        "| {} | {} | {:.4f} | {:.4f} | {:.4f} | {:.1f} | {:.4f} | {:.2f} | {:.2f} "
        "| {} | {} | {} | {:.4f} |\n",
        row.threads, basis(row), row.sequential_overhead, row.parallel_overhead, row.load_imbalance,
        row.imbalance_percent, row.time, row.speedup, row.efficiency, row.chunks,
        row.bandwidth > 0.0 ? fmt::format("{:.2f}", 1e-9 * row.bandwidth) : std::string("-"),
        row.bandwidth_bound_loops, row.bandwidth_added_seconds);
  }
  out << "\nEvery row is a prediction (a replay of the trace's per-iteration work through the "
         "scheduler's assignment on a virtual clock), never a measurement. Columns as in the "
         "sweep's Table 2: Seq. overhead = time outside loops; Para. overhead = loop wall - "
         "busiest thread's work; Imbalance = busiest - mean thread work, [%] = busiest/mean - 1; "
         "Speed-up against the same scheduler's predicted 1-thread time. B(P): the triad's "
         "bandwidth the ceiling used; Bandwidth-bound loops: instances it lengthened (each "
         "stretched as a whole), by Bandwidth added in all.\n";
  return out.str();
}

nlohmann::json prediction_json(const Prediction& p) {
  const TraceWorkload& w = *p.workload;
  nlohmann::json rows = nlohmann::json::array();
  for (const PredictedRow& r : p.rows) {
    rows.push_back({{"scheduler", r.scheduler},
                    {"threads", r.threads},
                    {"basis", basis(r)},
                    {"beyond_traced_cores", r.beyond_cores},
                    {"time_seconds", r.time},
                    {"sequential_overhead_seconds", r.sequential_overhead},
                    {"parallel_overhead_seconds", r.parallel_overhead},
                    {"load_imbalance_seconds", r.load_imbalance},
                    {"parallel_work_seconds", r.parallel_work},
                    {"imbalance_percent", r.imbalance_percent},
                    {"speedup", r.speedup},
                    {"efficiency", r.efficiency},
                    {"chunks", r.chunks},
                    {"dispatch_seconds_per_chunk", r.dispatch_seconds},
                    {"bandwidth_bytes_per_second", r.bandwidth},
                    {"bandwidth_basis", p.bandwidth.basis(r.threads)},
                    {"bandwidth_bound_loops", r.bandwidth_bound_loops},
                    {"bandwidth_added_seconds", r.bandwidth_added_seconds}});
  }
  return {{"schema", "clothbench-prediction"},
          {"schema_version", 2},
          {"trace",
           {{"file", p.trace_file},
            {"scene", w.scene},
            {"scheduler", w.scheduler},
            {"threads", w.threads},
            {"openmp_runtime", w.openmp_runtime},
            {"machine_cores", w.machine_cores},
            {"loop_instances", w.loops.size()},
            {"loop_instances_without_bytes", w.loops_without_bytes},
            {"busy_seconds", w.busy_seconds},
            {"sequential_seconds", w.sequential_seconds},
            {"run_seconds", w.run_seconds},
            {"loop_times_from", w.loop_times_from}}},
          {"overheads",
           {{"source", p.overheads.source},
            {"measured", p.overheads.measured},
            {"measured_threads", p.overheads.measured_threads},
            {"loop_seconds", p.overheads.loop_seconds},
            {"rule", "added above 1 thread only: overhead at the measured threads - at 1 thread"}}},
          {"bandwidth",
           {{"source", p.bandwidth.source},
            {"triad", bandwidth_model_json(p.bandwidth)["triad"]},
            {"rule",
             "a loop instance takes at least bytes / B(P); B(P) measured, else linear between "
             "measured thread counts, else flat beyond the largest"}}},
          {"sequential_share", p.sequential_share},
          {"amdahl_limit", p.amdahl_limit ? nlohmann::json(*p.amdahl_limit) : nlohmann::json()},
          {"notes", p.notes},
          {"rows", rows}};
}

PlotOutcome write_prediction_outputs(const Prediction& p, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  write_file_atomically(dir / "prediction.json", prediction_json(p).dump(2) + "\n");
  write_file_atomically(dir / "table.md", format_prediction_markdown(p));
  // fig12.dat: one gnuplot index per scheduler: threads, time, speed-up, efficiency.
  std::ostringstream data;
  data << "# threads time_s speedup efficiency (predicted)\n";
  std::vector<std::string> names;
  int max_threads = 1;
  for (const PredictedRow& r : p.rows) {
    if (names.empty() || names.back() != r.scheduler) {
      if (!names.empty()) data << "\n\n";
      names.push_back(r.scheduler);
      data << "# " << r.scheduler << "\n";
    }
    max_threads = std::max(max_threads, r.threads);
    data << fmt::format("{} {:.9g} {:.9g} {:.9g}\n", r.threads, r.time, r.speedup, r.efficiency);
  }
  write_file_atomically(dir / "fig12.dat", data.str());
  PlotOutcome outcome;
  if (!gnuplot_available()) {
    outcome.problems.push_back("gnuplot is not installed: no fig12.png");
    return outcome;
  }
  std::ostringstream gp;
  gp << png_terminal(1400, 580) << "set output 'fig12.png'\n";
  gp << fmt::format("set multiplot layout 1,2 title {}\n",
                    gnuplot_quote(fmt::format("Predicted from {} ({} at {} thread{})", p.trace_file,
                                              p.workload->scheduler, p.workload->threads,
                                              p.workload->threads == 1 ? "" : "s")));
  gp << fmt::format("set grid\nset xlabel 'threads'\nset logscale x 2\nset xrange [0.8:{}]\n",
                    max_threads * 1.25);
  if (p.workload->machine_cores > 0 && max_threads > p.workload->machine_cores) {
    gp << fmt::format(
        "set arrow 1 from {0}, graph 0 to {0}, graph 1 nohead dt 3 lc 'gray40'\n"
        "set label 1 'traced machine cores' at {0}, graph 0.04 left offset 0.5,0\n",
        p.workload->machine_cores);
  }
  gp << "set key top right\nset title 'Predicted time vs threads'\nset ylabel 'time [s]'\n"
        "set yrange [0:*]\nplot ";
  for (std::size_t i = 0; i < names.size(); ++i) {
    gp << fmt::format("{}'fig12.dat' index {} using 1:2 with linespoints lt {} lw 2 title {}",
                      i ? ", \\\n     " : "", i, i + 1, gnuplot_quote(names[i]));
  }
  gp << "\nset title 'Predicted speed-up (against each scheduler''s predicted 1-thread time)'\n"
        "set ylabel 'speed-up'\nset key top left\nset logscale y 2\nset yrange [0.8:*]\n";
  gp << "plot x with lines dt 2 lc 'black' title 'ideal'";
  if (p.amdahl_limit) {
    gp << fmt::format(", {:.9g} with lines dt 3 lc 'red' title {}", *p.amdahl_limit,
                      gnuplot_quote(fmt::format("Amdahl limit 1/s = {:.0f}", *p.amdahl_limit)));
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    gp << fmt::format(
        ", \\\n     'fig12.dat' index {} using 1:3 with linespoints lt {} lw 2 "
        "title {}",
        i, i + 1, gnuplot_quote(names[i]));
  }
  gp << "\nunset multiplot\n";
  run_gnuplot(dir, "fig12", gp.str(), outcome);
  return outcome;
}

}  // namespace clothbench::harness
