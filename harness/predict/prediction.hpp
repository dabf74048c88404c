// The schedule predictor's Table 2 and Fig. 12 (issue 17, "The predictor"): every loop of a
// trace replayed through each scheduler at each thread count (schedule_simulation.hpp), plus
// the trace's sequential time and the scheduling costs (overhead_model.hpp). The columns are
// the sweep's (harness/sweep/measured_run.hpp), summed over the loops:
//   sequential_overhead = the trace's time outside its loops
//   parallel_overhead   = loop wall - busiest thread's work (per-loop and dispatch costs,
//                         and a thread idle while the others still take chunks)
//   load_imbalance      = busiest thread's work - mean thread work
//   parallel_work       = mean thread work
// time = sequential_overhead + the loops' wall; speed-up against the same scheduler's
// predicted 1-thread time, efficiency = speed-up / P. Every row is a prediction; rows above
// the traced machine's cores are marked as beyond it.
//
// The bandwidth ceiling (bandwidth_model.hpp): a loop instance whose replayed time is below
// its bytes / B(P) takes bytes / B(P) instead, stretched as a whole (its threads' work and
// their waits grow by the same factor: memory slows every thread alike), so the added time
// falls on the same columns as the loop's own time did. Each row counts the bound instances
// and the time the ceiling added.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "harness/predict/bandwidth_model.hpp"
#include "harness/predict/overhead_model.hpp"
#include "harness/predict/schedule_simulation.hpp"
#include "harness/predict/trace_workload.hpp"
#include "harness/report/sweep_plots.hpp"

namespace clothbench::harness {

/// One predicted (scheduler, threads) row; seconds.
struct PredictedRow {
  std::string scheduler;  ///< canonical spec
  int threads = 1;
  bool beyond_cores = false;  ///< more threads than the traced machine's cores
  double time = 0.0;
  double sequential_overhead = 0.0;
  double parallel_overhead = 0.0;
  double load_imbalance = 0.0;
  double parallel_work = 0.0;
  double imbalance_percent = 0.0;  ///< 100 (busiest / mean - 1), as the sweep's
  double speedup = 0.0;
  double efficiency = 0.0;
  std::int64_t chunks = 0;
  double dispatch_seconds = 0.0;  ///< per chunk, as used
  double bandwidth = 0.0;         ///< B(threads) used, bytes per second (0: no ceiling)
  std::int64_t bandwidth_bound_loops = 0;  ///< loop instances the ceiling lengthened
  double bandwidth_added_seconds = 0.0;    ///< time the ceiling added to them
};

/// The model of the OpenMP runtime a trace ran on ("libomp" -> libomp, else libgomp).
OmpRuntimeModel runtime_model(const std::string& runtime_name);

/// Predicts one row: `model` at `threads` over `workload` with `overheads` and the ceiling of
/// `bandwidth` (none when it measured nothing). Throws std::invalid_argument when the trace
/// cannot feed the model's iteration space (a trace over the Active-Lists holds no block
/// costs).
PredictedRow predict_row(const TraceWorkload& workload, const ScheduleModel& model, int threads,
                         const OverheadModel& overheads, const BandwidthModel& bandwidth = {});

/// A whole prediction: the rows by scheduler then threads, and what they rest on.
struct Prediction {
  std::string trace_file;
  const TraceWorkload* workload = nullptr;  ///< not owned
  OverheadModel overheads;
  BandwidthModel bandwidth;
  double sequential_share = 0.0;       ///< s = sequential / (sequential + busy) of the trace
  std::optional<double> amdahl_limit;  ///< 1 / s (none when s = 0)
  std::vector<PredictedRow> rows;
  std::vector<std::string> notes;
};

/// Predicts every scheduler x thread count (speed-ups against a 1-thread prediction, made
/// when 1 is not among `threads`).
Prediction predict(const TraceWorkload& workload, const std::string& trace_file,
                   const std::vector<std::string>& schedulers, const std::vector<int>& threads,
                   const OverheadModel& overheads, const BandwidthModel& bandwidth = {});

/// Markdown: what the prediction rests on, then one Table 2 per scheduler.
std::string format_prediction_markdown(const Prediction& prediction);
/// The same as JSON (schema "clothbench-prediction", version 2: version 1 had no bandwidth).
nlohmann::json prediction_json(const Prediction& prediction);
/// Writes prediction.json, table.md and the predicted Fig. 12 (fig12.{dat,gp,png}: time and
/// speed-up against threads, with Amdahl's limit) into `dir`.
PlotOutcome write_prediction_outputs(const Prediction& prediction,
                                     const std::filesystem::path& dir);

}  // namespace clothbench::harness
