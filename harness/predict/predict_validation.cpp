// Predicted against measured sweep rows (see predict_validation.hpp).
#include "harness/predict/predict_validation.hpp"

#include <fmt/format.h>

#include <cmath>
#include <exception>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "harness/predict/prediction.hpp"
#include "harness/predict/trace_workload.hpp"
#include "harness/report/sweep_table.hpp"
#include "harness/run/core_round_trip.hpp"
#include "harness/trace/trace_file.hpp"

namespace clothbench::harness {

namespace {

struct Source {
  std::filesystem::path file;
  TraceWorkload workload;
  std::size_t chunks = 0;
  double busy_seconds = 0.0;  ///< as recorded (before take_loop_times)
};

Source load_source(const std::filesystem::path& file) {
  Source s;
  s.file = file;
  const TraceDocument document = read_trace(file);
  s.chunks = document.chunks.size();
  s.workload = build_workload(document, file.string());
  s.busy_seconds = s.workload.busy_seconds;
  return s;
}

}  // namespace

Validation validate_prediction(const nlohmann::json& sweep, const std::string& sweep_file,
                               const std::filesystem::path& trace_dir,
                               const std::optional<std::filesystem::path>& from,
                               const std::optional<OverheadModel>& overheads,
                               const std::optional<BandwidthModel>& bandwidth) {
  Validation v;
  v.sweep_file = sweep_file;
  if (sweep.contains("machine") && sweep["machine"].contains("load_average") &&
      !sweep["machine"]["load_average"].empty()) {
    v.machine_load = fmt::format("{:.2f}", sweep["machine"]["load_average"][0].get<double>());
  }
  std::vector<std::unique_ptr<Source>> sources;
  try {
    if (from) {
      sources.push_back(std::make_unique<Source>(load_source(*from)));
    } else {
      if (!std::filesystem::is_directory(trace_dir)) {
        throw std::invalid_argument(trace_dir.string() + ": not a directory");
      }
      for (const auto& entry : std::filesystem::directory_iterator(trace_dir)) {
        const std::string name = entry.path().filename().string();
        if (name.ends_with("-1t.cbtrace")) {
          sources.push_back(std::make_unique<Source>(load_source(entry.path())));
        }
      }
    }
  } catch (const std::exception& error) {  // unreadable file, bad header, inconsistent records
    throw std::invalid_argument(error.what());
  }
  if (sources.empty()) {
    throw std::invalid_argument(
        "--trace-dir: " + trace_dir.string() +
        " holds no 1-thread trace (*-1t.cbtrace; write them with `sweep --trace DIR`)");
  }
  // The traces of one sweep were written with the same --trace-overheads (or none).
  v.overheads = choose_overheads(overheads, sources.front()->workload);
  v.bandwidth = choose_bandwidth(bandwidth, sources.front()->workload);
  auto choose = [&](schedulers::IterationSpace space) -> Source* {
    Source* best = nullptr;
    for (const auto& s : sources) {
      if (s->workload.space != space) continue;
      if (best == nullptr || s->chunks > best->chunks) best = s.get();
    }
    return best;
  };
  // The finest trace of each space takes its loop times from the coarsest one of the same
  // space (take_loop_times: the tracing cost of its many chunks drops out).
  if (!from) {
    for (const schedulers::IterationSpace space :
         {schedulers::IterationSpace::blocks, schedulers::IterationSpace::active}) {
      Source* finest = choose(space);
      const Source* coarsest = nullptr;
      for (const auto& s : sources) {
        if (s->workload.space != space) continue;
        if (coarsest == nullptr || s->chunks < coarsest->chunks) coarsest = s.get();
      }
      if (finest == nullptr || coarsest == nullptr || coarsest->chunks >= finest->chunks) continue;
      try {
        take_loop_times(finest->workload, coarsest->workload, finest->file.filename().string(),
                        coarsest->file.filename().string());
      } catch (const std::invalid_argument& error) {
        v.notes.push_back(
            fmt::format("loop times not taken from a coarser trace: {}", error.what()));
      }
    }
  }
  for (const auto& row : sweep.at("rows")) {
    const nlohmann::json& t = row["time_seconds"];
    if (!t.is_object() || !t["median"].is_number()) continue;
    ValidationRow out;
    out.scheduler = row.value("scheduler_canonical", row.value("scheduler", std::string()));
    out.threads = row.value("threads", 1);
    out.measured_time = t["median"].get<double>();
    out.disturbed = row_disturbed(row);
    if (row.contains("core_round_trip_ns") && row["core_round_trip_ns"].is_object()) {
      out.round_trip_before_ns = row["core_round_trip_ns"].value("before", 0.0);
      out.round_trip_after_ns = row["core_round_trip_ns"].value("after", 0.0);
    }
    if (row.contains("accounting") && row["accounting"].is_object() &&
        row["accounting"]["imbalance_percent"].is_number()) {
      out.measured_imbalance_percent = row["accounting"]["imbalance_percent"].get<double>();
    }
    try {
      const Source* source = nullptr;
      const ScheduleModel probe = ScheduleModel::parse(out.scheduler, OmpRuntimeModel::libgomp);
      source = choose(probe.spec.space);
      if (source == nullptr) source = choose(schedulers::IterationSpace::blocks);
      if (source == nullptr) source = sources.front().get();
      const ScheduleModel model =
          ScheduleModel::parse(out.scheduler, runtime_model(source->workload.openmp_runtime));
      const PredictedRow p = predict_row(source->workload, model, out.threads,
                                         choose_overheads(overheads, source->workload),
                                         choose_bandwidth(bandwidth, source->workload));
      out.source = source->file.filename().string();
      if (!source->workload.loop_times_from.empty()) {
        out.source += " (loop times: " + source->workload.loop_times_from + ")";
      }
      out.predicted_time = p.time;
      out.predicted_imbalance_percent = p.imbalance_percent;
      out.error_percent = 100.0 * (p.time - out.measured_time) / out.measured_time;
      if (out.threads > 1 && !trace_dir.empty()) {
        // Against the same scheduler's 1-thread trace: the same chunks, so the same cost of
        // recording them.
        const std::string one = row_trace_file_name(out.scheduler, 1);
        const Source* base = nullptr;
        for (const auto& s : sources) {
          if (s->file.filename() == one) base = s.get();
        }
        const std::filesystem::path own =
            trace_dir / row_trace_file_name(out.scheduler, out.threads);
        if (base != nullptr && base->busy_seconds > 0.0 && std::filesystem::exists(own)) {
          try {
            const TraceWorkload w = build_workload(read_trace(own), own.string());
            out.work_ratio = w.busy_seconds / base->busy_seconds;
          } catch (const std::exception& error) {
            v.notes.push_back(fmt::format("{}: not read: {}", own.string(), error.what()));
          }
        }
      }
      out.bandwidth_bound_loops = p.bandwidth_bound_loops;
      out.bandwidth_added_seconds = p.bandwidth_added_seconds;
      v.rows.push_back(out);
    } catch (const std::invalid_argument& error) {
      v.skipped.push_back(fmt::format("{} x {}: {}", out.scheduler, out.threads, error.what()));
    }
  }
  return v;
}

std::string format_validation_markdown(const Validation& v) {
  std::ostringstream out;
  out << fmt::format("# Predicted vs measured: {}\n\n", v.sweep_file);
  out << fmt::format(
      "Sweep load average at its start: {}. Overheads: {}. Bandwidth ceiling: {}.\n\n",
      v.machine_load.empty() ? "not recorded" : v.machine_load, v.overheads.source,
      v.bandwidth.source);
  out << "| Scheduler | Threads | Predicted from | Predicted time [s] | Measured time [s] | "
         "Error [%] | Predicted imbalance [%] | Measured imbalance [%] | Measured timing | "
         "Work at P / 1 thread | Core round trip [ns] | Bandwidth-bound loops | Bandwidth added "
         "[s] |\n";
  out << "|:--|--:|:--|--:|--:|--:|--:|--:|:--|--:|--:|--:|--:|\n";
  double sum = 0.0, worst = 0.0;
  for (const ValidationRow& r : v.rows) {
    out << fmt::format(
        "| {} | {} | {} | {:.3f} | {:.3f} | {:+.1f} | {:.1f} | {} | {} | {} | {} | {} | {:.4f} "
        "|\n",
        r.scheduler, r.threads, r.source, r.predicted_time, r.measured_time, r.error_percent,
        r.predicted_imbalance_percent,
        r.measured_imbalance_percent ? fmt::format("{:.1f}", *r.measured_imbalance_percent)
                                     : std::string("-"),
        r.disturbed ? "DISTURBED" : "clean",
        r.work_ratio ? fmt::format("{:.2f}", *r.work_ratio) : std::string("-"),
        r.round_trip_before_ns > 0.0
            ? fmt::format("{:.0f} / {:.0f}", r.round_trip_before_ns, r.round_trip_after_ns)
            : std::string("-"),
        r.bandwidth_bound_loops, r.bandwidth_added_seconds);
    sum += std::abs(r.error_percent);
    worst = std::max(worst, std::abs(r.error_percent));
  }
  if (!v.rows.empty()) {
    out << fmt::format("\n{} rows: mean |error| {:.1f} %, largest {:.1f} %.\n", v.rows.size(),
                       sum / static_cast<double>(v.rows.size()), worst);
  }
  std::vector<std::string> inflated;
  for (const ValidationRow& r : v.rows) {
    if (r.work_ratio && *r.work_ratio > 1.1) {
      inflated.push_back(fmt::format("{} x {} ({:.2f})", r.scheduler, r.threads, *r.work_ratio));
    }
  }
  if (!inflated.empty()) {
    out << "Work at P / 1 thread: the busy time of the row's own P-thread trace (all threads' "
           "chunks) over its 1-thread trace's. Above 1.1 the loops themselves ran slower split "
           "over the threads (shared caches or core, cache lines moving between threads), which "
           "a replay of 1-thread costs does not model: ";
    out << fmt::format("{}.\n", fmt::join(inflated, ", "));
  }
  double nearest = 0.0, farthest = 0.0;
  for (const ValidationRow& r : v.rows) {
    for (const double t : {r.round_trip_before_ns, r.round_trip_after_ns}) {
      if (t <= 0.0) continue;
      nearest = nearest > 0.0 ? std::min(nearest, t) : t;
      farthest = std::max(farthest, t);
    }
  }
  // Rows whose cores sat elsewhere than while the overheads were measured.
  std::vector<std::string> elsewhere;
  for (const ValidationRow& r : v.rows) {
    const double row_ns = 0.5 * (r.round_trip_before_ns + r.round_trip_after_ns);
    if (r.round_trip_before_ns <= 0.0 || r.round_trip_after_ns <= 0.0) continue;
    const auto dispatch = v.overheads.dispatch_round_trip_ns.find(r.scheduler);
    const double dispatch_ns =
        dispatch == v.overheads.dispatch_round_trip_ns.end() ? 0.0 : dispatch->second;
    const bool loop_elsewhere = round_trip_changed(v.overheads.round_trip_ns, row_ns);
    const bool chunk_elsewhere = round_trip_changed(dispatch_ns, row_ns);
    if (loop_elsewhere || chunk_elsewhere) {
      std::string costs;
      if (loop_elsewhere)
        costs = fmt::format("per-loop cost at {:.0f} ns", v.overheads.round_trip_ns);
      if (chunk_elsewhere) {
        costs +=
            fmt::format("{}per-chunk cost at {:.0f} ns", costs.empty() ? "" : ", ", dispatch_ns);
      }
      elsewhere.push_back(
          fmt::format("{} x {} at {:.0f} ns ({})", r.scheduler, r.threads, row_ns, costs));
    }
  }
  if (!elsewhere.empty()) {
    out << "Core placement: these rows ran with their cores more than twice as far apart, or "
           "less than half as far, as when the overheads they are predicted with were measured "
           "(the micro-benchmark's own round trip), so those costs come from another placement: ";
    out << fmt::format("{}.\n", fmt::join(elsewhere, ", "));
  }
  if (round_trip_changed(nearest, farthest)) {
    out << fmt::format(
        "Core round trip: the cache-line round trip between the cores went from {:.0f} to {:.0f} "
        "ns within this sweep: the host moved the threads' cores nearer or farther apart, which "
        "changes what sharing a loop costs; rows measured at different round trips are not "
        "comparable, and neither is a row with one of a model measured at the other.\n",
        nearest, farthest);
  }
  for (const std::string& s : v.skipped) out << "Not predicted: " << s << "\n";
  for (const std::string& s : v.notes) out << "Note: " << s << "\n";
  return out.str();
}

nlohmann::json validation_json(const Validation& v) {
  nlohmann::json rows = nlohmann::json::array();
  for (const ValidationRow& r : v.rows) {
    rows.push_back({{"scheduler", r.scheduler},
                    {"threads", r.threads},
                    {"predicted_from", r.source},
                    {"predicted_time_seconds", r.predicted_time},
                    {"measured_time_seconds", r.measured_time},
                    {"error_percent", r.error_percent},
                    {"predicted_imbalance_percent", r.predicted_imbalance_percent},
                    {"measured_disturbed", r.disturbed},
                    {"bandwidth_bound_loops", r.bandwidth_bound_loops},
                    {"work_ratio", r.work_ratio ? nlohmann::json(*r.work_ratio) : nlohmann::json()},
                    {"core_round_trip_ns",
                     {{"before", r.round_trip_before_ns}, {"after", r.round_trip_after_ns}}},
                    {"bandwidth_added_seconds", r.bandwidth_added_seconds},
                    {"measured_imbalance_percent",
                     r.measured_imbalance_percent ? nlohmann::json(*r.measured_imbalance_percent)
                                                  : nlohmann::json()}});
  }
  return {{"schema", "clothbench-prediction-validation"},
          {"schema_version", 3},
          {"sweep", v.sweep_file},
          {"machine_load", v.machine_load},
          {"overheads", v.overheads.source},
          {"bandwidth", v.bandwidth.source},
          {"rows", rows},
          {"skipped", v.skipped},
          {"notes", v.notes}};
}

}  // namespace clothbench::harness
